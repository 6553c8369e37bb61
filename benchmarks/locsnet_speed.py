"""Training time and per-query inference time of a paper-size LoCS-Net on this machine's CPU.

The paper (Akcal et al. 2025) trains LoCS-Net on 3,072 Nordland places in about 1 minute
on an RTX 3060 GPU and answers a query in 25 ms on that GPU (796 ms on an Intel NUC).
This script trains the default architecture (:func:`paper_architecture`, 56x56 input,
three convolutional layers, 3,072 place neurons) with torch on the CPU, converts it to a
spiking network and times queries on the ``reference`` backend: the network is compiled
once, and each query resets it, sets the input spikes and runs one presentation window.
The peer is the same trained network as a rate model (numpy, one image at a time), so
the printed ratio is spiking time / rate-model time in the same run.

Images: ``--places`` places of a synthetic traverse (64x32, the size of nordland64;
3,072 Nordland places are not available here), one image per place for training, the
other traverse (winter at dusk) for the queries. A profile follows the timing: the
cost of a presentation with no input (neuron updates only) and the measured synaptic
events, from which the time per neuron update and per synaptic event follow.

Wall and CPU seconds are both printed: this machine's two cores may be shared.

Usage (from the repository root)::

    python benchmarks/locsnet_speed.py [--places 3072] [--epochs 40] [--queries 200] [--threads 1] [--presentations 50,30]

Each presentation window (the model's default is 50 ms) is timed on the same trained
network; a shorter window costs proportionally less and answers with fewer spikes.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

import numpy as np


def _timed(fn, *args, **kwargs):
    w, c = time.perf_counter(), time.process_time()
    out = fn(*args, **kwargs)
    return out, time.perf_counter() - w, time.process_time() - c


def _time_queries(arch, result, settings, ref, queries, presentation: float, t_pre: float) -> dict:
    """Calibrate, convert and time the queries for one presentation window; print and return the figures."""
    from neurovpr.models.locsnet import SpikingClassifier, SpikingParameters, rate_forward
    from neurovpr.models.locsnet.calibration import calibrate_spiking
    from neurovpr.models.locsnet.conversion import to_spiking_network

    n_q = queries.shape[0]
    spiking = SpikingParameters(presentation=presentation)
    pick = np.linspace(0, ref.shape[0] - 1, 100).astype(int)
    (cal, t_cal, _) = _timed(calibrate_spiking, arch, result.parameters, spiking, ref[pick],
                             drive=settings.place_drive, active=settings.active_places)
    params = cal[0]
    train_total = t_pre + result.seconds + t_cal
    print(f"[{presentation:g} ms window] training {result.seconds:.1f} s wall + preprocessing {t_pre:.1f} s + spiking "
          f"calibration {t_cal:.1f} s = {train_total:.1f} s; target < 300 s (paper: ~60 s on an RTX 3060)", flush=True)

    net = to_spiking_network(arch, params, spiking)
    clf, t_compile, _ = _timed(SpikingClassifier, net, arch, spiking)
    clf.run(queries[:3])  # warm-up: numba's compilation cache
    spikes = clf.run(queries, progress=True)
    wall = float(np.median(spikes.seconds))
    cpu = spikes.cpu_seconds / n_q
    # peer: the rate model, one image at a time
    rate_forward(arch, params, queries[:1])
    w0, c0 = time.perf_counter(), time.process_time()
    for q in range(n_q):
        rate_forward(arch, params, queries[q : q + 1])
    rate_wall, rate_cpu = (time.perf_counter() - w0) / n_q, (time.process_time() - c0) / n_q
    # profile: a presentation with no input costs the neuron updates only
    sim = clf.sim
    s0, c0 = sim.statistics(), time.process_time()
    for _ in range(20):
        sim.reset()
        sim.run(spiking.presentation, inputs={"input": np.zeros(arch.layer_sizes()["input"])})
    idle_cpu = (time.process_time() - c0) / 20
    s1 = sim.statistics()
    updates = (s1["neuron_updates"] - s0["neuron_updates"]) / 20
    events = spikes.activity["synaptic_events"]
    ns_update = idle_cpu / updates * 1e9
    ns_event = max(cpu - idle_cpu, 0.0) / max(events, 1) * 1e9
    print(f"compile (reference): {t_compile:.1f} s", flush=True)
    print(f"per query (reference, {spiking.presentation:g} ms window, dt {spiking.dt:g} ms): "
          f"{wall * 1e3:.2f} ms wall (median), {cpu * 1e3:.2f} ms CPU; target < 5 ms "
          f"(paper: 25 ms GPU, 796 ms NUC)", flush=True)
    print(f"peer, rate model in numpy: {rate_wall * 1e3:.2f} ms wall, {rate_cpu * 1e3:.2f} ms CPU per query; "
          f"spiking / rate = {cpu / rate_cpu:.2f} (CPU)", flush=True)
    print(f"profile per query: {updates:,.0f} neuron updates ({idle_cpu * 1e3:.2f} ms CPU with no input, "
          f"{ns_update:.1f} ns each), {events:,.0f} synaptic events (~{ns_event:.1f} ns each), "
          f"spikes per layer { {k: round(v) for k, v in spikes.layer_spikes.items()} }", flush=True)
    return {
        "calibration_seconds": t_cal, "train_total_seconds": train_total, "compile_seconds": t_compile,
        "query_wall_ms": wall * 1e3, "query_cpu_ms": cpu * 1e3, "rate_query_wall_ms": rate_wall * 1e3,
        "rate_query_cpu_ms": rate_cpu * 1e3, "ratio_spiking_to_rate_cpu": cpu / rate_cpu,
        "profile": {"neuron_updates": updates, "idle_cpu_ms": idle_cpu * 1e3, "ns_per_update": ns_update,
                    "synaptic_events": events, "ns_per_event": ns_event, "layer_spikes": spikes.layer_spikes},
    }


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--places", type=int, default=3072)
    p.add_argument("--epochs", type=int, default=40)
    p.add_argument("--queries", type=int, default=200)
    p.add_argument("--threads", type=int, default=1, help="torch threads for training")
    p.add_argument("--presentations", default="50,30", help="presentation windows to time, ms per query (default 50,30)")
    p.add_argument("--out", type=Path, default=Path("reports/locsnet_speed"))
    args = p.parse_args(argv)

    from neurovpr.data import synthetic_traverse
    from neurovpr.models.locsnet import paper_architecture
    from neurovpr.models.locsnet.preprocess import preprocess
    from neurovpr.models.locsnet.training import TrainingSettings, train

    print(f"machine: {os.cpu_count()} CPUs, load average {os.getloadavg()[0]:.1f}", flush=True)
    (traverse, t_gen, _) = _timed(synthetic_traverse, args.places, seed=0)
    arch = paper_architecture(args.places)
    (ref, t_pre, _) = _timed(preprocess, traverse.reference.images(), arch.input_size)
    n_q = min(args.queries, args.places)
    q_idx = np.linspace(0, args.places - 1, n_q).astype(int)
    queries = preprocess(traverse.query.subset(q_idx).images(), arch.input_size)
    print(f"{arch.describe()}; {arch.n_synapses():,} synapses", flush=True)
    print(f"data: synthetic traverse generated in {t_gen:.1f} s, preprocessed in {t_pre:.1f} s", flush=True)

    settings = TrainingSettings(epochs=args.epochs, threads=args.threads)
    result = train(arch, ref, np.arange(args.places), settings, progress=True)
    record = {
        "places": args.places, "epochs": args.epochs, "threads": args.threads, "architecture": arch.describe(),
        "synapses": arch.n_synapses(), "train_seconds": result.seconds, "train_cpu_seconds": result.cpu_seconds,
        "preprocess_seconds": t_pre, "final_train_accuracy": result.history[-1]["train_accuracy"], "queries": {},
    }
    for presentation in [float(x) for x in args.presentations.split(",") if x]:
        record["queries"][f"{presentation:g} ms"] = _time_queries(arch, result, settings, ref, queries, presentation, t_pre)
    record["load_average"] = os.getloadavg()[0]
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "speed.json").write_text(json.dumps(record, indent=2), encoding="utf-8")
    print(f"wrote {args.out / 'speed.json'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
