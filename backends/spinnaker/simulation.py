"""A network mapped onto a virtual SpiNN-5 board: resources from sPyNNaker, no spikes.

``run()`` raises :class:`~neurovpr.errors.SimulationError` with
:data:`.capabilities.RUN_REFUSAL`: producing spikes needs a SpiNNaker board. The
simulation still answers what does not need one: :meth:`SpiNNakerSimulation.mapping`
(sPyNNaker's partitioning and placement), the canonical connections and weights, and
an empty activity record (time stays 0).
"""

from __future__ import annotations

import copy
from typing import Any

import numpy as np

from neurovpr.errors import SimulationError
from neurovpr.ir.connectivity import expand
from neurovpr.ir.network import Network
from neurovpr.runtime.simulation import Simulation

from .capabilities import RUN_REFUSAL
from .mapping import map_network

__all__ = ["SpiNNakerSimulation"]


class SpiNNakerSimulation(Simulation):
    """A network mapped by sPyNNaker onto ``n_boards`` virtual SpiNN-5 boards.

    Parameters
    ----------
    network, dt, seed
        As for :func:`neurovpr.compile`.
    n_boards
        SpiNN-5 boards sPyNNaker may use.
    """

    def __init__(self, network: Network, *, dt: float, seed: int, n_boards: int = 1) -> None:
        super().__init__(network, backend="spinnaker", dt=dt, seed=seed)
        self._mapping = map_network(self._network, dt=dt, seed=seed, n_boards=n_boards)
        self._conns = {name: expand(self._network, name, dt=dt, seed=seed) for name in self._network.projections}
        self._weight_values = {name: c.weight.copy() for name, c in self._conns.items()}

    def mapping(self) -> dict[str, Any]:
        """What sPyNNaker says the network uses (see :func:`.mapping.map_network`)."""
        return copy.deepcopy(self._mapping)

    @property
    def time(self) -> float:
        """Always 0: nothing runs without a board."""
        return 0.0

    def _set_input(self, population: str, value: Any) -> None:
        """Inputs are checked by :meth:`Simulation.run`, which then refuses to run."""

    def _run(self, n_steps: int) -> None:
        raise SimulationError(RUN_REFUSAL)

    def _reset(self) -> None:
        """Nothing has run, so there is nothing to reset."""

    def _set_plasticity(self, on: bool) -> None:
        """Recorded by :class:`Simulation`; it would apply on a board."""

    def _set_recording(self, population: str, variable: str, neurons: np.ndarray) -> None:
        raise SimulationError(f"record: {RUN_REFUSAL}")

    def _spike_counts(self, population: str) -> np.ndarray:
        return np.zeros(self._network.populations[population].size, dtype=np.int64)

    def _spike_trains(self, population: str) -> tuple[np.ndarray, np.ndarray]:
        return np.zeros(0), np.zeros(0, dtype=np.int64)

    def _trace(self, population: str, variable: str) -> tuple[np.ndarray, np.ndarray]:
        raise SimulationError(f"trace: {RUN_REFUSAL}")

    def _connections(self, projection: str) -> tuple[np.ndarray, np.ndarray]:
        conns = self._conns[projection]
        return conns.pre, conns.post

    def _weights(self, projection: str) -> np.ndarray:
        return self._weight_values[projection].copy()

    def _set_weights(self, projection: str, values: np.ndarray) -> None:
        self._weight_values[projection] = values.copy()

    def _learned_state(self, population: str) -> dict[str, np.ndarray]:
        return {}
