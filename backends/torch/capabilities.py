"""What the ``torch`` backend can run, and why not the rest.

It runs inference: every spiking cell type but with learning off (static synapses;
adaptive thresholds held at their learned ``theta``), every connector, heterogeneous
delays, Poisson and array sources. Plastic synapses are refused at compile; a network
trained elsewhere runs here with its plastic projections made static.
"""

from __future__ import annotations

from types import MappingProxyType

from neurovpr.backendkit.capabilities import (
    EVERY_CONNECTOR,
    EVERY_RECORDABLE,
    SPIKE_SOURCES,
    SPIKING_NEURONS,
    STATIC_SYNAPSE,
)
from neurovpr.runtime.backend import Capabilities

__all__ = ["CAPABILITIES", "LEARNING_REFUSAL"]

#: Why the backend does not learn (the refusal of plastic synapses and of ``plasticity(True)``).
LEARNING_REFUSAL = (
    "the torch backend runs inference over a batch of independent items (plasticity off): weights and adaptive "
    "thresholds are fixed; train on the reference backend and evaluate here"
)

_PLASTIC = {"STDPMechanism": LEARNING_REFUSAL, "DiehlCookSTDP": LEARNING_REFUSAL}

#: Conformance cases (neurovpr.conformance) the backend cannot run, with the reason.
_UNSUPPORTED = {
    "theta_adaptation": "adaptive thresholds are learned state; the torch backend holds theta fixed (" + LEARNING_REFUSAL + ")",
    "plasticity_off": LEARNING_REFUSAL,
    "euler_theta": "adaptive thresholds are learned state; the torch backend holds theta fixed (" + LEARNING_REFUSAL + ")",
}

CAPABILITIES = Capabilities(
    cell_types=SPIKING_NEURONS | SPIKE_SOURCES,
    connectors=EVERY_CONNECTOR,
    synapses=STATIC_SYNAPSE,
    learns=False,
    heterogeneous_delays=True,
    zero_delays=True,
    euler_integration=True,
    recordables=EVERY_RECORDABLE,
    reasons=MappingProxyType(_PLASTIC),
    unsupported=MappingProxyType(_UNSUPPORTED),
)
