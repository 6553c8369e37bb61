"""What the reference backend can run."""

from __future__ import annotations

from types import MappingProxyType

from neurovpr.runtime.backend import Capabilities

#: Hwspec names whose number formats the backend emulates, and the arithmetic used for each
#: (backends/reference/fixed_point.py; docs/number_formats.md): Loihi 1 as NengoLoihi's emulator
#: computes it, Loihi 2 as Lava's bit-accurate process models do, SpiNNaker as sPyNNaker's LIF.
EMULATED_HARDWARE = MappingProxyType({"kapoho-bay": "loihi1", "loihi2": "loihi2", "spinn5": "spinnaker"})
#: State variables recorded in each emulated arithmetic.
RECORDABLE_ON_HARDWARE = MappingProxyType(
    {
        "loihi1": frozenset({"v"}),
        "loihi2": frozenset({"v"}),
        "spinnaker": frozenset({"v", "isyn_exc", "isyn_inh", "gsyn_exc", "gsyn_inh", "i_ca2"}),
    }
)

CAPABILITIES = Capabilities(
    cell_types=frozenset(
        {
            "IF_curr_exp",
            "IF_cond_exp",
            "IF_cond_exp_adaptive",
            "IF_curr_exp_ca2_adaptive",
            "SpikeSourcePoisson",
            "SpikeSourceArray",
        }
    ),
    connectors=frozenset(
        {
            "AllToAllConnector",
            "OneToOneConnector",
            "FixedProbabilityConnector",
            "FixedNumberPreConnector",
            "FromListConnector",
            "ConvolutionConnector",
        }
    ),
    synapses=frozenset({"StaticSynapse", "STDPMechanism", "DiehlCookSTDP"}),
    learns=True,
    heterogeneous_delays=True,
    hardware=frozenset(EMULATED_HARDWARE),
    recordables=frozenset({"v", "isyn_exc", "isyn_inh", "gsyn_exc", "gsyn_inh", "theta", "i_ca2"}),
    unsupported=MappingProxyType({}),
)
