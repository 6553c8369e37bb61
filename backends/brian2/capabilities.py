"""What the brian2 backend can run."""

from __future__ import annotations

from types import MappingProxyType

from neurovpr.runtime.backend import Capabilities

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
    recordables=frozenset({"v", "isyn_exc", "isyn_inh", "gsyn_exc", "gsyn_inh", "theta", "i_ca2"}),
    unsupported=MappingProxyType({}),
)
