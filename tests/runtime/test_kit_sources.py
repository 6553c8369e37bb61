"""Poisson spikes drawn by the backend kit (neurovpr.backendkit.sources): Bernoulli steps drawn as geometric gaps."""

from __future__ import annotations

import numpy as np
from scipy import stats

import neurovpr as nv
from neurovpr.backendkit import sources
from neurovpr.backendkit.sources import SourceState


def _state(rate, size: int, *, seed: int = 1, start: float = 0.0, duration: float = 1e9) -> SourceState:
    net = nv.Network("kit")
    net.add_population("s", size, nv.SpikeSourcePoisson(rate=rate, start=start, duration=duration))
    return SourceState(net.populations["s"], dt=0.1, seed=seed)


def test_counts_follow_the_binomial_of_rate_times_dt_per_step() -> None:
    rates = np.linspace(0.0, 600.0, 60)
    state = _state(rates, 60)
    n_steps, repeats = 2000, 50
    counts = np.zeros((repeats, 60))
    for r in range(repeats):
        steps, neurons = state.events(0, n_steps)
        counts[r] = np.bincount(neurons, minlength=60)
        assert np.all((steps >= 0) & (steps < n_steps))
        order = np.lexsort((neurons, steps))  # step by step, neurons in order, at most one spike per step
        np.testing.assert_array_equal(order, np.arange(steps.size))
        assert np.unique(steps * 60 + neurons).size == steps.size
    p = rates * 0.1 / 1000.0
    assert counts[:, 0].sum() == 0
    # each neuron's total over the repeats is Binomial(repeats * n_steps, p): two-sided test at 1e-4 per neuron
    total = counts[:, 1:].sum(axis=0)
    pvalues = np.array([stats.binomtest(int(k), repeats * n_steps, q).pvalue for k, q in zip(total, p[1:], strict=True)])
    assert pvalues.min() > 1e-4, pvalues.min()
    # and a neuron's steps are independent: its inter-spike gaps are geometric with mean 1 / p
    steps, neurons = state.events(0, 200_000)
    gaps = np.diff(steps[neurons == 59])
    assert abs(gaps.mean() * p[59] - 1.0) < 0.05


def test_window_certain_spikes_silence_and_many_neurons() -> None:
    every = _state(10_000.0, 3, start=0.5, duration=1.0)  # p = 1 in steps 5 .. 14 only
    steps, neurons = every.events(0, 30)
    np.testing.assert_array_equal(steps, np.repeat(np.arange(5, 15), 3))
    np.testing.assert_array_equal(neurons, np.tile(np.arange(3), 10))
    assert every.raster(0, 30).sum() == 30 and every.raster(20, 10).sum() == 0
    assert _state(0.0, 5).events(0, 100)[0].size == 0
    many = _state(50.0, sources._CHUNK_NEURONS + 7)  # more neurons than one chunk of gaps
    steps, neurons = many.events(0, 400)
    assert neurons.max() == sources._CHUNK_NEURONS + 6
    np.testing.assert_array_equal(np.lexsort((neurons, steps)), np.arange(steps.size))


def test_the_same_seed_and_calls_give_the_same_spikes() -> None:
    a, b = _state(80.0, 20, seed=7), _state(80.0, 20, seed=7)
    for first in (0, 350, 700):
        for x, y in zip(a.events(first, 350), b.events(first, 350), strict=True):
            np.testing.assert_array_equal(x, y)
    c = _state(80.0, 20, seed=8)
    assert not np.array_equal(a.events(0, 350)[0], c.events(0, 350)[0])
