"""What the ``speck`` backend (Sinabs's simulation of DYNAP-CNN layers) can run, and which conformance cases it cannot."""

from __future__ import annotations

from types import MappingProxyType

from neurovpr.backendkit.capabilities import SPIKE_SOURCES, STATIC_SYNAPSE
from neurovpr.conformance.cases import CASES
from neurovpr.runtime.backend import Capabilities

__all__ = ["CAPABILITIES", "CHIP_UNITS"]

CHIP_UNITS = (
    "Speck's neurons are non-leaky integrate-and-fire layers fed by one convolution or dense projection each, "
    "computed in Sinabs's integers at 1 ms steps (reset by subtracting the threshold, no refractory period, no "
    "synaptic current, no delays), where the conformance cases check PyNN's leaky float semantics against closed forms"
)

_REASONS = {
    "poisson": "the case runs at dt 0.1 ms; Speck's layers run at its hwspec's 1 ms step ([timing].time_step_ms)",
    "determinism": "the case feeds leaky neurons through a FixedProbabilityConnector, which no Speck layer holds",
}

CAPABILITIES = Capabilities(
    cell_types=frozenset({"IF_curr_exp"}) | SPIKE_SOURCES,
    connectors=frozenset({"AllToAllConnector", "ConvolutionConnector"}),
    synapses=STATIC_SYNAPSE,
    learns=False,
    heterogeneous_delays=False,
    arithmetic=frozenset({"speck"}),
    recordables=frozenset(),
    reasons=MappingProxyType(
        {
            "IF_cond_exp": "Speck's neurons are current-based integrate-and-fire",
            "FixedProbabilityConnector": "a Speck layer is a convolution or a dense layer",
            "OneToOneConnector": "a Speck layer is a convolution or a dense layer",
        }
    ),
    unsupported=MappingProxyType({case: _REASONS.get(case, CHIP_UNITS) for case in CASES}),
)
