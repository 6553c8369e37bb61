"""What the reference backend can run."""

from __future__ import annotations

from types import MappingProxyType

from neurovpr.backendkit.capabilities import (
    EVERY_CONNECTOR,
    EVERY_RECORDABLE,
    EVERY_SYNAPSE,
    SPIKE_SOURCES,
    SPIKING_NEURONS,
)
from neurovpr.runtime.backend import Capabilities

#: The chip arithmetics the backend emulates (a hwspec's ``[formats].arithmetic``), with the state
#: variables recorded in each (backends/reference/fixed_point.py; docs/number_formats.md): Loihi 1
#: as NengoLoihi's emulator computes it, Loihi 2 as Lava's bit-accurate process models do,
#: SpiNNaker as sPyNNaker's LIF, Xylo
#: Audio 2 as XyloSim's C++ model (backends/reference/xylo.py), Speck as Sinabs's discretised
#: DYNAP-CNN layers (backends/reference/speck.py).
RECORDABLE_ON_HARDWARE = MappingProxyType(
    {
        "loihi1": frozenset({"v"}),
        "loihi2": frozenset({"v"}),
        "spinnaker": frozenset({"v", "isyn_exc", "isyn_inh", "gsyn_exc", "gsyn_inh", "i_ca2"}),
        "xylo": frozenset({"v"}),
        "speck": frozenset({"v"}),
    }
)

CAPABILITIES = Capabilities(
    cell_types=SPIKING_NEURONS | SPIKE_SOURCES,
    connectors=EVERY_CONNECTOR,
    synapses=EVERY_SYNAPSE,
    learns=True,
    heterogeneous_delays=True,
    zero_delays=True,  # in floating point; the chip arithmetics refuse them (see the backend's _compile)
    euler_integration=True,  # in floating point, as zero delays
    arithmetic=frozenset(RECORDABLE_ON_HARDWARE),
    recordables=EVERY_RECORDABLE,
)
