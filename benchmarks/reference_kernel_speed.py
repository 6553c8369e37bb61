"""Speed of the reference backend's compiled step loop on two models, to compare two revisions of its kernels.

Runs, on the reference backend only, (1) the Diehl & Cook module of
``reference_vs_brian2.py`` (784-400-400, learning, weight normalisation between images),
(2) the mushroom-body network of ``models/mbsnn`` learning from synthetic PN spikes
(840 PNs, the paper's 4000 KCs) and (3) one Modular SNN module as ``models/modular_snn``
builds and trains it (its defaults: dt 0.1 ms, input delays U(0.1, 10) ms, 50 ms lockout,
350 ms presentations with weight normalisation, then the same images with learning off),
on ``--modular-images`` synthetic images, reported in CPU seconds per presentation. Each is
timed ``--repeats`` times after a warm-up (numba's compilation is not counted) and the
fastest CPU time is kept, which is the figure least disturbed by other work on a shared
machine. The spike totals are printed with the times: two revisions of the kernels that
compute the same thing print the same totals.

There is no peer in this run: the figures are meant for a before/after table of the same
command on two revisions, on the same machine.

Usage::

    python benchmarks/reference_kernel_speed.py [--places 40] [--mbsnn-ms 4000] [--modular-images 10] [--repeats 5] [--json OUT]
"""

from __future__ import annotations

import argparse
import json
import platform
import sys
import time
from pathlib import Path

import numpy as np

import neurovpr as nv
from neurovpr.models.mbsnn import MBSNNParameters, build_network, compile_mbsnn, present

sys.path.insert(0, str(Path(__file__).resolve().parent))
from mbsnn_realtime import synthetic_input
from reference_vs_brian2 import DT, PRESENT_MS, build_module, poisson_images


def dc_module(places: int, repeats: int, seed: int) -> dict:
    """Train the Diehl & Cook module on ``places`` images, ``repeats`` times; the fastest run and its spikes."""
    images = poisson_images(places, np.random.default_rng(seed))
    cpu, wall, spikes = [], [], set()
    for _ in range(repeats):
        sim = nv.compile(build_module(images[0], seed), backend="reference", dt=DT, seed=seed)
        sim.run(PRESENT_MS, inputs={"pixels": images[0]})  # warm-up (numba loads or compiles the kernels)
        sim.reset()
        _, post = sim.connections("pixels->exc")
        total, events = 0, sim.statistics()["synaptic_events"]
        wall0, cpu0 = time.perf_counter(), time.process_time()
        for img in images:
            w = sim.weights("pixels->exc", format="list")
            sim.set_weights("pixels->exc", np.minimum(w * (78.0 / np.bincount(post, weights=w))[post], 1.0))
            sim.run(PRESENT_MS, inputs={"pixels": img})
            total += int(sim.spike_counts("exc").sum())
            sim.reset()
        wall.append(time.perf_counter() - wall0)
        cpu.append(time.process_time() - cpu0)
        events = sim.statistics()["synaptic_events"] - events
        spikes.add((total, float(np.mean(sim.weights("pixels->exc")))))
    rate = events / min(cpu)
    return {"cpu_s": min(cpu), "wall_s": min(wall), "cpu_all": cpu, "result": sorted(spikes), "events_per_cpu_s": rate}


def mbsnn(duration_ms: float, repeats: int, seed: int) -> dict:
    """Let the mushroom-body network learn ``duration_ms`` of synthetic PN spikes, ``repeats`` times."""
    spikes, _ = synthetic_input(840, duration_ms + 20.0, seed=seed)
    params = MBSNNParameters()
    network = build_network(spikes.n_pn, params, seed=seed)
    cpu, wall, results = [], [], set()
    for _ in range(repeats):
        sim = compile_mbsnn(network, dt=params.dt, seed=seed)
        present(sim, spikes.window(0.0, 20.0), learn=True)  # warm-up
        piece = spikes.window(0.0, duration_ms)
        wall0, cpu0 = time.perf_counter(), time.process_time()
        response = present(sim, piece, learn=True)
        wall.append(time.perf_counter() - wall0)
        cpu.append(time.process_time() - cpu0)
        results.add(tuple(sorted(response.counts.items())))
    return {"cpu_s": min(cpu), "wall_s": min(wall), "cpu_all": cpu, "result": sorted(results)}


def modular_module(n_images: int, repeats: int, seed: int, integration: str = "euler") -> dict:
    """Train a Modular SNN module (the model's defaults, ``integration`` steps) on ``n_images`` synthetic images,
    then record them; CPU s per image."""
    from neurovpr.models.modular_snn import ModuleParameters, TrainingSettings
    from neurovpr.models.modular_snn.training import Presenter, normalise_input_weights

    settings = TrainingSettings(params=ModuleParameters(integration=integration))
    images = np.random.default_rng(seed).integers(0, 256, size=(n_images, settings.params.n_input)).astype(np.uint8)
    train, record, results = [], [], set()
    for _ in range(repeats):
        sim = nv.compile(settings.network("module", seed), backend="reference", dt=settings.dt, seed=seed)
        presenter = Presenter(sim, settings)
        presenter.present(images[0])  # warm-up (numba loads or compiles the kernels)
        total = 0
        cpu0 = time.process_time()
        for image in images:
            normalise_input_weights(sim, settings.weight_sum, settings.params.w_max)
            total += int(presenter.present(image).sum())
        train.append((time.process_time() - cpu0) / n_images)
        sim.plasticity(False)
        cpu0 = time.process_time()
        for image in images:
            total += int(presenter.present(image).sum())
        record.append((time.process_time() - cpu0) / n_images)
        results.add((total, float(np.mean(sim.weights("pixels->exc")))))
    return {"cpu_s": min(train), "record_cpu_s": min(record), "cpu_all": train, "result": sorted(results)}


def main() -> None:
    """Run both models and print the table."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--places", type=int, default=40, help="images for the Diehl & Cook module")
    parser.add_argument("--mbsnn-ms", type=float, default=4000.0, help="simulated ms of mushroom-body learning")
    parser.add_argument("--modular-images", type=int, default=10, help="images for the Modular SNN module (0: not run)")
    parser.add_argument("--modular-integration", choices=("euler", "exact"), default="euler",
                        help="the Modular SNN module's cell steps (default euler, the model's)")  # fmt: skip
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--json", type=Path, default=None)
    args = parser.parse_args()
    rows = {
        f"D&C module, {args.places} images": dc_module(args.places, args.repeats, args.seed),
        f"MBSNN 4000 KCs, {args.mbsnn_ms:.0f} ms": mbsnn(args.mbsnn_ms, args.repeats, args.seed),
    }
    modular = (
        modular_module(args.modular_images, args.repeats, args.seed, args.modular_integration) if args.modular_images else None
    )
    print(f"reference backend, fastest of {args.repeats}; machine: {platform.processor() or platform.machine()}")
    print(f"{'run':32s}{'cpu s':>9s}{'wall s':>9s}  result (spikes, ...)")
    for name, r in rows.items():
        print(f"{name:32s}{r['cpu_s']:9.3f}{r['wall_s']:9.3f}  {r['result']}")
    dc = rows[f"D&C module, {args.places} images"]
    print(f"D&C module: {dc['events_per_cpu_s']:.3g} synaptic events per CPU second")
    if modular is not None:
        rows[f"Modular SNN module, {args.modular_images} images"] = modular
        print(
            f"Modular SNN module at dt 0.1 ms, CPU s per image: training {modular['cpu_s']:.4f}, "
            f"recording {modular['record_cpu_s']:.4f}  {modular['result']}"
        )
    if args.json:
        args.json.write_text(json.dumps(rows, indent=2))


if __name__ == "__main__":
    main()
