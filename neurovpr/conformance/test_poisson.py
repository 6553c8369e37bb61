"""SpikeSourcePoisson: mean count, Fano factor, timing on the grid, start and duration."""

from __future__ import annotations

import math

import numpy as np

import neurovpr as nv

DT = 0.1
T_STOP = 1000.0
N = 4000
#: statistical bound, in standard deviations (a false alarm has probability ~6e-7 per check)
SIGMAS = 5.0


def _check_population(name: str, times: np.ndarray, idx: np.ndarray, *, rate: float, first: int, last: int) -> None:
    """Compare one population with ``Binomial(n_active_steps, p)`` counts, ``p = rate dt / 1000``.

    Active steps are ``first <= j < last``. Each neuron's count has mean ``n p`` and
    variance ``n p (1 - p)`` (Fano factor ``1 - p``). The sample Fano factor over ``N``
    neurons has standard error ``(1 - p) sqrt(2 / (N - 1) + kappa / N)`` with the
    binomial excess kurtosis ``kappa = (1 - 6 p (1 - p)) / (n p (1 - p))``.
    """
    p = rate * DT / 1000.0
    n = last - first
    steps = times / DT
    np.testing.assert_allclose(steps, np.round(steps), rtol=0, atol=1e-6, err_msg=f"{name}: spikes off the grid")
    steps = np.round(steps).astype(np.int64)
    assert np.unique(idx * (last + 1) + steps).size == steps.size, f"{name}: two spikes of one neuron in one step"
    if N * p >= 40:
        # with N p >= 40 expected spikes per step, the first and last active steps both
        # carry spikes (each is empty with probability (1 - p)^N < 1e-17)
        assert steps.min() == first and steps.max() == last - 1, (
            f"{name}: spikes from step {steps.min()} to {steps.max()}, active steps are [{first}, {last})"
        )
    else:
        assert steps.min() >= first and steps.max() < last, f"{name}: spikes outside the steps [{first}, {last})"

    counts = np.bincount(idx, minlength=N)
    mean, var = N * n * p, N * n * p * (1 - p)
    assert abs(counts.sum() - mean) < SIGMAS * math.sqrt(var), f"{name}: {counts.sum()} spikes, expected {mean:.0f}"

    fano = counts.var(ddof=1) / counts.mean()
    kappa = (1 - 6 * p * (1 - p)) / (n * p * (1 - p))
    se = (1 - p) * math.sqrt(2 / (N - 1) + kappa / N)
    assert abs(fano - (1 - p)) < SIGMAS * se, f"{name}: Fano factor {fano:.4f}, expected {1 - p:.4f} +- {se:.4f}"

    # spikes spread evenly over the active steps: 10 bins, each binomial
    bins = np.bincount((steps - first) * 10 // n, minlength=10)
    expected, sd = mean / 10, math.sqrt(var / 10)
    assert np.all(np.abs(bins - expected) < SIGMAS * sd), f"{name}: counts per tenth of the window {bins.tolist()}"


def test_poisson_counts_and_fano(backend):
    """Each neuron emits at most one spike per step with probability ``rate dt / 1000``,
    stamped at the step start ``j dt``, while ``start <= j dt < start + duration``.

    Two rates (20 Hz from the cell type, 200 Hz set through ``inputs=``) and a
    windowed source (100 Hz, ``start = 200 ms``, ``duration = 300 ms``).
    """
    case = "poisson"
    net = nv.Network("poisson")
    net.add_population("slow", N, nv.SpikeSourcePoisson(rate=20.0))
    net.add_population("fast", N, nv.SpikeSourcePoisson(rate=0.0))
    net.add_population("window", N, nv.SpikeSourcePoisson(rate=100.0, start=200.0, duration=300.0))
    sim = backend.compile(net, case=case, dt=DT, seed=11)
    sim.run(T_STOP, inputs={"fast": 200.0})
    n_steps = round(T_STOP / DT)
    for name, rate, first, last in (("slow", 20.0, 0, n_steps), ("fast", 200.0, 0, n_steps), ("window", 100.0, 2000, 5000)):
        times, idx = sim.spike_trains(name)
        np.testing.assert_array_equal(sim.spike_counts(name), np.bincount(idx, minlength=N))
        _check_population(name, times, idx, rate=rate, first=first, last=last)
