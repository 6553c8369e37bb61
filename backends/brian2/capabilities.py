"""What the brian2 backend can run."""

from __future__ import annotations

from neurovpr.backendkit.capabilities import (
    EVERY_CONNECTOR,
    EVERY_RECORDABLE,
    EVERY_SYNAPSE,
    SPIKE_SOURCES,
    SPIKING_NEURONS,
)
from neurovpr.runtime.backend import Capabilities

CAPABILITIES = Capabilities(
    cell_types=SPIKING_NEURONS | SPIKE_SOURCES,
    connectors=EVERY_CONNECTOR,
    synapses=EVERY_SYNAPSE,
    learns=True,
    heterogeneous_delays=True,
    zero_delays=True,  # between neurons (Brian2's zero delay); from a spike source they are refused when built
    euler_integration=True,  # Brian2's method='euler'
    recordables=EVERY_RECORDABLE,
)
