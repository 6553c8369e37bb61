"""LoCS-Net on real Nordland data: off-chip vs on-chip accuracy, cores and energy per inference.

Trains LoCS-Net (the default architecture, 56x56 input) on the 2,400 summer images of
``../shared/datasets/nordland64`` (one place per frame: the set is every 10th frame of
the videos, close to the paper's every 8th; the paper's 3,072 places are not available
here) and queries it with the 2,400 winter images (ground truth: query i is place i).
Two variants show what hardware-aware training buys:

- ``plain``: no weight regularisation, float weights;
- ``hw-aware``: L2 weight regularisation and quantisation-aware training to Kapoho Bay's
  8-bit weights (``--quantise kapoho-bay``).

Each variant is evaluated, on the same queries, as the rate model (numpy), as a
spiking network on ``reference`` (all queries) and on ``nengo``, ``nengo-loihi``,
``lava`` and ``lava-fixed`` (``--slow-queries`` evenly spaced queries; each backend in
its own process with a time limit, and the reference on the same subset for
comparison). Off-chip: reference, nengo, lava; on-chip: nengo-loihi (NengoLoihi's
Loihi emulator) and lava-fixed (bit-accurate Loihi 2). The fit on ``kapoho-bay`` and
``loihi2`` comes from neurovpr's checker (NengoLoihi's block splitting), the energy per
inference from the activity counted on the reference backend and each hwspec's energy
per operation, next to the paper's 0.060 J on Kapoho Bay.

Usage (from the repository root)::

    python benchmarks/locsnet_nordland.py [--epochs 40] [--slow-queries 100] [--out reports/locsnet_nordland]

Writes ``results.json`` and the run directories (``<out>/<variant>/``) to ``--out``;
``--resume`` reuses finished runs.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
import traceback
from pathlib import Path
from typing import Any

import numpy as np

SLOW_BACKENDS = ("nengo", "nengo-loihi", "lava", "lava-fixed")
ON_CHIP = {"nengo-loihi", "lava-fixed"}
VARIANTS: dict[str, dict[str, Any]] = {
    "plain": {"weight_decay": 0.0},
    "hw-aware": {"weight_decay": 1e-4, "quantise": "kapoho-bay"},
}


def _train(data: Path, out: Path, epochs: int, options: dict[str, Any], resume: bool) -> dict[str, Any]:
    from neurovpr import models

    return models.get("locsnet").train(data=data, out=out, epochs=epochs, resume=resume, **options)


def _inputs(run_dir: Path, data: Path) -> tuple[Any, np.ndarray, np.ndarray, np.ndarray]:
    from neurovpr.data import open_traverse
    from neurovpr.models.locsnet.places import place_ground_truth
    from neurovpr.models.locsnet.preprocess import preprocess
    from neurovpr.models.locsnet.runs import load_run

    run = load_run(run_dir)
    traverse = open_traverse(data)
    size = tuple(run.info["preprocess"]["size"])
    queries = preprocess(traverse.query.images(progress=True), size, patch_norm=run.info["preprocess"]["patch_norm"])
    reference = preprocess(traverse.reference.images(progress=True), size, patch_norm=run.info["preprocess"]["patch_norm"])
    return run, queries, reference, place_ground_truth(traverse.ground_truth, run.labels)


def _metrics(similarity: np.ndarray, gt: np.ndarray) -> dict[str, float]:
    from neurovpr.models.locsnet.report import score, similarity_distances

    return score(similarity_distances(similarity), gt)[0]


def _backend_job(run_dir: Path, data: Path, backend: str, q_idx: list[int]) -> dict[str, Any]:
    """Evaluate one backend on a subset of queries (runs in a fresh interpreter, see :func:`_run_backend`)."""
    try:
        from neurovpr.models.locsnet.inference import SpikingClassifier

        run, queries, _, gt = _inputs(run_dir, data)
        idx = np.asarray(q_idx)
        t0 = time.perf_counter()
        clf = SpikingClassifier(run.network, run.arch, run.spiking, backend=backend, seed=0)
        compile_s = time.perf_counter() - t0
        res = clf.run(queries[idx], progress=True, desc=backend)
        return {"backend": backend, "metrics": _metrics(res.counts, gt[:, idx]), "queries": int(idx.size),
                "compile_seconds": compile_s, "seconds_per_query": float(np.median(res.seconds)),
                "counts": res.counts.tolist(), "layer_spikes": res.layer_spikes}
    except Exception as exc:  # reported, not hidden
        return {"backend": backend, "error": f"{type(exc).__name__}: {exc}", "traceback": traceback.format_exc()[-2000:]}


def _run_backend(run_dir: Path, data: Path, backend: str, q_idx: np.ndarray, timeout: float) -> dict[str, Any]:
    """:func:`_backend_job` in a new Python process (Lava needs a fresh process that can fork its workers)."""
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "result.json"
        cmd = [sys.executable, str(Path(__file__).resolve()), "--backend-job", backend, "--run-dir", str(run_dir),
               "--data", str(data), "--job-queries", ",".join(str(int(i)) for i in q_idx), "--job-result", str(out)]
        try:
            proc = subprocess.run(cmd, timeout=timeout, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
        except subprocess.TimeoutExpired:
            return {"backend": backend, "error": f"no result within {timeout:.0f} s (time limit)"}
        if not out.is_file():
            return {"backend": backend, "error": f"the evaluation process exited with {proc.returncode}: "
                                                 f"{proc.stderr.strip().splitlines()[-1] if proc.stderr.strip() else ''}"}
        return json.loads(out.read_text(encoding="utf-8"))


def _slow_backends(run_dir: Path, data: Path, rates: np.ndarray, gt: np.ndarray, ref_counts: np.ndarray | None,
                   slow_queries: int, timeout: float, backends: tuple[str, ...]) -> dict[str, Any]:
    """Each slow backend on ``slow_queries`` evenly spaced queries, next to the reference and the rate model on them."""
    q_idx = np.unique(np.linspace(0, gt.shape[1] - 1, slow_queries).astype(int))
    if ref_counts is None:
        ref = _run_backend(run_dir, data, "reference", q_idx, timeout)
        ref_sub = np.asarray(ref["counts"]) if "counts" in ref else None
    else:
        ref_sub = ref_counts[:, q_idx]
    out: dict[str, Any] = {}
    for backend in backends:
        print(f"  {backend} on {q_idx.size} queries ...", flush=True)
        r = _run_backend(run_dir, data, backend, q_idx, timeout)
        r["queries"] = int(q_idx.size)
        r["rate_model_same_queries"] = _metrics(rates[:, q_idx], gt[:, q_idx])
        if ref_sub is not None:
            r["reference_same_queries"] = _metrics(ref_sub, gt[:, q_idx])
        if "counts" in r:
            counts = np.asarray(r.pop("counts"))
            if ref_sub is not None:
                r["argmax_agreement_with_reference"] = float(np.mean(counts.argmax(0) == ref_sub.argmax(0)))
        out[backend] = r
        print(f"  {backend}: {r.get('metrics', r.get('error'))}", flush=True)
    return out


def evaluate_variant(
    run_dir: Path, data: Path, slow_queries: int, timeout: float, backends: tuple[str, ...] = SLOW_BACKENDS,
    previous: dict[str, Any] | None = None,
) -> dict[str, Any]:
    """Every backend on one trained run; fit and energy on the hwspecs.

    With ``previous`` (an earlier result of the same run) only the slow ``backends`` are
    evaluated again; everything else is kept.
    """
    from neurovpr.hardware.check import check_network
    from neurovpr.hardware.energy import estimate_energy, read_activity
    from neurovpr.models.locsnet.inference import SpikingClassifier, rate_forward
    from neurovpr.models.locsnet.report import sad_place_distances, score, write_activity

    run, queries, reference, gt = _inputs(run_dir, data)
    rates = rate_forward(run.arch, run.params, queries)["places"].T
    # the training images themselves (reference image i is place i): how well the places are learned
    seen = _metrics(rate_forward(run.arch, run.params, reference)["places"].T, gt)
    if previous is not None:
        out = dict(previous)
        out.pop("subset", None)  # the layout of an earlier version of this script
        out["rate_model_training_images"] = seen
        out.setdefault("backends", {}).update(
            _slow_backends(run_dir, data, rates, gt, None, slow_queries, timeout, backends))
        return out
    out = {"training": run.info.get("timing"), "history_last": run.info["history"][-1]}
    out["rate_model"] = _metrics(rates, gt)
    out["rate_model_training_images"] = seen
    out["SAD"] = score(sad_place_distances(reference, queries, run.labels), gt)[0]
    clf = SpikingClassifier(run.network, run.arch, run.spiking, seed=0)
    res = clf.run(queries, progress=True, desc="all queries")
    write_activity(run_dir, res, run.spiking.dt)
    out["reference"] = {"metrics": _metrics(res.counts, gt), "queries": int(queries.shape[0]),
                        "seconds_per_query": float(np.median(res.seconds)),
                        "cpu_seconds_per_query": res.cpu_seconds / queries.shape[0], "activity": res.activity,
                        "layer_spikes": res.layer_spikes}
    out["backends"] = _slow_backends(run_dir, data, rates, gt, res.counts, slow_queries, timeout, backends)
    activity = read_activity(run_dir / "activity.json")
    out["hardware"] = {}
    for hw in ("kapoho-bay", "loihi2"):
        report = check_network(run.network, hw)
        entry: dict[str, Any] = {"fits": report.fits, "chips": report.partition.chips, "cores": len(report.partition.cores),
                                 "violations": [v.as_dict() for v in report.partition.violations]}
        try:
            entry["energy"] = estimate_energy(activity, report.spec, network=run.network).as_dict()
        except Exception as exc:  # reported, not hidden
            entry["energy_error"] = f"{type(exc).__name__}: {exc}"
        out["hardware"][hw] = entry
    return out


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--data", type=Path, default=None, help="nordland64 folder (default: ../shared/datasets/nordland64)")
    p.add_argument("--epochs", type=int, default=40)
    p.add_argument("--slow-queries", type=int, default=100)
    p.add_argument("--timeout", type=float, default=3600.0, help="seconds per slow backend")
    p.add_argument("--variants", default=",".join(VARIANTS))
    p.add_argument("--out", type=Path, default=Path("reports/locsnet_nordland"))
    p.add_argument("--resume", action="store_true", help="reuse finished runs (and results, with --backends)")
    p.add_argument("--backends", default=",".join(SLOW_BACKENDS), help="slow backends to evaluate")
    p.add_argument("--backend-job", default=None, help=argparse.SUPPRESS)
    p.add_argument("--run-dir", type=Path, default=None, help=argparse.SUPPRESS)
    p.add_argument("--job-queries", default=None, help=argparse.SUPPRESS)
    p.add_argument("--job-result", type=Path, default=None, help=argparse.SUPPRESS)
    args = p.parse_args(argv)
    if args.backend_job is not None:
        q_idx = [int(i) for i in args.job_queries.split(",")]
        result = _backend_job(args.run_dir, args.data, args.backend_job, q_idx)
        args.job_result.write_text(json.dumps(result), encoding="utf-8")
        return 0
    from neurovpr.paths import shared_datasets

    data = args.data
    if data is None:
        root = shared_datasets()
        if root is None:
            print("real data not found: set NEUROVPR_SHARED_DATA or pass --data", file=sys.stderr)
            return 2
        data = root / "nordland64"
    results: dict[str, Any] = {}
    args.out.mkdir(parents=True, exist_ok=True)
    backends = tuple(b for b in args.backends.split(",") if b)
    if args.resume and (args.out / "results.json").is_file():
        results = json.loads((args.out / "results.json").read_text(encoding="utf-8"))
    for variant in args.variants.split(","):
        run_dir = args.out / variant
        print(f"== {variant}: training ({VARIANTS[variant]})", flush=True)
        summary = _train(data, run_dir, args.epochs, VARIANTS[variant], args.resume)
        print(f"   {summary}", flush=True)
        results[variant] = evaluate_variant(run_dir, data, args.slow_queries, args.timeout, backends,
                                            previous=results.get(variant) if args.resume else None)
        (args.out / "results.json").write_text(json.dumps(results, indent=2), encoding="utf-8")
    for variant, r in results.items():
        print(f"\n{variant}: rate model P@100R {r['rate_model']['P@100R']:.3f} AUC {r['rate_model']['AUC_PR']:.3f}; "
              f"reference (all {r['reference']['queries']}) P@100R {r['reference']['metrics']['P@100R']:.3f} "
              f"AUC {r['reference']['metrics']['AUC_PR']:.3f}; SAD P@100R {r['SAD']['P@100R']:.3f}; "
              f"rate model on its training (summer) images R@1 {r['rate_model_training_images']['R@1']:.3f}")
        for name, b in r.get("backends", {}).items():
            tag = "on-chip" if name in ON_CHIP else "off-chip"
            if "metrics" in b:
                same = b.get("reference_same_queries", {})
                print(f"  {name:<12} ({tag}, {b['queries']} queries): P@100R {b['metrics']['P@100R']:.3f} "
                      f"AUC {b['metrics']['AUC_PR']:.3f}; reference on the same queries P@100R "
                      f"{same.get('P@100R', float('nan')):.3f}; {b['seconds_per_query']:.2f} s/query")
            else:
                print(f"  {name:<12} ({tag}): {b.get('error')}")
        for hw, h in r["hardware"].items():
            joules = h.get("energy", {}).get("joules_per_inference") if isinstance(h.get("energy"), dict) else None
            print(f"  {hw}: fits {h['fits']}, {h['cores']} cores, {h['chips']} chip(s), "
                  f"energy {joules if joules is not None else h.get('energy_error')} J/inference (paper: 0.060 J)")
    print(f"wrote {args.out / 'results.json'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
