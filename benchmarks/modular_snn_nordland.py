"""Modular SNN and its ensembles on real Nordland data, next to SAD and Perfect Memory.

Trains ``--members`` modular SNNs (default 5) on ``--places`` summer images of
``../shared/datasets/nordland64`` (reference) on the reference backend, in local worker
processes, shows them the winter images of the same places (query), and prints R@1 and
R@5 at sequence lengths 1, 2, 4 and 10 (Eq. 13) for: one modular SNN (member 0), the
ensembles of the first 3 and of all 5 members (Eq. 10), the mean of each ensemble's
members, SAD and Perfect Memory on the same 28x28 patch-normalised images. Ground truth:
query i matches reference i, zero tolerance. Also reports the wall-clock and CPU time of
training one module and what the full 2,400-place, 30-epoch run would cost at that rate.

Which places (``--subset``): ``vprsnn`` (default) keeps the frames that the Modular SNN
paper's code uses for Nordland (its image list in ``../shared/datasets/vprsnn_lists``,
which leaves out the stations and other segments where the train stands still; 1,892 of
the 2,400 nordland64 frames) and takes the first ``--places`` of them, in route order;
``first`` takes the first ``--places`` frames as they are (the route starts with about 20
near-identical frames in a station, which no method can tell apart).

Usage (from the repository root)::

    python benchmarks/modular_snn_nordland.py                   # defaults below
    python benchmarks/modular_snn_nordland.py --places 200 --epochs 30 --resume

Writes ``results.json`` and the run (``run/``, resumable with ``--resume``) to ``--out``.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

from neurovpr.data.traverse import Traverse
from neurovpr.fileio import atomic_write_text
from neurovpr.models.modular_snn import TrainingSettings, member_similarities, query_responses, train_run
from neurovpr.models.modular_snn.parallel import default_workers
from neurovpr.models.modular_snn.plugin import load_traverse
from neurovpr.models.modular_snn.report import evaluate_similarities
from neurovpr.paths import shared_datasets

FULL_PLACES, FULL_EPOCHS, MODULE = 2400, 30, 25


_SUBSETS = {
    "vprsnn": "the first {n} places of the VPRSNN Nordland list (stops removed)",
    "first": "the first {n} places",
}


def _select(traverse: Traverse, subset: str, n: int) -> Traverse:
    """The ``n`` places of ``subset`` (see the module docstring)."""
    if subset == "first":
        return traverse.first(n)
    shared = shared_datasets()
    listing = None if shared is None else shared / "vprsnn_lists" / "dataset_imagenames" / "nordland_imageNames_spring.txt"
    if listing is None or not listing.is_file():
        raise SystemExit("--subset vprsnn needs ../shared/datasets/vprsnn_lists; use --subset first")
    kept = {Path(line.strip()).name for line in listing.read_text().splitlines() if line.strip()}
    idx = np.array([i for i, name in enumerate(traverse.reference.names) if name in kept])[:n]
    if idx.size < n:
        raise SystemExit(f"only {idx.size} places of {traverse.name} are in the VPRSNN list, fewer than --places {n}")
    return traverse.subset(idx, idx)


def _args() -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--data", type=Path, default=None, help="dataset (default ../shared/datasets/nordland64)")
    p.add_argument("--places", type=int, default=100, help="number of places (default 100)")
    p.add_argument("--subset", choices=("vprsnn", "first"), default="vprsnn", help="which places (default vprsnn)")
    p.add_argument("--epochs", type=int, default=20, help="epochs per module (default 20; the paper uses 30)")
    p.add_argument("--members", type=int, default=5, help="ensemble members (default 5)")
    p.add_argument("--seq-lens", default="1,2,4,10", help="sequence lengths (default 1,2,4,10)")
    p.add_argument("--workers", type=int, default=None, help="worker processes (default: CPU cores)")
    p.add_argument("--seed", type=int, default=0, help="master seed (default 0)")
    p.add_argument("--out", type=Path, default=Path("reports/modular_snn_nordland"), help="output folder")
    p.add_argument("--resume", action="store_true", help="continue a run in --out")
    return p.parse_args()


def main() -> int:
    args = _args()
    data = args.data
    if data is None:
        shared = shared_datasets()
        if shared is None:
            print("no real data: set NEUROVPR_SHARED_DATA or pass --data", file=sys.stderr)
            return 2
        data = shared / "nordland64"
    seq_lens = [int(x) for x in args.seq_lens.split(",")]
    workers = args.workers or default_workers()
    traverse = _select(load_traverse(data), args.subset, args.places)
    reference = traverse.reference.preprocessed()
    query = traverse.query.preprocessed()
    settings = TrainingSettings(epochs=args.epochs, module_size=MODULE)
    run_dir = args.out / "run"
    start = time.perf_counter()
    summary = train_run(run_dir, reference, settings, members=args.members, seed=args.seed, workers=workers, resume=args.resume)
    train_wall = time.perf_counter() - start
    info = json.loads((run_dir / "run.json").read_text())
    counts = query_responses(run_dir, info, query, workers=workers)
    sims = member_similarities(run_dir, info, counts)
    ensembles = sorted({k for k in (3, args.members) if k <= args.members})
    results = {k: evaluate_similarities(sims[:k], reference, query, traverse.ground_truth, seq_lens=seq_lens) for k in ensembles}
    total_wall = time.perf_counter() - start

    table: dict[str, dict[str, dict[str, float]]] = {}
    for seq_len in map(str, seq_lens):
        first = results[ensembles[0]]["by_seq_len"][seq_len]
        rows = {"Modular SNN (member 0)": first["members"][0]}
        for k in ensembles:
            level = results[k]["by_seq_len"][seq_len]
            rows[f"Ensemble of {k}"] = level["ensemble"]
            rows[f"  mean of its {k} members"] = level["mean_of_members"]
        rows.update(first["baselines"])
        table[seq_len] = {name: {"R@1": m["R@1"], "R@5": m["R@5"]} for name, m in rows.items()}

    n_train = info["train_seconds_per_module"]
    n_cpu = info["train_cpu_seconds_per_module"]
    per_image = n_cpu / (args.epochs * MODULE)
    rec_per_image = info["record_cpu_seconds_per_module"] / args.places
    full_module_cpu = FULL_EPOCHS * MODULE * per_image + FULL_PLACES * rec_per_image
    out = {
        "data": str(data),
        "subset": f"{_SUBSETS[args.subset].format(n=args.places)} (reference = summer, query = winter), {args.epochs} epochs, "
        f"{MODULE} places per module, {args.members} members, seed {args.seed}",
        "plan": info["plan"],
        "hyperactive_thetas": info["hyperactive"]["thetas"],
        "workers": workers,
        "table": table,
        "per_member": {s: results[ensembles[-1]]["by_seq_len"][s]["members"] for s in map(str, seq_lens)},
        "timing": {
            "train_seconds_per_module_wall": n_train,
            "train_seconds_per_module_cpu": n_cpu,
            "record_seconds_per_module_cpu": info["record_cpu_seconds_per_module"],
            "cpu_seconds_per_training_image": round(per_image, 4),
            "cpu_seconds_per_recorded_image": round(rec_per_image, 4),
            "full_run_estimate_cpu_seconds_per_module": round(full_module_cpu, 1),
            "full_run_estimate_cpu_hours_per_member": round(full_module_cpu * FULL_PLACES / MODULE / 3600, 1),
            "train_wall_seconds": round(train_wall, 1),
            "total_wall_seconds": round(total_wall, 1),
            "trained_now": summary.get("trained_now"),
        },
    }
    args.out.mkdir(parents=True, exist_ok=True)
    atomic_write_text(args.out / "results.json", json.dumps(out, indent=1))
    _print(out, seq_lens)
    return 0


def _print(out: dict, seq_lens: list[int]) -> None:
    print(f"\nModular SNN on {out['data']}: {out['subset']}; {out['plan']}")
    head = "".join(f"{f'L={n} R@1':>10}{f'L={n} R@5':>10}" for n in seq_lens)
    print(f"{'method':<28}{head}")
    for name in out["table"][str(seq_lens[0])]:
        cells = "".join(f"{out['table'][str(n)][name]['R@1']:>10.3f}{out['table'][str(n)][name]['R@5']:>10.3f}" for n in seq_lens)
        print(f"{name:<28}{cells}")
    t = out["timing"]
    print(
        f"\ntraining one module ({MODULE} places): {t['train_seconds_per_module_wall']:.1f} s wall, "
        f"{t['train_seconds_per_module_cpu']:.1f} s CPU ({t['cpu_seconds_per_training_image']} s CPU per training image); "
        f"full {FULL_PLACES}-place, {FULL_EPOCHS}-epoch run: about {t['full_run_estimate_cpu_hours_per_member']} CPU hours "
        f"per member; this run: {t['total_wall_seconds']} s wall on {out['workers']} workers"
    )
    hyper = np.round(out["hyperactive_thetas"], 1).tolist()
    print(f"hyperactive thresholds per member: {hyper}; results in results.json")


if __name__ == "__main__":
    sys.exit(main())
