"""Real-time factor of the mushroom-body SNN on the reference backend and on Brian2, in one run.

The real-time factor is simulated seconds per wall-clock second while the network
learns (plasticity on) from event-camera PN spikes: above 1 is faster than real time.
SpiNNaker ran the paper's network exactly in real time (factor 1); the paper's Brian2
version (10,000 KCs) took over 20 minutes per 2 s of input (factor below 1/600).

Input: the first seconds of the moving part of a real recording
(``../shared/datasets/mbsnn_routes``, 210 PNs) when present, otherwise synthetic PN
spikes of the same statistics for 840 PNs (the paper's 8x8 mega-pixels). Times exclude
network construction and compilation (reported separately) and a short warm-up run
(numba's JIT, Brian2's code generation). Wall and CPU seconds are both printed: this
machine's cores may be shared, and CPU time is what one core spent. Synaptic events per CPU
second (``statistics()``: every spike times its neuron's outgoing connections) are printed
for the backends that count them.

Usage::

    python benchmarks/mbsnn_realtime.py [--n-kc 4000] [--seconds 2] [--brian2-seconds 0.1]
        [--dt 0.1] [--brian2-target numpy|cython] [--synthetic]
"""

from __future__ import annotations

import argparse
import importlib
import sys
import time
from collections.abc import Callable
from typing import Any

import numpy as np

import neurovpr as nv
from neurovpr.data.events import PNSpikes, read_pn_mat
from neurovpr.models.mbsnn import MBSNNParameters, build_network, compile_mbsnn, present
from neurovpr.paths import shared_datasets


def real_input() -> tuple[PNSpikes, str] | None:
    """The moving part of the NB3 recording, or ``None`` when the data is absent."""
    root = shared_datasets()
    files = sorted((root / "mbsnn_routes").glob("NB3_*.mat")) if root is not None else []
    if not files:
        return None
    return read_pn_mat(files[0], n_pn=210).trim_inactive(), f"{files[0].name} (moving part, 210 PNs)"


def synthetic_input(n_pn: int, duration_ms: float, seed: int = 0) -> tuple[PNSpikes, str]:
    """PN spikes in 1-ms bins: each mega-pixel fires in bursts as edges sweep past (mean ~65 Hz)."""
    rng = np.random.default_rng(seed)
    n_bins = int(duration_ms)
    t = np.arange(n_bins)[:, None]
    phase = rng.random(n_pn) * 2 * np.pi
    period = rng.uniform(150.0, 600.0, n_pn)
    p = 0.065 * (1.0 + np.sin(2 * np.pi * t / period + phase)) ** 2 / 1.5
    hits = rng.random((n_bins, n_pn)) < np.clip(p, 0.0, 1.0)
    times, idx = np.nonzero(hits)
    return PNSpikes(times_ms=times.astype(float), idx=idx, n_pn=n_pn, duration_ms=float(n_bins)), (
        f"synthetic ({n_pn} PNs)"
    )


def brian2_compiler() -> tuple[Callable[..., nv.Simulation] | None, str]:
    """A function compiling for Brian2, or ``None`` and the reason it is unavailable."""
    try:
        nv.get_backend("brian2")
        return (lambda net, **kw: nv.compile(net, backend="brian2", **kw)), "entry point 'brian2'"
    except nv.NeurovprError as exc:
        registry_reason = str(exc)
    try:
        module = importlib.import_module("neurovpr.backends.brian2")
    except ImportError as exc:
        return None, f"neurovpr.backends.brian2 does not import ({exc}); registry: {registry_reason}"
    backend = module.BACKEND
    reason = backend.unavailable_reason()
    if reason is not None:
        return None, reason
    return (lambda net, dt, seed, **kw: backend.compile(net, dt=dt, seed=seed, **kw)), "neurovpr.backends.brian2 (imported)"


def measure(sim: nv.Simulation, spikes: PNSpikes, seconds: float) -> dict[str, Any]:
    """Warm up, then time learning over the first ``seconds`` of ``spikes``."""
    present(sim, spikes.window(0.0, min(20.0, spikes.duration_ms)), learn=True)
    piece = spikes.window(0.0, min(seconds * 1000.0, spikes.duration_ms))
    before = _events(sim)
    wall0, cpu0 = time.perf_counter(), time.process_time()
    response = present(sim, piece, learn=True, progress="simulating")
    wall, cpu = time.perf_counter() - wall0, time.process_time() - cpu0
    simulated = response.duration_ms / 1000.0
    after = _events(sim)
    events = None if before is None or after is None else after - before
    return {"simulated_s": simulated, "wall_s": wall, "cpu_s": cpu, "rt_wall": simulated / wall,
            "rt_cpu": simulated / cpu if cpu > 0 else float("inf"), "counts": response.counts,
            "synaptic_events": events, "events_per_cpu_s": events / cpu if events is not None and cpu > 0 else None}  # fmt: skip


def _events(sim: nv.Simulation) -> int | None:
    """Synaptic events so far (``statistics()``), or ``None`` where the backend does not count them."""
    try:
        return int(sim.statistics()["synaptic_events"])
    except nv.NeurovprError:
        return None


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--n-kc", type=int, default=4000, help="Kenyon cells (default 4000, the paper's)")
    parser.add_argument("--seconds", type=float, default=2.0, help="simulated seconds on the reference backend")
    parser.add_argument("--brian2-seconds", type=float, default=0.1, help="simulated seconds on Brian2")
    parser.add_argument("--brian2-target", default="cython", choices=("numpy", "cython"))
    parser.add_argument("--dt", type=float, default=MBSNNParameters().dt, help="time step in ms")
    parser.add_argument("--synthetic", action="store_true", help="synthetic input even when real data is present")
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args(argv)

    found = None if args.synthetic else real_input()
    spikes, source = found if found is not None else synthetic_input(840, args.seconds * 1000.0 + 20.0)
    params = MBSNNParameters(n_kc=args.n_kc, dt=args.dt)
    t0 = time.perf_counter()
    network = build_network(spikes.n_pn, params, seed=args.seed)
    build_s = time.perf_counter() - t0
    print(f"input: {source}; network: {spikes.n_pn} PNs, {args.n_kc} KCs (x2 compartments), 1 MBON; "
          f"{network.n_neurons} units, dt = {args.dt} ms; built in {build_s:.1f} s")  # fmt: skip

    rows: list[tuple[str, dict[str, Any] | str]] = []
    t0 = time.perf_counter()
    sim = compile_mbsnn(network, dt=args.dt, seed=args.seed)
    print(f"reference: compiled in {time.perf_counter() - t0:.1f} s")
    rows.append(("reference", measure(sim, spikes, args.seconds)))
    del sim

    compiler, how = brian2_compiler()
    if compiler is None:
        rows.append(("brian2", f"unavailable: {how}"))
    else:
        t0 = time.perf_counter()
        try:
            sim = compiler(network, dt=args.dt, seed=args.seed, target=args.brian2_target)
        except nv.NeurovprError as exc:
            rows.append(("brian2", f"unavailable: {exc}"))
        else:
            print(f"brian2 ({args.brian2_target}, via {how}): compiled in {time.perf_counter() - t0:.1f} s")
            rows.append((f"brian2 ({args.brian2_target})", measure(sim, spikes, args.brian2_seconds)))

    print()
    head = f"{'backend':<18}{'simulated s':>12}{'wall s':>9}{'cpu s':>9}{'RT (wall)':>11}{'RT (cpu)':>10}"
    print(f"{head}{'syn. events / cpu s':>21}")
    for name, row in rows:
        if isinstance(row, str):
            print(f"{name:<18}{row}")
            continue
        rate = "not counted" if row["events_per_cpu_s"] is None else f"{row['events_per_cpu_s']:.3g}"
        print(f"{name:<18}{row['simulated_s']:>12.3f}{row['wall_s']:>9.2f}{row['cpu_s']:>9.2f}"
              f"{row['rt_wall']:>10.3f}x{row['rt_cpu']:>9.3f}x{rate:>21}")  # fmt: skip
    measured = [row for _, row in rows if not isinstance(row, str)]
    if len(measured) == 2:
        ratio = measured[0]["rt_wall"] / measured[1]["rt_wall"]
        print(f"reference / brian2 speed ratio (wall): {ratio:.1f}")
    ref = measured[0]
    verdict = "meets" if ref["rt_wall"] >= 20.0 else "misses"
    print(f"target >= 20x real time on the reference backend: {verdict} ({ref['rt_wall']:.2f}x wall, "
          f"{ref['rt_cpu']:.2f}x cpu); SpiNNaker: 1x; paper's Brian2 (10,000 KCs): < 1/600x")  # fmt: skip
    return 0


if __name__ == "__main__":
    sys.exit(main())
