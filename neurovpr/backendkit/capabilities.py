"""Building blocks of a backend's capability declaration: the IR's type names by family.

Derived from the IR's own type tables, so a backend that runs "every connector" keeps
doing so when the IR gains one, and no backend spells the lists out again::

    CAPABILITIES = Capabilities(
        cell_types=SPIKING_NEURONS | SPIKE_SOURCES,
        connectors=EVERY_CONNECTOR,
        synapses=EVERY_SYNAPSE,
        learns=True,
        recordables=EVERY_RECORDABLE,
    )
"""

from __future__ import annotations

from types import MappingProxyType

from neurovpr.ir.cells import CELL_TYPES, NeuronType, SourceType
from neurovpr.ir.connectors import CONNECTORS
from neurovpr.ir.synapses import SYNAPSE_TYPES, Synapse
from neurovpr.runtime.backend import ZERO_DELAY, Capabilities

__all__ = [
    "EVERY_CONNECTOR",
    "SPIKING_NEURONS",
    "SPIKE_SOURCES",
    "CURRENT_LIF",
    "EVERY_SYNAPSE",
    "STATIC_SYNAPSE",
    "EVERY_RECORDABLE",
    "CURRENT_LIF_INFERENCE",
]

#: Every connector of the IR.
EVERY_CONNECTOR = frozenset(CONNECTORS)
#: The spiking neuron models (every cell type but the spike sources and the rate-based ``SoftLIF``).
SPIKING_NEURONS = frozenset(name for name, cls in CELL_TYPES.items() if issubclass(cls, NeuronType))
#: The spike sources (``SpikeSourcePoisson``, ``SpikeSourceArray``).
SPIKE_SOURCES = frozenset(name for name, cls in CELL_TYPES.items() if issubclass(cls, SourceType))
#: ``IF_curr_exp`` and the spike sources: what backends computing in normalised compartments run
#: (:mod:`neurovpr.backendkit.lif`).
CURRENT_LIF = frozenset({"IF_curr_exp"}) | SPIKE_SOURCES
#: Every synapse type, static and plastic.
EVERY_SYNAPSE = frozenset(name for name, cls in SYNAPSE_TYPES.items() if issubclass(cls, Synapse))
#: Fixed weights only (inference backends).
STATIC_SYNAPSE = frozenset({"StaticSynapse"})
#: Every state variable a spiking neuron model records.
EVERY_RECORDABLE = frozenset(var for name in SPIKING_NEURONS for var in CELL_TYPES[name].recordable)

#: The preset of the backends that run the inference subset in normalised compartments (Nengo,
#: NengoLoihi, Lava): ``IF_curr_exp`` and the spike sources, every connector, fixed weights, delays
#: per synapse, ``v`` recorded. A backend adds its own ``unsupported``/``tolerances``/``arithmetic``
#: with :func:`dataclasses.replace`.
CURRENT_LIF_INFERENCE = Capabilities(
    cell_types=CURRENT_LIF,
    connectors=EVERY_CONNECTOR,
    synapses=STATIC_SYNAPSE,
    learns=False,
    heterogeneous_delays=True,
    recordables=frozenset({"v"}),
    reasons=MappingProxyType({ZERO_DELAY: "its synaptic delays start at one time step (a zero delay is not built)"}),
)
