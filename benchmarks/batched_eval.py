"""Batched query phases: the reference backend against the torch backend (CPU, and CUDA when present).

Evaluation shows every query image to every trained network with learning off; the
images are independent, so ``Simulation.run_batch`` runs them as one batch. The reference
backend runs a batch as the loop of run and reset; the torch backend simulates
``--batch-size`` images at once as tensor steps. All are timed in the same run on the
same trained networks, after one untimed batch of the timed shape (numba's cache, torch's
first calls; its wall time is stored), and the ratios are printed.

1. Modular SNN query phase, one module of the paper's size (784 inputs, 400 + 400
   neurons, 350 ms at dt 0.1 ms): one module is trained on the first 25 nordland64
   places (``--epochs``, 1 by default: speed, not accuracy, is measured), then
   ``--queries`` query images go through it through the model's own path
   (``record_responses``, the function evaluation calls). The time of one member's query
   phase for 500 and 2,400 places is extrapolated from the measured time per
   module-image (a member of P places has ceil(P / 25) modules, each shown all P
   queries); running all of it here would take hours on the reference backend.
   Poisson input is drawn by each backend (the reference its own generator, torch the
   backend kit's), so spike counts agree in distribution, not spike for spike; the mean
   spikes per image are printed for both.
2. LoCS-Net queries: the default architecture (56x56 input, three convolutional layers)
   for ``--locsnet-places`` places of a synthetic traverse, trained for
   ``--locsnet-epochs`` epochs, converted with regular (explicit) input spikes, so both
   backends receive the same spikes and their place-neuron counts must be identical.

Usage (from the repository root)::

    python benchmarks/batched_eval.py [--queries 200] [--batch-size 256] [--threads 1] [--dtypes float64,float32]
                                      [--fuse off,on] [--locsnet-places 100] [--out DIR]
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np
from tqdm.auto import tqdm

import neurovpr as nv
from neurovpr.fileio import atomic_write_text
from neurovpr.paths import shared_datasets

MODULE = 25


def _machine() -> str:
    return f"{platform.machine()}, {os.cpu_count()} CPUs, load average {os.getloadavg()[0]:.1f}"


def _torch_runs(
    batch_size: int, threads: int = 1, dtypes: tuple[str, ...] = ("float64",), fuse: tuple[bool, ...] = (False,)
) -> list[tuple[str, dict]]:
    """The torch backend's runs: on the CPU and on CUDA (device None: absent), in each of ``dtypes``, eager and/or fused.

    The first dtype's runs are labelled ``torch-cpu`` / ``torch-cuda``, the others get the
    dtype appended (``torch-cpu-float32``); runs with the option ``fuse`` get ``-fused``.
    """
    import torch

    cuda = "cuda" if torch.cuda.is_available() else None
    return [
        (f"torch-{name}" + ("" if k == 0 else f"-{dtype}") + ("-fused" if fused else ""),
         {"device": dev, "batch_size": batch_size, "threads": threads, "dtype": dtype, "fuse": fused})
        for k, dtype in enumerate(dtypes)
        for fused in fuse
        for name, dev in (("cpu", "cpu"), ("cuda", cuda))
    ]  # fmt: skip


def _timed(fn, *args, **kwargs):
    w, c = time.perf_counter(), time.process_time()
    out = fn(*args, **kwargs)
    return out, time.perf_counter() - w, time.process_time() - c


def modular(args: argparse.Namespace) -> dict:
    """Time one module's query phase on each backend; extrapolate one member of 500 and 2,400 places."""
    from neurovpr.models.modular_snn import ModuleParameters, TrainingSettings
    from neurovpr.models.modular_snn.deployment import static_network
    from neurovpr.models.modular_snn.plugin import load_traverse
    from neurovpr.models.modular_snn.training import Presenter, record_responses, train_module

    data = args.data or (shared_datasets() / "nordland64" if shared_datasets() else None)
    if data is None:
        raise SystemExit("no real data: set NEUROVPR_SHARED_DATA or pass --data")
    traverse = load_traverse(data)
    reference = traverse.reference.preprocessed()[:MODULE]
    n_q = min(args.queries, len(traverse.query))
    pick = np.linspace(0, len(traverse.query) - 1, n_q).astype(int)
    queries = traverse.query.preprocessed()[pick].reshape(n_q, -1)
    settings = TrainingSettings(params=ModuleParameters(integration=args.integration), epochs=args.epochs, module_size=MODULE)
    (network, _, _, _), t_train, _ = _timed(train_module, reference, np.arange(MODULE), settings, seed=1, name="module")
    print(f"trained one module on {MODULE} nordland64 places ({args.epochs} epoch(s)) in {t_train:.0f} s", flush=True)
    static = static_network(network)
    runs: dict[str, dict] = {}
    for label, backend, options in [
        ("reference", "reference", {}),
        *[(lbl, "torch", o) for lbl, o in _torch_runs(args.batch_size, args.threads, args.dtypes, args.fuse)],
    ]:
        if backend == "torch" and options["device"] is None:
            runs[label] = {"measured": False, "note": "not measured: no CUDA device on this machine"}
            continue
        sim = nv.compile(static, backend=backend, dt=settings.dt, seed=2, **options)
        sim.plasticity(False)
        # warm-up with one batch of the timed shape: numba's cache, torch's first calls
        _, warm, _ = _timed(record_responses, Presenter(sim, settings), queries[: min(n_q, args.batch_size)])
        sim.reset()
        with tqdm(total=n_q, desc=f"modular queries ({label})", unit="image", leave=False) as bar:
            counts, wall, cpu = _timed(record_responses, Presenter(sim, settings), queries, tick=bar.update)
        runs[label] = {
            "measured": True, "wall_s_per_module_image": wall / n_q, "cpu_s_per_module_image": cpu / n_q,
            "mean_spikes_per_image": float(counts.sum(axis=1).mean()), "warm_up_wall_s": warm,
        }  # fmt: skip
        for places in (500, 2400):
            module_images = math.ceil(places / MODULE) * places
            runs[label][f"member_{places}_places_wall_s_extrapolated"] = module_images * wall / n_q
            runs[label][f"member_{places}_places_cpu_s_extrapolated"] = module_images * cpu / n_q
        print(f"  {label}: {wall / n_q * 1e3:.1f} ms wall, {cpu / n_q * 1e3:.1f} ms CPU per module-image; "
              f"{runs[label]['mean_spikes_per_image']:.1f} spikes per image", flush=True)  # fmt: skip
    ref, ref_cpu = runs["reference"]["wall_s_per_module_image"], runs["reference"]["cpu_s_per_module_image"]
    for run in runs.values():
        if run.get("measured"):
            run["throughput_vs_reference"] = ref / run["wall_s_per_module_image"]
            run["cpu_throughput_vs_reference"] = ref_cpu / run["cpu_s_per_module_image"]
    return {"queries": n_q, "module_places": MODULE, "epochs": args.epochs, "train_seconds": t_train, "runs": runs}


def locsnet(args: argparse.Namespace) -> dict:
    """Time LoCS-Net queries on each backend with the same explicit input spikes; check the counts agree."""
    from neurovpr.data import synthetic_traverse
    from neurovpr.models.locsnet import SpikingClassifier, SpikingParameters, paper_architecture
    from neurovpr.models.locsnet.conversion import to_spiking_network
    from neurovpr.models.locsnet.preprocess import preprocess
    from neurovpr.models.locsnet.training import TrainingSettings, train

    places = args.locsnet_places
    traverse = synthetic_traverse(places, seed=0)
    arch = paper_architecture(places)
    ref = preprocess(traverse.reference.images(), arch.input_size)
    queries = preprocess(traverse.query.images(), arch.input_size)
    result = train(arch, ref, np.arange(places), TrainingSettings(epochs=args.locsnet_epochs, threads=1))
    spiking = SpikingParameters(input_coding="regular")
    net = to_spiking_network(arch, result.parameters, spiking)
    runs: dict[str, dict] = {}
    counts: dict[str, np.ndarray] = {}
    for label, backend, options in [
        ("reference", "reference", {}),
        *[(lbl, "torch", o) for lbl, o in _torch_runs(args.batch_size, args.threads, args.dtypes, args.fuse)],
    ]:
        if backend == "torch" and options["device"] is None:
            runs[label] = {"measured": False, "note": "not measured: no CUDA device on this machine"}
            continue
        clf = SpikingClassifier(net, arch, spiking, backend=backend, **options)
        clf.run(queries[: min(len(queries), args.batch_size)])  # warm-up: one batch of the timed shape
        out, wall, cpu = _timed(clf.run, queries, progress=True, desc=f"locsnet ({label})")
        counts[label] = out.counts
        runs[label] = {
            "measured": True,
            "wall_ms_per_query": wall / len(queries) * 1e3,
            "cpu_ms_per_query": cpu / len(queries) * 1e3,
        }
        this = runs[label]
        print(f"  {label}: {this['wall_ms_per_query']:.1f} ms wall, {this['cpu_ms_per_query']:.1f} ms CPU per query", flush=True)
    ref, ref_cpu = runs["reference"]["wall_ms_per_query"], runs["reference"]["cpu_ms_per_query"]
    for label, run in runs.items():
        if run.get("measured"):
            run["throughput_vs_reference"] = ref / run["wall_ms_per_query"]
            run["cpu_throughput_vs_reference"] = ref_cpu / run["cpu_ms_per_query"]
            run["identical_counts"] = bool(np.array_equal(counts[label], counts["reference"]))
            run["identical_predictions"] = bool(np.array_equal(counts[label].argmax(0), counts["reference"].argmax(0)))
    return {
        "places": places,
        "queries": len(queries),
        "epochs": args.locsnet_epochs,
        "architecture": arch.describe(),
        "runs": runs,
    }


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--data", type=Path, default=None, help="Modular SNN data (default: the shared nordland64)")
    p.add_argument("--queries", type=int, default=200, help="query images through the module")
    p.add_argument("--epochs", type=int, default=1, help="training epochs of the module")
    p.add_argument("--integration", choices=("euler", "exact"), default="euler",
                   help="the module's cell steps (ModuleParameters.integration; default euler, the model's)")  # fmt: skip
    p.add_argument("--batch-size", type=int, default=256, help="items the torch backend simulates at once")
    p.add_argument("--threads", type=int, default=1, help="the torch backend's CPU threads (its option threads)")
    p.add_argument("--dtypes", default="float64", help="the torch backend's dtypes to time, comma-separated (float64, float32)")
    p.add_argument("--fuse", default="off,on", help="the torch backend's option fuse to time, comma-separated (off, on)")
    p.add_argument("--locsnet-places", type=int, default=100)
    p.add_argument("--locsnet-epochs", type=int, default=5)
    p.add_argument("--skip", default="", help="comma-separated parts to skip: modular, locsnet")
    p.add_argument("--out", type=Path, default=Path("reports/batched_eval"))
    args = p.parse_args(argv)
    skip = {s for s in args.skip.split(",") if s}
    args.dtypes = tuple(d for d in args.dtypes.split(",") if d)
    if not args.dtypes or any(d not in ("float64", "float32") for d in args.dtypes):
        p.error(f"--dtypes: float64 and/or float32, got {','.join(args.dtypes) or 'nothing'}")
    fuse = [f for f in args.fuse.split(",") if f]
    if not fuse or any(f not in ("off", "on") for f in fuse):
        p.error(f"--fuse: off and/or on, got {args.fuse or 'nothing'}")
    args.fuse = tuple(f == "on" for f in fuse)
    print(f"machine: {_machine()}", flush=True)
    record: dict = {"machine": _machine(), "batch_size": args.batch_size, "torch_threads": args.threads}
    record["torch_dtypes"] = list(args.dtypes)
    record["torch_fuse"] = list(args.fuse)
    if "modular" not in skip:
        record["modular_snn"] = modular(args)
    if "locsnet" not in skip:
        record["locsnet"] = locsnet(args)
    record["load_average_after"] = os.getloadavg()[0]
    args.out.mkdir(parents=True, exist_ok=True)
    atomic_write_text(args.out / "batched_eval.json", json.dumps(record, indent=2))
    print(json.dumps(record, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
