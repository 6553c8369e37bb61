"""What the spinnaker backend can map onto a SpiNN-5 board (it does not run networks)."""

from __future__ import annotations

from types import MappingProxyType

from neurovpr.backendkit.capabilities import EVERY_CONNECTOR
from neurovpr.backendkit.pynn_names import SPYNNAKER_CELL_TYPES
from neurovpr.runtime.backend import Capabilities

__all__ = ["CAPABILITIES", "RUN_REFUSAL", "REASONS"]

#: The sentence ``Simulation.run`` raises.
RUN_REFUSAL = (
    "The spinnaker backend maps networks onto a virtual SpiNN-5 board; producing spikes needs a SpiNNaker "
    "board, which is not attached."
)

#: Why sPyNNaker cannot take an IR type.
REASONS = MappingProxyType(
    {
        "IF_cond_exp_adaptive": "sPyNNaker has no neuron model with Diehl & Cook's adaptive threshold (theta)",
        "DiehlCookSTDP": "sPyNNaker has no timing or weight dependence for Diehl & Cook's rule",
        "SoftLIF": "it is a rate approximation used only for training",
        "zero delay": "sPyNNaker's synapses take at least one time step",
        "euler integration": "sPyNNaker's neuron models integrate in their own fixed-point form, which cannot be chosen",
    }
)

CAPABILITIES = Capabilities(
    cell_types=frozenset(SPYNNAKER_CELL_TYPES),
    connectors=EVERY_CONNECTOR,
    synapses=frozenset({"StaticSynapse", "STDPMechanism"}),
    learns=True,
    runs=False,
    run_refusal=RUN_REFUSAL,
    heterogeneous_delays=True,
    recordables=frozenset(),
    reasons=REASONS,
)
