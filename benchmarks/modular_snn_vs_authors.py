"""The Modular SNN next to the authors' own code (QVPR/VPRSNN) on the same nordland64 places.

One modular SNN (one member, ``--seed``) on the first ``--places + --calibration-places``
places of the paper's filtered Nordland list in nordland64 (summer reference, winter
query, zero tolerance), split as VPRSNN splits them: ``--calibration-places`` random
places (the same for every seed) calibrate the hyperactive threshold, the other
``--places`` are the reported ones, cut at random into modules of 25. Both sides train
``--epochs`` epochs and assign neurons from the last ``--assignment-presentations``
training presentations.

- neurovpr: this repository's model with its defaults (the authors' code's behaviour,
  see :mod:`neurovpr.models.modular_snn`), reference backend, in local worker processes.
- the authors' code: with ``--authors PATH`` (a checkout of QVPR/VPRSNN) and
  ``--authors-python PYTHON`` (an environment with what it imports: Brian2, OpenCV,
  seaborn, scikit-learn, matplotlib), it is run unmodified except for its data loading
  (:mod:`vprsnn_oracle` says exactly what is adapted); ``--write-fixture`` stores the
  figures it produced, with this command, in ``benchmarks/fixtures/modular_snn_vprsnn_oracle.json``.
  Without ``--authors`` the figures come from that fixture.

Printed side by side: Recall@1 on the reported places (agreement: the difference within
two standard errors of the difference of two binomial proportions over the query count),
spikes per neuron per image (query and reference images; the ratio neurovpr / authors is
printed, no tolerance is claimed beyond it), neurons assigned per place, the largest
share of a module's neurons on one place, the hyperactive threshold and count. The
defaults are the settings of the stored fixture (75 reported and 25 calibration places,
5 epochs, assignment from the last 25 presentations, seed 0), so the plain command
compares with it.

``--theta T`` evaluates both sides at one fixed hyperactive threshold (reference images a
neuron fires for) instead of each member's threshold calibrated on 25 places (the authors'
side reuses its finished module steps and reruns only its test evaluation; its figures go
to a fixture of their own, which records the threshold). ``--seeding code`` trains this
model's side with the authors' code's random draws (:mod:`neurovpr.models.modular_snn.plan`).
``--first-member K`` compares this model's members K..K+N-1 (of a run of K+N members) with
the authors' same N seeds, to see how much the choice of members moves the ensemble figures.

Usage (from the repository root)::

    python benchmarks/modular_snn_vs_authors.py                        # the fixture vs neurovpr
    python benchmarks/modular_snn_vs_authors.py --authors ../VPRSNN --authors-python ../vprsnn-env/bin/python \\
        --workdir /tmp/vprsnn-run --write-fixture                      # rerun the authors' code too
"""

from __future__ import annotations

import argparse
import itertools
import json
import math
import os
import platform
import shlex
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
from modular_snn_nordland import select_places
from vprsnn_oracle import (
    OracleSettings,
    by_size,
    collect_facts,
    concentration_facts,
    ensemble_facts,
    neurons_vs_breadth,
    route_order_rates,
    run_authors,
    write_lists,
)

from neurovpr.data.traverse import Traverse
from neurovpr.evaluation.concentration import match_concentration
from neurovpr.evaluation.metrics import distance_from_similarity, recall_at_n
from neurovpr.fileio import atomic_write_text
from neurovpr.models.baselines import sad_distances
from neurovpr.models.modular_snn import (
    ModuleParameters,
    TrainingSettings,
    ensemble_similarity,
    hyperactive_neurons,
    member_similarities,
    query_responses,
    record_assignments,
    train_run,
)
from neurovpr.models.modular_snn.parallel import default_workers, read_npz
from neurovpr.models.modular_snn.plan import SEEDINGS, calibration_places
from neurovpr.models.modular_snn.plugin import load_traverse
from neurovpr.paths import shared_datasets

FIXTURE = Path(__file__).resolve().parent / "fixtures" / "modular_snn_vprsnn_oracle.json"
MODULE = 25


def _args(argv: list[str] | None = None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--places", type=int, default=75, help="reported (test) places (default 75)")
    p.add_argument("--calibration-places", type=int, default=25, help="calibration places (default 25)")
    p.add_argument("--epochs", type=int, default=5, help="training epochs of every module, both sides (default 5)")
    p.add_argument("--assignment-presentations", type=int, default=25, help="the code's --update_interval (default 25)")
    p.add_argument("--seed", type=int, default=0, help="member seed (default 0)")
    p.add_argument("--members", type=int, default=1,
                   help="members: the authors' code with seeds SEED .. SEED+N-1 (each in WORKDIR/S<seed> when N > 1), "
                        "neurovpr's members 0 .. N-1 of one run; N > 1 also compares the ensembles (default 1)")  # fmt: skip
    p.add_argument("--neurons", type=int, default=400, help="excitatory neurons per module (default 400)")
    p.add_argument("--authors", type=Path, default=None, help="a checkout of QVPR/VPRSNN: rerun it")
    p.add_argument("--authors-python", default=None, help="the Python that runs it (default: this one)")
    p.add_argument("--authors-revision", default=None, help="the checkout's commit, stored with the figures")
    p.add_argument("--authors-workers", type=int, default=1,
                   help="module steps of the authors' code run at once, each its own process (default 1)")  # fmt: skip
    p.add_argument("--workdir", type=Path, default=Path("reports/vprsnn_authors"), help="where the authors' code writes")
    p.add_argument("--write-fixture", action="store_true", help="store the authors' figures in the fixture")
    p.add_argument("--fixture", type=Path, default=FIXTURE, help="the fixture to read or write")
    p.add_argument("--out", type=Path, default=Path("reports/modular_snn_vs_authors"), help="neurovpr's run and results")
    p.add_argument("--workers", type=int, default=None, help="neurovpr's worker processes (default: CPU cores)")
    p.add_argument("--only-authors", action="store_true", help="run the authors' code only (no neurovpr side)")
    p.add_argument("--simulate-rest", action="store_true",
                   help="neurovpr side: the code's 150 ms rest between images instead of reset()")  # fmt: skip
    p.add_argument("--dt", type=float, default=None, help="neurovpr side: the time step, ms (default: the model's, 0.1)")
    p.add_argument("--delay-recurrent", type=float, default=None,
                   help="neurovpr side: the E->I and I->E delay, ms (default: the model's, 0 as in the code)")  # fmt: skip
    p.add_argument("--integration", choices=("exact", "euler"), default=None,
                   help="neurovpr side: how a step advances the cells (ModuleParameters.integration; default: the "
                        "model's; euler: the code's forward-Euler steps)")  # fmt: skip
    p.add_argument("--theta", type=int, default=None,
                   help="both sides at this fixed hyperactive threshold (reference images fired for) instead of each "
                        "member's calibrated one; the authors' finished module steps are reused")  # fmt: skip
    p.add_argument("--first-member", type=int, default=0,
                   help="neurovpr side: compare members K..K+N-1 of a run of K+N members (default 0; the authors' "
                        "seeds stay --seed..--seed+N-1)")  # fmt: skip
    p.add_argument("--seeding", choices=SEEDINGS, default="module",
                   help="neurovpr side: random draws, every module its own (default) or as the authors' code (every "
                        "module of a member the same initial weights, delays and Poisson streams; "
                        "models/modular_snn/plan.py)")  # fmt: skip
    return p.parse_args(argv)


def _settings(args: argparse.Namespace) -> OracleSettings:
    return OracleSettings(
        n_test=args.places, n_cal=args.calibration_places, module_size=MODULE, epochs=args.epochs, seed=args.seed,
        n_e=args.neurons, update_interval=args.assignment_presentations,
    )  # fmt: skip


def filtered_traverse(n: int) -> Traverse:
    """The first ``n`` places of the VPRSNN Nordland list in nordland64 (summer reference, winter query)."""
    shared = shared_datasets()
    if shared is None:
        raise SystemExit("no real data: set NEUROVPR_SHARED_DATA (nordland64 and vprsnn_lists are needed)")
    return select_places(load_traverse(shared / "nordland64"), "vprsnn", n)


def neurovpr_facts(args: argparse.Namespace, s: OracleSettings, traverse: Traverse) -> dict[str, Any]:
    """Train and evaluate ``--members`` modular SNNs here with the same settings.

    Returns the first member's figures (the same as :func:`collect_facts`) with ``"members"``
    (every member's), ``"ensembles"`` (with more than one member: for every set of two or
    more, the sum of their matrices, as :func:`ensemble_facts`) and ``"SAD"`` on the same places.
    """
    settings = TrainingSettings(
        params=ModuleParameters(
            n_neurons=s.n_e,
            **({} if args.integration is None else {"integration": args.integration}),
            **({} if args.delay_recurrent is None else {"delay_recurrent": args.delay_recurrent}),
        ),
        epochs=s.epochs, module_size=s.module_size,
        assignment_presentations=s.update_interval, simulate_rest=args.simulate_rest,
        **({} if args.dt is None else {"dt": args.dt}),
    )  # fmt: skip
    reference, query = traverse.reference.preprocessed(), traverse.query.preprocessed()
    run_dir = args.out / "run"
    workers = args.workers or default_workers()
    start, cpu = time.perf_counter(), time.process_time()
    first = args.first_member
    summary = train_run(
        run_dir, reference, settings, members=first + args.members, seed=s.seed, n_calibration=s.n_cal, workers=workers,
        resume=True, seeding=args.seeding, theta=None if args.theta is None else float(args.theta),
    )  # fmt: skip
    info = summary["run_info"]
    counts = query_responses(run_dir, info, query, workers=workers)
    chosen = list(range(first, first + args.members))
    ms = member_similarities(run_dir, info, counts, traverse.ground_truth, members=chosen)
    gt = traverse.ground_truth.subset(ms.places, ms.queries)
    members = [_member_facts(run_dir, info, counts, ms, gt, k, m, len(reference)) for k, m in enumerate(chosen)]
    sad = sad_distances(reference[ms.places], query[ms.queries], preprocess=False)  # the same 28x28 images
    out = {
        **members[0],
        "members": members,
        "first_member": first,
        "SAD": {"R@1": float(recall_at_n(sad, gt, [1])[1]), **match_concentration(sad)},
        "train_record_seconds_per_module_cpu": float(sum(info[f"{k}_cpu_seconds_per_module"] for k in ("train", "record"))),
        "wall_seconds": round(time.perf_counter() - start, 1),
        "main_process_cpu_seconds": round(time.process_time() - cpu, 1),
    }
    if args.members > 1:
        out["ensembles"] = {}
        for chosen in _subsets(args.members):
            ensemble = distance_from_similarity(ensemble_similarity([ms.similarities[i] for i in chosen]))
            out["ensembles"][_label(chosen)] = {
                "members": len(chosen), "R@1": float(recall_at_n(ensemble, gt, [1])[1]), **concentration_facts(ensemble),
            }  # fmt: skip
    return out


def _size_cells(v: dict[str, float], width: int) -> str:
    share, spread = v["most_chosen_share"], v["spread"]
    return f"{v['R@1']:>{width}.3f}{v['distinct_best_matches']:>10.1f}{share:>11.3f}{spread:>8.2f}"


def _subsets(n: int) -> list[tuple[int, ...]]:
    """Every ensemble of two or more of ``n`` members (member indices), smaller ones first."""
    return [c for k in range(2, n + 1) for c in itertools.combinations(range(n), k)]


def _label(members: tuple[int, ...]) -> str:
    return "+".join(map(str, members))


def _member_facts(
    run_dir: Path, info: dict, counts: dict, ms: Any, gt: Any, k: int, member: int, n_reference: int
) -> dict[str, Any]:
    """The figures of ``member`` (``ms``'s ``k``-th), the same as :func:`collect_facts` reads from the authors' outputs."""
    distances = distance_from_similarity(ms.similarities[k])
    theta = ms.thresholds[k]
    tested = [mod for mod in info["modules"] if not mod["calibration"] and int(mod["member"]) == member]
    records = [read_npz(run_dir / "modules" / f"{mod['name']}.npz") for mod in tested]
    q = np.concatenate([counts[mod["name"]][ms.queries] for mod in tested], axis=1)
    fired = np.concatenate([r["images_fired"] for r in records])
    spikes = np.concatenate([r["total_spikes"] for r in records])
    hyper = hyperactive_neurons(fired, theta)
    per_place, share, unassigned, assigned = [], [], 0, []
    for r in records:
        a = record_assignments(r)
        assigned.append(a)
        unassigned += int(np.count_nonzero(a < 0))
        c = np.bincount(a[a >= 0], minlength=n_reference)
        per_place.append(c[c > 0])
        share.append(float(c.max() / a.size))
    per_place_all = np.concatenate(per_place)
    return {
        "R@1": float(recall_at_n(distances, gt, [1])[1]),
        "queries": int(ms.queries.size),
        "hyperactive_threshold_images": float(theta),
        "calibration_R@1_by_threshold": {str(t): v for t, v in ms.calibration[k].items()},
        "hyperactive_neurons": int(hyper.sum()),
        "hyperactive_fraction": float(hyper.mean()),
        "spikes_per_neuron_per_query_image": float(q.mean()),
        "spikes_per_neuron_per_reference_image": float(spikes.mean() / n_reference),
        "silent_neuron_fraction_per_query_image": float(np.mean(q == 0)),
        "reference_images_fired_for_per_neuron_mean": float(fired.mean()),
        "unassigned_neurons": unassigned,
        "places_with_neurons": int(sum(c.size for c in per_place)),
        "neurons_per_assigned_place_mean": float(per_place_all.mean()),
        "neurons_per_assigned_place_max": int(per_place_all.max()),
        "largest_share_of_a_module_on_one_place": float(max(share)),
        "neurons_vs_breadth_rank_correlation": neurons_vs_breadth(np.concatenate(assigned), fired),
        **concentration_facts(distances),
    }


def _authors(args: argparse.Namespace, s: OracleSettings, argv: list[str]) -> dict[str, Any]:
    """Run the authors' code (see :mod:`vprsnn_oracle`) and return its figures; store them with ``--write-fixture``.

    With ``--members N`` > 1 each seed runs in its own work folder ``S<seed>`` (the code's output
    folders do not name the seed) and the record gains ``"members"`` (every seed's figures) and
    ``"ensembles"`` (for every set of two or more members, ``"0+1"``, ..., the sum of their
    route-ordered ``summed_rates``, as ``ens_seq/process_ensembles.py`` sums its members).
    """
    traverse = filtered_traverse(s.n_places)
    reference, query = list(traverse.reference.paths), list(traverse.query.paths)
    python = args.authors_python or sys.executable
    python = os.path.abspath(python) if os.sep in python else python  # the steps run in the work folder
    start = time.perf_counter()
    members, rates = [], []
    for seed in range(s.seed, s.seed + args.members):
        sk = s.with_seed(seed)
        workdir = (args.workdir if args.members == 1 else args.workdir / f"S{seed}").resolve()
        lists = write_lists(workdir, reference, query)
        run = run_authors(args.authors, python, workdir, sk, lists, workers=args.authors_workers, theta=args.theta)
        members.append(collect_facts(workdir, sk, run))
        rates.append(route_order_rates(workdir, sk, run["threshold"]))
        if seed == s.seed:
            shuffled = np.load(workdir / f"shuffled_indices_L{s.n_places}_S{s.seed}.npy", allow_pickle=False)
    record = {
        "what": "figures produced by the Modular SNN authors' code (QVPR/VPRSNN), run unmodified except for its "
        "data loading (benchmarks/vprsnn_oracle.py), on the nordland64 places named below",
        "command": "python benchmarks/modular_snn_vs_authors.py " + " ".join(shlex.quote(a) for a in _portable(argv)),
        "authors_revision": args.authors_revision,
        "settings": s.as_dict(),
        **({} if args.theta is None else {"theta": args.theta}),
        "data": f"nordland64, the first {s.n_places} places of the VPRSNN Nordland list (summer reference, winter query)",
        "calibration_places": sorted(int(i) for i in shuffled[: s.n_cal]),
        "machine": f"{platform.machine()}, {platform.python_version()}",
        "wall_seconds": round(time.perf_counter() - start, 1),
        "facts": members[0],
    }
    if args.members > 1:
        record.update(
            members=members, ensembles={_label(c): ensemble_facts([rates[i] for i in c]) for c in _subsets(args.members)}
        )
    if args.write_fixture:
        args.fixture.parent.mkdir(parents=True, exist_ok=True)
        atomic_write_text(args.fixture, json.dumps(record, indent=1) + "\n")
    return record


#: Options whose values are paths of the machine that ran the command: stored as placeholders.
_PATH_OPTIONS = {"--authors": "VPRSNN", "--authors-python": "VPRSNN_ENV/bin/python", "--workdir": "WORKDIR"}


def _portable(argv: list[str]) -> list[str]:
    """``argv`` with the values of :data:`_PATH_OPTIONS` replaced by placeholders (no machine's paths in the fixture)."""
    out = list(argv)
    for i, arg in enumerate(out[:-1]):
        if arg in _PATH_OPTIONS:
            out[i + 1] = _PATH_OPTIONS[arg]
    return out


def _agree(p1: float, p2: float, n: int) -> tuple[float, bool]:
    """Standard error of the difference of two independent proportions over ``n`` queries; within 2 of them?"""
    p = (p1 + p2) / 2
    se = math.sqrt(2 * p * (1 - p) / n) if 0 < p < 1 else 1.0 / n
    return se, abs(p1 - p2) <= 2 * se


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    args = _args(argv)
    s = _settings(args)
    if args.members < 1:
        print(f"--members is {args.members}; expected at least 1", file=sys.stderr)
        return 2
    if args.first_member < 0:
        print(f"--first-member is {args.first_member}; expected 0 or more", file=sys.stderr)
        return 2
    if args.theta is not None and args.theta < 0:
        print(f"--theta is {args.theta}; expected a whole number of reference images >= 0", file=sys.stderr)
        return 2
    if args.authors is not None:
        oracle = _authors(args, s, argv)
    elif args.fixture.is_file():
        oracle = json.loads(args.fixture.read_text())
    else:
        print(f"{args.fixture} is missing: pass --authors PATH to run the authors' code", file=sys.stderr)
        return 2
    if args.only_authors:
        print(json.dumps({k: oracle[k] for k in ("facts", "ensembles") if k in oracle}, indent=1))
        return 0
    held = len(oracle.get("members", [None]))  # fixtures of one member have no "members" entry
    if held != args.members:
        print(f"the fixture holds {held} member(s), not {args.members}; "
              "rerun the authors' code with this --members", file=sys.stderr)  # fmt: skip
        return 2
    if oracle["settings"] != s.as_dict():
        print(f"the fixture was made with {oracle['settings']}, not {s.as_dict()}; rerun the authors' code", file=sys.stderr)
        return 2
    if oracle.get("theta") != args.theta:
        made, asked = (("calibrated thresholds" if t is None else f"--theta {t}") for t in (oracle.get("theta"), args.theta))
        print(f"the fixture was made with {made}, not {asked}; rerun the authors' code with this --theta", file=sys.stderr)
        return 2
    ours = neurovpr_facts(args, s, filtered_traverse(s.n_places))
    if oracle.get("calibration_places") != calibration_places(s.n_places, s.n_cal).tolist():
        print("the calibration places differ from the authors' code's (same seed-42 draw expected)", file=sys.stderr)
        return 1
    _print(oracle, ours, s)
    args.out.mkdir(parents=True, exist_ok=True)
    atomic_write_text(args.out / "comparison.json", json.dumps({"authors": oracle, "neurovpr": ours}, indent=1))
    return 0


_ROWS = (
    ("R@1", "Recall@1 (reported places)"),
    ("spikes_per_neuron_per_query_image", "spikes per neuron per query image"),
    ("spikes_per_neuron_per_reference_image", "spikes per neuron per reference image"),
    ("silent_neuron_fraction_per_query_image", "silent neurons per query image (fraction)"),
    ("reference_images_fired_for_per_neuron_mean", "reference images a neuron fires for (mean)"),
    ("neurons_per_assigned_place_mean", "neurons per assigned place (mean)"),
    ("neurons_per_assigned_place_max", "neurons per assigned place (max)"),
    ("largest_share_of_a_module_on_one_place", "largest share of a module's neurons on one place"),
    ("neurons_vs_breadth_rank_correlation", "places: rank corr. of neuron count and breadth"),
    ("places_with_neurons", "places with at least one neuron"),
    ("unassigned_neurons", "unassigned neurons"),
    ("hyperactive_threshold_images", "hyperactive threshold (reference images)"),
    ("hyperactive_neurons", "hyperactive neurons"),
)


def _print(oracle: dict[str, Any], ours: dict[str, Any], s: OracleSettings) -> None:
    a, b = oracle["facts"], ours
    print(f"\nModular SNN vs the authors' code: {oracle['data']}")
    print(f"{s.n_test} reported places, {s.n_cal} calibration places, {s.epochs} epochs, seed {s.seed}; below: member 0")
    print(f"{'':<52}{'authors':>12}{'neurovpr':>12}")
    for key, label in _ROWS:
        if key in a:  # fixtures made before a figure was stored lack it
            print(f"{label:<52}" + "".join(f"{v:>12.4g}" if v is not None else f"{'n/a':>12}" for v in (a[key], b[key])))
    for key in ("spikes_per_neuron_per_query_image", "spikes_per_neuron_per_reference_image"):
        print(f"{key}: neurovpr / authors = {b[key] / a[key]:.2f}")
    if "most_chosen_share" in a:  # fixtures made before the concentration was stored lack it
        n_top = b["most_chosen_places"]
        print(f"{'best matches: distinct reference places':<52}{a['distinct_best_matches']:>12}{b['distinct_best_matches']:>12}")
        print(f"{f'queries won by the {n_top} most-chosen places (share)':<52}"
              f"{a['most_chosen_share']:>12.3f}{b['most_chosen_share']:>12.3f}")  # fmt: skip
    if "ensembles" in oracle:
        head = [("authors: R@1", 14), ("distinct", 10), ("top share", 11)]
        head += [("neurovpr: R@1", 15), ("distinct", 10), ("top share", 11)]
        print("\n" + " " * 24 + "".join(f"{h:>{w}}" for h, w in head))
        pairs = zip(oracle["members"], b["members"], strict=True)
        first = b["first_member"]
        rows = [(f"member {k} (seed {s.seed + k})" + (f"/{first + k}" if first else ""), x, y) for k, (x, y) in enumerate(pairs)]
        if len(oracle["members"]) <= 3:  # with more, every ensemble is in comparison.json; printed: means by size
            rows += [
                (f"ensemble of {label.replace('+', ', ')}", x, b["ensembles"][label]) for label, x in oracle["ensembles"].items()
            ]
        for label, x, y in rows:
            print(f"{label:<24}{x['R@1']:>14.3f}{x['distinct_best_matches']:>10}{x['most_chosen_share']:>11.3f}"
                  f"{y['R@1']:>15.3f}{y['distinct_best_matches']:>10}{y['most_chosen_share']:>11.3f}")  # fmt: skip
        a_sizes, b_sizes = by_size(oracle["members"], oracle["ensembles"]), by_size(b["members"], b["ensembles"])
        print("\nmeans over every ensemble of a size; spread: the share of them less concentrated than their members' mean")
        print(f"{'':<24}" + "".join(f"{h:>{w}}" for h, w in (*head[:3], ("spread", 8), *head[3:], ("spread", 8))))
        for n in a_sizes:
            cells = [_size_cells(v, w) for v, w in ((a_sizes[n], 14), (b_sizes[n], 15))]
            label = ("members" if n == 1 else f"ensembles of {n}") + f" ({a_sizes[n]['count']})"
            print(f"{label:<24}" + "".join(cells))
    sad = b["SAD"]
    print(f"SAD on the same places: R@1 {sad['R@1']:.3f}, best matches on {sad['distinct_best_matches']} places, "
          f"the {sad['top_places']} most-chosen win {sad['top_share']:.3f} of the queries")  # fmt: skip
    se, ok = _agree(a["R@1"], b["R@1"], s.n_test)
    print(f"\nR@1 difference {b['R@1'] - a['R@1']:+.3f}, standard error of the difference {se:.3f} over {s.n_test} queries: "
          f"{'within' if ok else 'NOT within'} 2 standard errors")  # fmt: skip


if __name__ == "__main__":
    sys.exit(main())
