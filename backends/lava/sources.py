"""Spike sources on the step grid of docs/semantics.md, drawn before each run and replayed.

A ``SpikeSourcePoisson`` neuron emits at most one spike per step ``j``, with
probability ``rate * dt / 1000``, stamped at ``j dt``, while
``start <= j dt < start + duration``; a ``SpikeSourceArray`` spike at ``t`` is stamped
at ``round(t / dt) dt``. Both give a 0/1 raster per step (several array spikes of
one neuron in the same step count once). Poisson draws come from a generator
seeded by the compile seed and the population's name; it continues across
``reset()``, so repeated runs see fresh spikes, and the same seed and sequence of
calls give the same spikes.
"""

from __future__ import annotations

import zlib

import numpy as np

from neurovpr.ir.cells import SpikeSourceArray, SpikeSourcePoisson
from neurovpr.ir.network import Population

__all__ = ["SourceState"]

#: Purpose key of the Poisson stream (independent of connectivity streams).
_POISSON = 3


class SourceState:
    """The current activity of one spike-source population.

    Parameters
    ----------
    pop
        The source population.
    dt
        Time step (ms).
    seed
        Compile seed.
    """

    def __init__(self, pop: Population, *, dt: float, seed: int) -> None:
        self._size = pop.size
        self._dt = dt
        cell = pop.cell_type
        self._poisson = isinstance(cell, SpikeSourcePoisson)
        if self._poisson:
            assert isinstance(cell, SpikeSourcePoisson)
            self._rates = np.broadcast_to(np.asarray(cell.rate, dtype=np.float64), (pop.size,)).copy()
            self._start, self._duration = float(cell.start), float(cell.duration)
            key = zlib.crc32(pop.name.encode("utf-8"))
            self._rng = np.random.default_rng(np.random.SeedSequence(entropy=seed, spawn_key=(key, _POISSON)))
        else:
            assert isinstance(cell, SpikeSourceArray)
            self.set_array(cell)

    def set_rates(self, rates: np.ndarray) -> None:
        """New Poisson rates (Hz), one per neuron."""
        self._rates = np.asarray(rates, dtype=np.float64).copy()

    def set_array(self, spikes: SpikeSourceArray) -> None:
        """New spike times (ms since the last reset)."""
        counts = np.diff(spikes.offsets)
        self._stamps = np.rint(np.asarray(spikes.times) / self._dt).astype(np.int64)
        self._neurons = np.repeat(np.arange(self._size, dtype=np.int64), counts)

    def set(self, value: object) -> None:
        """Apply a validated input: rates (array) or a :class:`SpikeSourceArray`."""
        if isinstance(value, SpikeSourceArray):
            self.set_array(value)
        else:
            self.set_rates(np.asarray(value))

    def raster(self, first: int, n_steps: int) -> np.ndarray:
        """0/1 spikes (``(n_steps, size)`` bool) stamped at steps ``first .. first + n_steps - 1``."""
        if self._poisson:
            draws = self._rng.random((n_steps, self._size))
            t = (first + np.arange(n_steps)) * self._dt
            active = (t >= self._start) & (t < self._start + self._duration)
            return (draws < self._rates * (self._dt / 1000.0)) & active[:, None]
        out = np.zeros((n_steps, self._size), dtype=bool)
        sel = (self._stamps >= first) & (self._stamps < first + n_steps)
        out[self._stamps[sel] - first, self._neurons[sel]] = True
        return out
