"""Spike sources drawn on the host, on the step grid of docs/semantics.md, and their seeding.

A ``SpikeSourcePoisson`` neuron emits at most one spike per step ``j``, with probability
``rate * dt / 1000``, stamped at ``j dt``, in the steps whose start lies in
``[start, start + duration)``; a ``SpikeSourceArray`` spike at ``t`` is stamped at
``round(t / dt) dt``. Poisson draws come from the generator of the population's stream
(:func:`poisson_rng`: the compile seed, the population's name and the purpose
:data:`~neurovpr.ir.connectivity.POISSON`); it continues across ``reset()``, so repeated
runs see fresh spikes, and the same seed and sequence of calls give the same spikes on
every backend that draws here.
"""

from __future__ import annotations

import numpy as np

from neurovpr.ir.cells import SpikeSourceArray, SpikeSourcePoisson
from neurovpr.ir.connectivity import POISSON, stream_rng
from neurovpr.ir.network import Population

from .params import per_neuron
from .timing import grid_steps, window_steps

__all__ = ["SourceState", "poisson_rng", "array_events"]

#: Poisson neurons whose gaps are drawn together, and the most gaps drawn in one block.
_CHUNK_NEURONS = 4096
_MAX_DRAWS = 2**22


def poisson_rng(population: Population, seed: int) -> np.random.Generator:
    """The generator of a Poisson population's spikes (independent of every connectivity stream)."""
    return stream_rng(population.name, seed, POISSON)


def array_events(spikes: SpikeSourceArray, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """``(steps, neurons)`` of every spike of ``spikes``, in its stored (neuron-major) order."""
    neurons = np.repeat(np.arange(spikes.n_neurons, dtype=np.int64), np.diff(spikes.offsets))
    return grid_steps(spikes.times, dt), neurons


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
            self._rates = per_neuron(cell.rate, pop.size)
            self._first, self._end = window_steps(cell.start, cell.duration, dt)
            self._rng = poisson_rng(pop, seed)
        else:
            assert isinstance(cell, SpikeSourceArray)
            self.set_array(cell)

    def set_rates(self, rates: np.ndarray) -> None:
        """New Poisson rates (Hz), one per neuron."""
        self._rates = np.asarray(rates, dtype=np.float64).copy()

    def set_array(self, spikes: SpikeSourceArray) -> None:
        """New spike times (ms since the last reset)."""
        self._stamps, self._neurons = array_events(spikes, self._dt)

    def set(self, value: object) -> None:
        """Apply a validated input: rates (array) or a :class:`SpikeSourceArray`."""
        if isinstance(value, SpikeSourceArray):
            self.set_array(value)
        else:
            self.set_rates(np.asarray(value))

    def events(self, first: int, n_steps: int) -> tuple[np.ndarray, np.ndarray]:
        """``(steps, neurons)`` of the spikes stamped at steps ``first .. first + n_steps - 1``.

        Poisson spikes come step by step, neurons in order; an array neuron with several
        spikes in one step appears once per spike, in stored order.
        """
        if self._poisson:
            return self._poisson_events(first, n_steps)
        sel = (self._stamps >= first) & (self._stamps < first + n_steps)
        return self._stamps[sel], self._neurons[sel]

    def raster(self, first: int, n_steps: int) -> np.ndarray:
        """0/1 spikes (``(n_steps, size)`` bool) stamped at steps ``first .. first + n_steps - 1``.

        Several array spikes of one neuron in one step count once here.
        """
        out = np.zeros((n_steps, self._size), dtype=bool)
        steps, neurons = self.events(first, n_steps)
        out[steps - first, neurons] = True
        return out

    def _poisson_events(self, first: int, n_steps: int) -> tuple[np.ndarray, np.ndarray]:
        """Poisson spikes of steps ``first .. first + n_steps - 1``, sorted by step then neuron.

        Each neuron's steps are Bernoulli trials with ``p = rate * dt / 1000``; the gaps between
        its successes are geometric, so they are drawn directly (the work follows the spikes,
        not steps x neurons): a neuron's gaps are drawn in blocks until its next spike falls
        past the window.
        """
        lo, hi = max(first, self._first), min(first + n_steps, self._end)
        p = np.clip(self._rates * (self._dt / 1000.0), 0.0, 1.0)
        active = np.flatnonzero(p > 0)
        if hi <= lo or active.size == 0:
            return np.zeros(0, np.int64), np.zeros(0, np.int64)
        n = hi - lo
        steps_out, neurons_out = [], []
        for start in range(0, active.size, _CHUNK_NEURONS):
            who = active[start : start + _CHUNK_NEURONS]
            last = np.full(who.size, -1, dtype=np.int64)  # each neuron's last spike so far (offset in the window)
            todo = np.arange(who.size)
            while todo.size:
                q = p[who[todo]]
                expect = float((q * (n - 1 - last[todo])).max())
                block = max(4, min(int(expect + 4.0 * np.sqrt(expect) + 4.0), _MAX_DRAWS // todo.size or 1))
                at = last[todo, None] + np.cumsum(self._rng.geometric(q[:, None], size=(todo.size, block)), axis=1)
                inside = at < n
                rows = np.nonzero(inside)[0]
                steps_out.append(at[inside])
                neurons_out.append(who[todo[rows]])
                last[todo] = at[:, -1]
                todo = todo[at[:, -1] < n - 1]
        steps = np.concatenate(steps_out) + lo
        neurons = np.concatenate(neurons_out).astype(np.int64)
        order = np.lexsort((neurons, steps))
        return steps[order], neurons[order]
