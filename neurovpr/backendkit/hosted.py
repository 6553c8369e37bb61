"""A Simulation base for backends that run neurovpr's expanded connections and read spikes back as rasters.

Such a backend (``nengo``, ``lava`` here) builds its simulator from
:func:`~neurovpr.ir.connectivity.expand`'s connections and the current weights, feeds it
the host-drawn spikes of :class:`~.sources.SourceState`, and hands back per-step spike
rasters and voltages. :class:`HostedSimulation` keeps everything else: the expanded
connections and weights, the sources, the spike record and activity counts, voltage
traces, and the ``Simulation`` hooks that read them. A subclass implements building
(:meth:`HostedSimulation._build`, called again when weights change), running, resetting
its simulator and recording.
"""

from __future__ import annotations

from abc import abstractmethod
from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

import numpy as np

from neurovpr.errors import SimulationError, UnsupportedFeatureError
from neurovpr.ir.connectivity import expand
from neurovpr.ir.connectors import ConvolutionConnector
from neurovpr.ir.network import Network
from neurovpr.runtime.backend import unsupported_error
from neurovpr.runtime.simulation import Simulation

from .readout import SpikeRecord
from .sources import SourceState

if TYPE_CHECKING:
    from neurovpr.hardware.check import HardwareTarget

__all__ = ["HostedSimulation"]


class HostedSimulation(Simulation):
    """A network whose connections, sources and read-out neurovpr keeps on the host.

    Parameters
    ----------
    network, backend, dt, seed, hardware
        As for :class:`~neurovpr.runtime.simulation.Simulation`.

    Attributes
    ----------
    _conns
        Expanded connections per projection (canonical order).
    _values
        Current weights per projection (canonical order).
    _sources
        :class:`~.sources.SourceState` per spike-source population.
    _record
        The :class:`~.readout.SpikeRecord`.
    _voltages
        Per population recording ``v``: the recorded ``(steps, size)`` blocks in mV.
    _steps
        Steps since the last reset.
    """

    def __init__(
        self, network: Network, *, backend: str, dt: float, seed: int, hardware: HardwareTarget | None = None
    ) -> None:
        super().__init__(network, backend=backend, dt=dt, seed=seed, hardware=hardware)
        net = self._network
        self._conns = {name: expand(net, proj, dt=dt, seed=seed) for name, proj in net.projections.items()}
        self._values = {name: conns.weight.copy() for name, conns in self._conns.items()}
        self._sources = {name: SourceState(pop, dt=dt, seed=seed) for name, pop in net.populations.items() if pop.is_source}
        self._neuron_pops = [name for name, pop in net.populations.items() if not pop.is_source]
        self._record = SpikeRecord(net, self._conns, dt=dt)
        self._voltages: dict[str, list[np.ndarray]] = {}
        self._steps = 0
        self._run_ns = 0
        self._build_ns = 0

    def _refuse(self, problems: list[str]) -> None:
        """Raise the backend's refusal naming the first of ``problems`` (nothing when empty)."""
        error = unsupported_error(self._backend, problems)
        if error is not None:
            raise error

    @abstractmethod
    def _build(self) -> None:
        """(Re)build the simulator from ``_conns``, ``_values`` and the recording."""

    def _clear_records(self) -> None:
        self._record.clear()
        self._voltages = {name: [] for name, var in self._recording if var == "v"}

    # -- Simulation hooks ----------------------------------------------------------
    @property
    def time(self) -> float:
        """Simulated time since the last reset (ms)."""
        return self._steps * self._dt

    def _set_input(self, population: str, value: Any) -> None:
        self._sources[population].set(value)

    def _set_plasticity(self, on: bool) -> None:
        """Nothing learns here (plastic synapses are refused at compile)."""

    def _spike_counts(self, population: str) -> np.ndarray:
        return self._record.counts(population)

    def _spike_trains(self, population: str) -> tuple[np.ndarray, np.ndarray]:
        return self._record.trains(population)

    def _trace(self, population: str, variable: str) -> tuple[np.ndarray, np.ndarray]:
        neurons = self._recording[(population, variable)]
        parts = self._voltages.get(population, [])
        values = np.concatenate(parts) if parts else np.zeros((0, self._network.populations[population].size))
        start = self._steps - values.shape[0]
        times = (start + np.arange(values.shape[0]) + 1) * self._dt
        return times, values[:, neurons]

    def _connections(self, projection: str) -> tuple[np.ndarray, np.ndarray]:
        conns = self._conns[projection]
        return conns.pre, conns.post

    def _weights(self, projection: str) -> np.ndarray:
        return self._values[projection].copy()

    def _set_weights(self, projection: str, values: np.ndarray) -> None:
        if isinstance(self._network.projections[projection].connector, ConvolutionConnector):
            raise UnsupportedFeatureError(
                f"set_weights: projection {projection!r} is convolutional; its shared kernel is fixed at compile."
            )
        if self._steps:
            raise SimulationError(
                f"set_weights: backend {self._backend!r} rebuilds its simulator to change weights; "
                f"call reset() before setting the weights of {projection!r}."
            )
        self._values[projection] = values
        self._build()

    def _learned_state(self, population: str) -> dict[str, np.ndarray]:
        return {}

    def _statistics(self) -> Mapping[str, int]:
        stats = dict(self._record.stats)
        stats["run_wall_ns"] = self._run_ns
        stats["build_wall_ns"] = self._build_ns
        return stats
