"""The tour's first part: one network, declared once, run on every backend by changing one flag.

The network is small and fully determined (explicit input spike times, explicit
weights), so any difference between backends comes from their numerics alone:
40 regular spike trains -> 100 ``IF_curr_exp`` neurons -> 20 ``IF_curr_exp`` neurons.
Every backend runs it for the same simulated time; the table compares its spike
counts with the reference backend's and gives what one simulated second costs.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any

import numpy as np

import neurovpr as nv
from neurovpr.apps.compare import availability_refusal
from neurovpr.errors import NeurovprError

__all__ = ["TOUR_BACKENDS", "tour_network", "run_backends"]

#: The backends the tour tries, in order (the first that runs is the reference of comparison).
TOUR_BACKENDS = ("reference", "brian2", "nengo", "lava", "nengo-loihi", "lava-fixed")
_RECORDED = ("hidden", "output")
#: Share of the run simulated once, untimed, before the timed run (after which the simulation is reset).
_WARM_UP = 0.1


def tour_network(duration_ms: float, seed: int = 0) -> nv.Network:
    """The network every backend runs: explicit spike trains into two LIF layers."""
    rng = np.random.default_rng(seed)
    n_in, n_hidden, n_out = 40, 100, 20
    periods = rng.uniform(8.0, 40.0, n_in)
    trains = [np.arange(rng.uniform(1.0, p), duration_ms, p).round() for p in periods]
    net = nv.Network("tour")
    net.add_population("input", n_in, nv.SpikeSourceArray.from_lists(trains))
    cell = nv.IF_curr_exp(tau_m=20.0, tau_syn_E=5.0, tau_syn_I=5.0, tau_refrac=2.0)
    net.add_population("hidden", n_hidden, cell)
    net.add_population("output", n_out, cell)
    w_in = rng.uniform(0.0, 0.9, (n_in, n_hidden)) * (rng.random((n_in, n_hidden)) < 0.3)
    w_out = rng.uniform(0.0, 0.5, (n_hidden, n_out)) * (rng.random((n_hidden, n_out)) < 0.3)
    net.connect("input", "hidden", nv.AllToAllConnector(), nv.StaticSynapse(weight=w_in, delay=1.0))
    net.connect("hidden", "output", nv.AllToAllConnector(), nv.StaticSynapse(weight=w_out, delay=1.0))
    return net


@dataclass(frozen=True, slots=True, kw_only=True)
class BackendRun:
    """One backend's run of the tour network (``refused`` set when it did not run)."""

    backend: str
    refused: str | None = None
    spikes: dict[str, int] | None = None
    counts: np.ndarray | None = None
    compile_seconds: float | None = None
    warm_up_seconds: float | None = None
    seconds_per_simulated_second: float | None = None


def _run_one(net: nv.Network, backend: str, duration_ms: float, dt: float) -> BackendRun:
    refusal = availability_refusal(backend)
    if refusal is not None:
        return BackendRun(backend=backend, refused=refusal)
    try:
        start = time.perf_counter()
        sim = nv.compile(net, backend=backend, dt=dt, seed=0)
        compiled = time.perf_counter()
        # a short first run pays one-time costs (numba's JIT on a fresh install, code generation), then reset
        sim.run(_WARM_UP * duration_ms)
        sim.reset()
        warm = time.perf_counter()
        sim.run(duration_ms)
        ran = time.perf_counter()
        counts = {pop: np.asarray(sim.spike_counts(pop), dtype=np.int64) for pop in _RECORDED}
    except NeurovprError as exc:
        return BackendRun(backend=backend, refused=str(exc))
    return BackendRun(
        backend=backend,
        spikes={pop: int(c.sum()) for pop, c in counts.items()},
        counts=np.concatenate([counts[p] for p in _RECORDED]),
        compile_seconds=compiled - start,
        warm_up_seconds=warm - compiled,
        seconds_per_simulated_second=(ran - warm) / (duration_ms / 1000.0),
    )


def _agreement(counts: np.ndarray, reference: np.ndarray) -> dict[str, float | None]:
    same = float(np.mean(counts == reference))
    if np.std(counts) == 0 or np.std(reference) == 0:
        return {"identical_counts": same, "count_correlation": None}
    return {"identical_counts": same, "count_correlation": float(np.corrcoef(counts, reference)[0, 1])}


def run_backends(duration_ms: float, *, backends: tuple[str, ...] = TOUR_BACKENDS, dt: float = 1.0) -> dict[str, Any]:
    """Run the tour network on each backend; rows of spike counts, agreement and cost.

    Returns a JSON-ready dict: ``network`` (what was run), ``rows`` (one per backend that
    ran: spikes per population, the share of neurons whose spike count equals the
    reference backend's, Pearson's r of the per-neuron counts, compile seconds, the seconds
    of an untimed first run of a tenth of the duration (one-time costs such as numba's JIT),
    and wall seconds per simulated second of the timed run after a reset) and ``refused`` (backend -> the sentence why not,
    naming the extra to install).
    """
    net = tour_network(duration_ms)
    rows, refused = [], {}
    reference: np.ndarray | None = None
    for name in backends:
        run = _run_one(net, name, duration_ms, dt)
        if run.refused is not None:
            refused[name] = run.refused
            continue
        assert run.counts is not None
        if reference is None:
            reference = run.counts
        rows.append(
            {
                "backend": name,
                "spikes": run.spikes,
                **_agreement(run.counts, reference),
                "compile_seconds": round(run.compile_seconds or 0.0, 3),
                "warm_up_seconds": round(run.warm_up_seconds or 0.0, 3),
                "seconds_per_simulated_second": round(run.seconds_per_simulated_second or 0.0, 4),
            }
        )
    sizes = {name: net.populations[name].size for name in ("input", *_RECORDED)}
    return {
        "network": f"{sizes['input']} spike trains -> {sizes['hidden']} -> {sizes['output']} IF_curr_exp neurons",
        "duration_ms": duration_ms,
        "dt_ms": dt,
        "reference_backend": rows[0]["backend"] if rows else None,
        "rows": rows,
        "refused": refused,
    }
