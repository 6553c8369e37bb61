"""Modular SNN and its ensembles on real Nordland data, next to SAD and Perfect Memory.

Trains ``--members`` modular SNNs (default 5) on ``--places`` summer images of
``../shared/datasets/nordland64`` (reference) on the reference backend, in local worker
processes, shows them the winter images of the same places (query), and prints R@1 and
R@5 at sequence lengths 1, 2, 4 and 10 (Eq. 13) for: one modular SNN (member 0), the
ensembles of the first 3 and of all 5 members (Eq. 10), the mean of each ensemble's
members, SAD and Perfect Memory on the same 28x28 patch-normalised images. Ground truth:
query i matches reference i, zero tolerance. As the authors' code does, ``--calibration-places``
of the places (default: about 20 % in whole modules, 100 of 500) calibrate each member's
hyperactive threshold and are left out of the table: Recall@N is measured on the other
(reported) places and their queries only. Also reports how concentrated the ensemble's best
matches are (:func:`neurovpr.evaluation.match_concentration`), for every member the neurons
behind its most-chosen places at L = 1 (:mod:`neurovpr.models.modular_snn.anatomy`: the share of
their neurons kept as not hyperactive and the kept neurons' activity, against all places, and the
rank correlation of each place's wins with both; stored with the member's matrix, absent for
matrices saved before), the wall-clock and CPU time of training one module and what the full
2,400-place, 30-epoch run would cost at that rate.

Which places (``--subset``): ``vprsnn`` (default) keeps the frames that the Modular SNN
paper's code uses for Nordland (its image list in ``../shared/datasets/vprsnn_lists``,
which leaves out the stations and other segments where the train stands still; 1,892 of
the 2,400 nordland64 frames) and takes the first ``--places`` of them, in route order;
``first`` takes the first ``--places`` frames as they are (the route starts with about 20
near-identical frames in a station, which no method can tell apart).

Members on several machines. Every member's modules are seeded by the master seed and
the member index alone, and each member's similarity matrix is saved as
``similarity/m<member>.npz`` with the digests of its data and settings. ``--only-members
3,4`` trains just those members of the ``--members`` ensemble, shows them the query images
and saves their matrices; ``--combine`` then evaluates the ensembles from the saved matrices of all
members (copied into one ``--out``), refusing any whose data, settings or seed differ.

Epochs. ``--epochs`` is one count (default: the model's 30, the authors' Nordland
configuration) or several, e.g. ``--epochs 20,30,60``: then every member is trained once
per count (``epochs<E>/`` in ``--out``, each with its own ``run/`` and ``similarity/``) and
takes the count and hyperactive threshold with the best Recall@1 on the calibration places
(:func:`neurovpr.models.modular_snn.calibrate_epochs`), as the authors' README describes
the calibration of both (their released Nordland members: 60 and 70 epochs); the reported
places never choose.

Usage (from the repository root)::

    python benchmarks/modular_snn_nordland.py                   # defaults below
    python benchmarks/modular_snn_nordland.py --places 200 --epochs 20 --resume
    python benchmarks/modular_snn_nordland.py --members 5 --only-members 3,4   # on another machine
    python benchmarks/modular_snn_nordland.py --members 5 --combine            # after copying similarity/

Writes ``results.json``, PNG plots of the largest ensemble at sequence lengths 1 and the
longest (distance matrix, precision-recall and Recall@N curves, ``plots/``), the members'
matrices (``similarity/``) and the run (``run/``, resumable with ``--resume``) to ``--out``.
"""

from __future__ import annotations

import argparse
import io
import json
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np

from neurovpr.data.traverse import Traverse
from neurovpr.evaluation.metrics import distance_from_similarity
from neurovpr.fileio import atomic_write_bytes, atomic_write_text
from neurovpr.models.modular_snn import (
    ModuleParameters,
    TrainingSettings,
    calibrate_epochs,
    hub_anatomy,
    member_similarities,
    query_responses,
    train_run,
)
from neurovpr.models.modular_snn.parallel import default_workers
from neurovpr.models.modular_snn.plan import SEEDINGS, default_calibration_places, describe_plan
from neurovpr.models.modular_snn.plugin import load_traverse
from neurovpr.models.modular_snn.report import evaluate_similarities, write_plots
from neurovpr.models.modular_snn.runs import digest, reference_digest
from neurovpr.paths import shared_datasets

FULL_PLACES, FULL_EPOCHS, MODULE = 2400, 30, 25


_SUBSETS = {
    "vprsnn": "the first {n} places of the VPRSNN Nordland list (stops removed)",
    "first": "the first {n} places",
}


def select_places(traverse: Traverse, subset: str, n: int) -> Traverse:
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
    p.add_argument("--epochs", type=_counts, default=[TrainingSettings().epochs],
                   help="epochs per module, or several counts to calibrate per member, e.g. 20,30,60 (default: the "
                   "model's, 30: the paper's and the authors' Nordland one)")  # fmt: skip
    p.add_argument("--members", type=int, default=5, help="ensemble members (default 5)")
    p.add_argument("--calibration-places", type=int, default=None, help="places that calibrate the hyperactive threshold "
                   "and are not reported (default: about 20%% of --places in whole modules)")  # fmt: skip
    p.add_argument("--seq-lens", default="1,2,4,10", help="sequence lengths (default 1,2,4,10)")
    p.add_argument("--workers", type=int, default=None, help="worker processes (default: CPU cores)")
    p.add_argument("--seed", type=int, default=0, help="master seed (default 0)")
    p.add_argument("--out", type=Path, default=Path("reports/modular_snn_nordland"), help="output folder")
    p.add_argument("--resume", action="store_true", help="continue a run in --out")
    p.add_argument("--only-members", default=None, help="train and save only these members, e.g. 3,4 (see the docstring)")
    p.add_argument("--combine", action="store_true", help="evaluate from the saved matrices of every member in --out")
    p.add_argument("--integration", choices=("euler", "exact"), default="euler",
                   help="cell steps (ModuleParameters.integration; default euler, as the authors' code)")  # fmt: skip
    p.add_argument("--seeding", choices=SEEDINGS, default="module",
                   help="random draws: every module its own (default), or as the authors' code "
                        "(models/modular_snn/plan.py)")  # fmt: skip
    return p.parse_args()


def _counts(text: str) -> list[int]:
    """``--epochs``: one whole number >= 1 or several, comma-separated."""
    try:
        counts = sorted({int(x) for x in text.split(",")})
    except ValueError:
        raise argparse.ArgumentTypeError(f"epochs {text!r} is not a comma-separated list of whole numbers") from None
    if not counts or counts[0] < 1:
        raise argparse.ArgumentTypeError(f"epochs {text!r} must be whole numbers >= 1")
    return counts


_TIMING_KEYS = ("train_seconds_per_module", "train_cpu_seconds_per_module", "record_cpu_seconds_per_module")


def _member_key(args: argparse.Namespace, settings: TrainingSettings, reference: np.ndarray, query: np.ndarray) -> str:
    """What a saved member matrix must match to join an ensemble: data, settings, seed."""
    parts = [settings.as_dict(), reference_digest(reference), reference_digest(query), args.seed, args.subset, args.places]
    parts.append(args.calibration_places)
    if args.seeding != "module":  # matrices saved before the option existed keep their key
        parts.append(args.seeding)
    return digest(parts)


def _machine() -> str:
    """The machine a member was computed on, as the results name it."""
    return f"{platform.machine()}, {os.cpu_count()} CPUs"


def _save_member(folder: Path, member: int, sim: np.ndarray, key: str, info: dict, extra: dict) -> None:
    """``similarity/m<member>.npz``: the matrix (reported places x queries), its key, the reported places and
    queries, the member's hyperactive threshold, the run's timing per module and the machine."""
    timing = np.array([float(info[k]) for k in _TIMING_KEYS])
    machine = _machine()
    buf = io.BytesIO()
    np.savez_compressed(
        buf, similarity=sim.astype(np.float32), key=np.str_(key), timing=timing, machine=np.str_(machine),
        places=extra["places"], queries=extra["queries"], threshold=np.float64(extra["threshold"]),
        calibration_thresholds=np.array(sorted(extra["calibration"]), dtype=np.float64),
        calibration_recall=np.array([extra["calibration"][t] for t in sorted(extra["calibration"])], dtype=np.float64),
        **{f"anatomy_{name}": values for name, values in extra["anatomy"].items()},
    )  # fmt: skip
    atomic_write_bytes(folder / f"m{member:02d}.npz", buf.getvalue())


def _load_member(folder: Path, member: int, key: str) -> tuple[np.ndarray, dict]:
    path = folder / f"m{member:02d}.npz"
    if not path.is_file():
        raise SystemExit(f"{path} is missing: train member {member} (--only-members {member}) and copy its matrix here")
    with np.load(path) as f:
        if str(f["key"]) != key:
            raise SystemExit(f"{path} was computed from other data, settings or seed than this run")
        meta = dict(zip(_TIMING_KEYS, f["timing"].tolist(), strict=True), machine=str(f["machine"]))
        meta.update(places=f["places"].astype(np.int64), queries=f["queries"].astype(np.int64), threshold=float(f["threshold"]))
        # matrices saved before the anatomy was stored have none
        names = [k for k in f.files if k.startswith("anatomy_")]
        meta["anatomy"] = {k.removeprefix("anatomy_"): f[k] for k in names} if names else None
        # and before the calibration Recall@1 per threshold was stored
        if "calibration_recall" in f.files:
            meta["calibration"] = dict(zip(f["calibration_thresholds"].tolist(), f["calibration_recall"].tolist(), strict=True))
        else:
            meta["calibration"] = None
        return f["similarity"].astype(np.float64), meta


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
    traverse = select_places(load_traverse(data), args.subset, args.places)
    reference = traverse.reference.preprocessed()
    query = traverse.query.preprocessed()
    if args.calibration_places is None:
        args.calibration_places = default_calibration_places(args.places, MODULE)
    several = len(args.epochs) > 1
    only = None if args.only_members is None else sorted({int(x) for x in args.only_members.split(",")})
    start = time.perf_counter()
    keys: dict[int, str] = {}
    trained_now = 0
    for epochs in args.epochs:
        settings = TrainingSettings(params=ModuleParameters(integration=args.integration), epochs=epochs, module_size=MODULE)
        folder = args.out / f"epochs{epochs}" if several else args.out
        run_dir, sim_dir = folder / "run", folder / "similarity"
        keys[epochs] = key = _member_key(args, settings, reference, query)
        if args.combine:
            continue
        summary = train_run(
            run_dir, reference, settings, members=args.members, seed=args.seed, workers=workers, resume=args.resume,
            only_members=only, n_calibration=args.calibration_places, seeding=args.seeding,
        )  # fmt: skip
        info = summary["run_info"]
        trained_now += summary["trained_now"]
        counts = query_responses(run_dir, info, query, workers=workers)
        chosen = only if only is not None else list(range(args.members))
        ms = member_similarities(run_dir, info, counts, traverse.ground_truth, members=chosen)
        for k, m in enumerate(chosen):
            extra = {
                "places": ms.places, "queries": ms.queries, "threshold": ms.thresholds[k], "anatomy": ms.anatomy[k],
                "calibration": ms.calibration[k],
            }  # fmt: skip
            _save_member(sim_dir, m, ms.similarities[k], key, info, extra)
        if only is not None:
            wall = time.perf_counter() - start
            print(f"members {chosen} ({epochs} epochs) saved in {sim_dir} ({wall:.0f} s wall on {workers} workers)")
    if only is not None and not args.combine:
        return 0
    train_wall = time.perf_counter() - start
    loaded = [_choose_epochs(args, keys, m) for m in range(args.members)]
    sims = [sim for sim, _ in loaded]
    places, queries = loaded[0][1]["places"], loaded[0][1]["queries"]
    gt = traverse.ground_truth.subset(places, queries)
    ensembles = sorted({k for k in (3, args.members) if k <= args.members})
    results = {
        k: evaluate_similarities(sims[:k], reference[places], query[queries], gt, seq_lens=seq_lens) for k in ensembles
    }
    total_wall = time.perf_counter() - start
    timing = [{k: v for k, v in meta.items() if k in (*_TIMING_KEYS, "machine", "epochs")} for _, meta in loaded]
    # each member's own best matches at L = 1 against the neurons behind its places (saved with its matrix)
    hubs = {
        str(m): hub_anatomy(distance_from_similarity(sim), meta["anatomy"])
        for m, (sim, meta) in enumerate(loaded)
        if meta["anatomy"] is not None
    }
    thetas = [meta["threshold"] for _, meta in loaded]

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
    concentration = {s: results[ensembles[-1]]["by_seq_len"][s]["concentration"] for s in map(str, seq_lens)}

    # the timing summary comes from the members computed on this machine (all members if none was)
    here = [t for t in timing if t["machine"] == _machine()] or timing
    n_train = float(np.mean([t["train_seconds_per_module"] for t in here]))
    n_cpu = float(np.mean([t["train_cpu_seconds_per_module"] for t in here]))
    per_image = float(np.mean([t["train_cpu_seconds_per_module"] / (t["epochs"] * MODULE) for t in here]))
    rec_per_image = float(np.mean([t["record_cpu_seconds_per_module"] for t in here])) / args.places
    # a module of the full run: its training, then every reference image and every query image
    full_module_cpu = FULL_EPOCHS * MODULE * per_image + 2 * FULL_PLACES * rec_per_image
    out = {
        "data": str(data),
        "subset": f"{_SUBSETS[args.subset].format(n=args.places)} (reference = summer, query = winter), "
        f"{'/'.join(map(str, args.epochs))} epochs{' (calibrated per member)' if len(args.epochs) > 1 else ''}, "
        f"{MODULE} places per module, {args.members} members, seed {args.seed}",
        "plan": describe_plan(args.places, MODULE, args.calibration_places),
        "reported": {"places": int(places.size), "queries": int(queries.size)},
        "hyperactive_thetas": thetas,
        "epochs": [meta["epochs"] for _, meta in loaded],
        "calibration_recall_at_1": [meta["calibration_by_epochs"] for _, meta in loaded],
        "concentration": concentration,
        "hub_anatomy": hubs,
        "workers": workers,
        "table": table,
        "per_member": {s: results[ensembles[-1]]["by_seq_len"][s]["members"] for s in map(str, seq_lens)},
        "per_member_timing": timing,
        "timing": {
            "machine": here[0]["machine"],
            "members_timed": len(here),
            "train_seconds_per_module_wall": n_train,
            "train_seconds_per_module_cpu": n_cpu,
            "record_seconds_per_module_cpu": rec_per_image * args.places,
            "cpu_seconds_per_training_image": round(per_image, 4),
            "cpu_seconds_per_recorded_image": round(rec_per_image, 4),
            "full_run_estimate_cpu_seconds_per_module": round(full_module_cpu, 1),
            "full_run_estimate_cpu_hours_per_member": round(full_module_cpu * FULL_PLACES / MODULE / 3600, 1),
            "train_wall_seconds": None if args.combine else round(train_wall, 1),
            "total_wall_seconds": round(total_wall, 1),
            "trained_now": None if args.combine else trained_now,
        },
    }
    args.out.mkdir(parents=True, exist_ok=True)
    # distance matrix, PR curves and Recall@N of the largest ensemble, without and with the longest sequence
    biggest = ensembles[-1]
    plot_lens = sorted({1, max(seq_lens)})
    plots = [write_plots(results[biggest], args.out / "plots", n, tag=f"ensemble{biggest}_L{n}") for n in plot_lens]
    out["plots"] = sorted(str(f.relative_to(args.out)) for files in plots for f in files.values())
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
        f"\ntraining one module ({MODULE} places; {t['members_timed']} member(s) on {t['machine']}): "
        f"{t['train_seconds_per_module_wall']:.1f} s wall, "
        f"{t['train_seconds_per_module_cpu']:.1f} s CPU ({t['cpu_seconds_per_training_image']} s CPU per training image); "
        f"full {FULL_PLACES}-place, {FULL_EPOCHS}-epoch run: about {t['full_run_estimate_cpu_hours_per_member']} CPU hours "
        f"per member; this run: {t['total_wall_seconds']} s wall on {out['workers']} workers"
    )
    print(f"hyperactive thresholds per member (reference images fired for): {out['hyperactive_thetas']}")
    for m, (epochs, by_epochs) in enumerate(zip(out["epochs"], out["calibration_recall_at_1"], strict=True)):
        if by_epochs:
            best = ", ".join(f"{e} epochs {max(r.values()):.3f}" if r else f"{e} epochs n/a" for e, r in by_epochs.items())
            print(f"member {m}: {epochs} epochs; best calibration R@1 by epochs: {best}")
    for n in seq_lens:
        c, sad = out["concentration"][str(n)]["ensemble"], out["concentration"][str(n)]["SAD"]["top_share"]
        print(
            f"L={n}: best matches on {c['distinct_best_matches']} distinct places (ensemble), the most-chosen "
            f"{c['top_places']} places win {c['top_share']:.3f} of the queries (SAD {sad:.3f})"
        )
    for m, h in out["hub_anatomy"].items():
        top, every, rho = h["top"], h["all"], h["spearman_wins_vs"]
        print(
            f"member {m}, L=1: its most-chosen {h['top_places']} places (win {h['top_share']:.3f}) keep "
            f"{_fmt(top['kept_share'])} of their neurons (all places {_fmt(every['kept_share'])}), whose mean "
            f"activity is {_fmt(top['kept_activity'], '.1f')} reference images (all {_fmt(every['kept_activity'], '.1f')}); "
            f"rank correlation of wins with kept share {_fmt(rho['kept_share'])}, with kept activity "
            f"{_fmt(rho['kept_activity'])}, with mean similarity {_fmt(rho['mean_similarity'])}"
        )
    print(f"machines: {sorted({t['machine'] for t in out['per_member_timing']})}; results in results.json")


def _choose_epochs(args: argparse.Namespace, keys: dict[int, str], member: int) -> tuple[np.ndarray, dict]:
    """A member's matrix at its epoch count: the only one, or the one calibration chooses among several."""
    if len(args.epochs) == 1:
        sim, meta = _load_member(args.out / "similarity", member, keys[args.epochs[0]])
        by_epochs = {} if meta["calibration"] is None else {str(args.epochs[0]): meta["calibration"]}
        meta.update(epochs=args.epochs[0], calibration_by_epochs=by_epochs)
        return sim, meta
    found = {e: _load_member(args.out / f"epochs{e}" / "similarity", member, keys[e]) for e in args.epochs}
    old = [e for e, (_, meta) in found.items() if meta["calibration"] is None]
    if old:
        raise SystemExit(f"member {member}'s matrix at {old[0]} epochs was saved without its calibration Recall@1; recompute it")
    if any(meta["calibration"] == {} for _, meta in found.values()):
        raise SystemExit("choosing the epochs needs calibration places (--calibration-places above 0)")
    epochs, _ = calibrate_epochs({e: meta["calibration"] for e, (_, meta) in found.items()})
    sim, meta = found[epochs]
    meta.update(epochs=epochs, calibration_by_epochs={str(e): m["calibration"] for e, (_, m) in found.items()})
    return sim, meta


def _fmt(x: float | None, spec: str = ".2f") -> str:
    return "n/a" if x is None else format(x, spec)


if __name__ == "__main__":
    sys.exit(main())
