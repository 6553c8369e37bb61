"""The spinnaker backend: sPyNNaker's own mapping on a virtual SpiNN-5 board.

The network is translated to sPyNNaker's PyNN models (``IF_curr_exp``, ``IF_cond_exp``,
``IF_curr_exp_ca2_adaptive`` as ``extra_models.IFCurrExpCa2Adaptive``, Poisson and
array sources, ``StaticSynapse`` and ``STDPMechanism``) with the canonical connections
and mapped by sPyNNaker's partitioner, placer and router onto a virtual board. It
reports what sPyNNaker says the network uses (``Simulation.mapping()``, or
:func:`neurovpr.backends.spinnaker.mapping.map_network` directly) and refuses to run:
spikes need a board. Importing this package does not import sPyNNaker.

Option of :func:`neurovpr.compile`: ``n_boards`` (default 1), the SpiNN-5 boards
sPyNNaker may use.
"""

from __future__ import annotations

from types import MappingProxyType
from typing import Any

from neurovpr.hardware.check import HardwareTarget
from neurovpr.ir.network import Network
from neurovpr.runtime.backend import Backend
from neurovpr.runtime.simulation import Simulation

from .capabilities import CAPABILITIES
from .mapping import silenced
from .simulation import SpiNNakerSimulation

__all__ = ["SpiNNakerBackend", "BACKEND"]


class SpiNNakerBackend(Backend):
    """Declaration of the ``spinnaker`` backend."""

    name = "spinnaker"
    description = "sPyNNaker's partitioning, placement and routing on a virtual SpiNN-5 board (no spikes)"
    requires = ("spynnaker.pyNN",)
    version_of = "sPyNNaker"
    extra = "spinnaker"
    capabilities = CAPABILITIES
    options = MappingProxyType({"n_boards": 1})

    def unavailable_reason(self) -> str | None:
        """``None`` when sPyNNaker imports (its import output silenced)."""
        with silenced():
            return super().unavailable_reason()

    def _compile(
        self, network: Network, *, dt: float, seed: int, hardware: HardwareTarget | None, **options: Any
    ) -> Simulation:
        return SpiNNakerSimulation(network, dt=dt, seed=seed, n_boards=options["n_boards"])


BACKEND = SpiNNakerBackend()
