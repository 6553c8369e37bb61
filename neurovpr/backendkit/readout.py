"""Spike counts, spike trains and activity counts, filled from per-step spike rasters.

Activity is counted as the reference backend defines it (``Simulation.statistics()``):
steps, neuron updates (steps x neurons that are not sources), spikes of every population,
and synaptic events (each spike times its neuron's number of outgoing connections).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from neurovpr.ir.connectivity import Connections
from neurovpr.ir.network import Network

__all__ = ["SpikeRecord", "ACTIVITY_COUNTS", "spike_trains"]

#: The activity counts every backend reports, in ``Simulation.statistics()`` order.
ACTIVITY_COUNTS = ("steps", "neuron_updates", "spikes", "synaptic_events", "plastic_updates")


def spike_trains(parts: list[tuple[np.ndarray, np.ndarray]]) -> tuple[np.ndarray, np.ndarray]:
    """Join ``(times, neurons)`` pieces into one train sorted by time, then neuron."""
    if not parts:
        return np.zeros(0), np.zeros(0, dtype=np.int64)
    times = np.concatenate([p[0] for p in parts])
    idx = np.concatenate([p[1] for p in parts])
    order = np.lexsort((idx, times))
    return times[order], idx[order]


class SpikeRecord:
    """What a network emitted since the last reset, and its activity since compile.

    Parameters
    ----------
    network
        The compiled network.
    connections
        Its expanded projections (for the out-degree of every neuron).
    dt
        Time step (ms).
    """

    def __init__(self, network: Network, connections: Mapping[str, Connections], *, dt: float) -> None:
        self._dt = dt
        self._sizes = {name: pop.size for name, pop in network.populations.items()}
        self._n_neurons = sum(pop.size for pop in network.populations.values() if not pop.is_source)
        self._out_degree = {name: np.zeros(n, dtype=np.int64) for name, n in self._sizes.items()}
        for name, proj in network.projections.items():
            self._out_degree[proj.pre] += np.bincount(connections[name].pre, minlength=self._sizes[proj.pre])
        self.stats = dict.fromkeys(ACTIVITY_COUNTS, 0)
        self.clear()

    def clear(self) -> None:
        """Forget the spikes (a reset); the activity counts keep growing."""
        self._counts = {name: np.zeros(n, dtype=np.int64) for name, n in self._sizes.items()}
        self._trains: dict[str, list[tuple[np.ndarray, np.ndarray]]] = {name: [] for name in self._sizes}

    def add(self, population: str, raster: np.ndarray, first: int, *, source: bool) -> None:
        """Record a ``(n_steps, size)`` raster of steps ``first, first + 1, ...``.

        A source spike of step ``j`` is stamped ``j dt`` (the start of its step), a neuron
        spike ``(j + 1) dt`` (the end of the step it was computed in).
        """
        rows, idx = np.nonzero(raster)
        times = (first + rows + (0 if source else 1)) * self._dt
        self._trains[population].append((times, idx))
        counts = np.bincount(idx, minlength=raster.shape[1])
        self._counts[population] += counts
        self.stats["spikes"] += int(idx.size)
        self.stats["synaptic_events"] += int(counts @ self._out_degree[population])

    def add_steps(self, n_steps: int) -> None:
        """Count ``n_steps`` steps of every neuron."""
        self.stats["steps"] += n_steps
        self.stats["neuron_updates"] += n_steps * self._n_neurons

    def counts(self, population: str) -> np.ndarray:
        """Spikes per neuron since the last reset."""
        return self._counts[population].copy()

    def trains(self, population: str) -> tuple[np.ndarray, np.ndarray]:
        """``(times_ms, neurons)`` since the last reset, sorted by time."""
        return spike_trains(self._trains[population])
