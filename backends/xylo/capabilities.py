"""What the ``xylo`` backend (Rockpool's XyloSim) can run, and which conformance cases it cannot."""

from __future__ import annotations

from types import MappingProxyType

from neurovpr.conformance.cases import CASES
from neurovpr.runtime.backend import Capabilities

__all__ = ["CAPABILITIES", "CHIP_UNITS"]

CHIP_UNITS = (
    "XyloSim computes in Xylo's integer chip units at 1 ms steps (bit-shift decays, reset by subtracting the "
    "threshold, no refractory period, no delays), where the conformance cases check PyNN's float semantics "
    "against closed forms"
)

_REASONS = {
    "poisson": "Xylo's inputs are spike rasters; neurovpr feeds XyloSim explicit spike arrays only",
    "determinism": "needs Poisson sources, which the backend does not feed to XyloSim",
}

CAPABILITIES = Capabilities(
    cell_types=frozenset({"IF_curr_exp", "SpikeSourceArray"}),
    connectors=frozenset({"AllToAllConnector", "OneToOneConnector", "FixedProbabilityConnector",
                          "FixedNumberPreConnector", "FromListConnector", "ConvolutionConnector"}),
    synapses=frozenset({"StaticSynapse"}),
    learns=False,
    heterogeneous_delays=False,
    arithmetic=frozenset({"xylo"}),
    recordables=frozenset({"v"}),
    reasons=MappingProxyType({
        "SpikeSourcePoisson": "Xylo's inputs are spike rasters: give explicit spike arrays",
        "IF_cond_exp": "Xylo's neurons are current-based",
    }),
    unsupported=MappingProxyType({case: _REASONS.get(case, CHIP_UNITS) for case in CASES}),
)
