"""AUC-ROC of the mushroom-body SNN, SeqSLAM and Perfect Memory on the same real route recordings.

For each ordered pair (LEARN, TEST) of the mbsnn_routes recordings (``../shared/datasets``):
the MBSNN learns the segment ``--segment`` (fractions of LEARN's moving part) with
plasticity on, then TEST's moving part is played through the naive and the trained
network (plasticity off); familiarity per window is the relative drop of the MBON rate.
SeqSLAM and Perfect Memory learn frames of PN spike counts of the same segment and score
the same windows. Positives are TEST's windows inside the segment by normalised time.

Every pair run is printed and written (``--out``: ``results.json``, one ROC plot and one
familiarity plot per pair, and a summary bar chart); nothing is left out of the table.
NB0 was recorded on a differing path (it is not a clean repeat of NB3-NB6); pairs with it
are run only when asked for with ``--pairs``.

Usage::

    python benchmarks/mbsnn_routes_auc.py [--pairs NB3:NB4,NB4:NB3,...] [--n-kc 4000]
        [--segment 0.4:0.6] [--windows 100] [--dt 0.1] [--stretch 1] [--out mbsnn_routes_auc]
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

from neurovpr.data.events import PNSpikes, read_pn_mat, stretch_time
from neurovpr.evaluation.metrics import auc_roc
from neurovpr.models.mbsnn import (
    KC_KC,
    MBSNNParameters,
    build_network,
    compile_mbsnn,
    familiarity,
    naive_weights,
    present,
    segment_labels,
)
from neurovpr.models.mbsnn.evaluation import baseline_scores, score
from neurovpr.models.mbsnn.plots import plot_familiarity, plot_roc_curves
from neurovpr.models.mbsnn.training import parse_segment
from neurovpr.paths import shared_datasets

RUNS = ("NB3", "NB4", "NB5", "NB6")
DEFAULT_PAIRS = [f"{a}:{b}" for a in RUNS for b in RUNS if a != b]


def load(root: Path, run: str) -> PNSpikes:
    """The moving part of one recording (210 PNs)."""
    files = sorted((root / "mbsnn_routes").glob(f"{run}_*.mat"))
    if not files:
        raise SystemExit(f"no recording {run}_*.mat in {root / 'mbsnn_routes'}")
    return read_pn_mat(files[0], n_pn=210).trim_inactive()


def plot_summary(rows: list[dict], path: Path) -> None:
    """Bar chart of the three methods' AUC-ROC per pair."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(max(6.0, 0.7 * len(rows) + 2), 3.8), dpi=100)
    FigureCanvasAgg(fig)
    ax = fig.add_subplot(1, 1, 1)
    x = np.arange(len(rows))
    for k, name in enumerate(("MBSNN", "SeqSLAM", "PerfectMemory")):
        ax.bar(x + (k - 1) * 0.27, [r[name]["AUC_ROC"] for r in rows], width=0.27, label=name)
    ax.set_xticks(x, [f"{r['learn']}->{r['test']}" for r in rows], rotation=45, fontsize=8)
    ax.set_ylim(0.0, 1.0)
    ax.axhline(0.5, color="gray", linewidth=0.8, linestyle="--")
    ax.set_ylabel("AUC-ROC")
    ax.set_title("Learned segment vs the rest of the route")
    ax.legend(fontsize=8, loc="lower right")
    fig.tight_layout()
    fig.savefig(path, format="png")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--pairs", default=",".join(DEFAULT_PAIRS), help="LEARN:TEST pairs, comma-separated")
    parser.add_argument("--segment", default="0.4:0.6", help="learned segment START:END (default 0.4:0.6)")
    parser.add_argument("--n-kc", type=int, default=4000)
    parser.add_argument("--windows", type=int, default=100)
    parser.add_argument("--dt", type=float, default=MBSNNParameters().dt)
    parser.add_argument("--stretch", type=float, default=1.0,
                        help="stretch the test recordings' time axis (a speed change; default 1)")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--out", type=Path, default=Path("mbsnn_routes_auc"))
    args = parser.parse_args(argv)

    root = shared_datasets()
    if root is None:
        print("the real recordings are not present (set NEUROVPR_SHARED_DATA or place ../shared/datasets)")
        return 2
    pairs = [tuple(p.split(":")) for p in args.pairs.split(",") if p]
    start, end = parse_segment(args.segment)
    params = MBSNNParameters(n_kc=args.n_kc, dt=args.dt)
    args.out.mkdir(parents=True, exist_ok=True)
    recordings = {run: load(root, run) for pair in pairs for run in pair}
    tests = {run: stretch_time(recordings[run], args.stretch) for _, run in pairs}
    network = build_network(210, params, seed=args.seed)
    sim = compile_mbsnn(network, dt=params.dt, seed=args.seed)
    naive = naive_weights(sim)
    labels = segment_labels(args.windows, start, end)
    before: dict[str, np.ndarray] = {}
    rows = []
    t_start = time.perf_counter()
    for learn, test in pairs:
        t0 = time.perf_counter()
        if test not in before:
            sim.set_weights(KC_KC, naive)
            before[test] = present(sim, tests[test], learn=False, progress=f"{test} naive").rates(args.windows)
        sim.set_weights(KC_KC, naive)
        segment = recordings[learn].segment(start, end)
        present(sim, segment, learn=True, progress=f"learn {learn}")
        after = present(sim, tests[test], learn=False, progress=f"{test} trained").rates(args.windows)
        scores = {"MBSNN": familiarity(before[test], after)}
        scores.update(baseline_scores(segment, tests[test], args.windows, share=end - start))
        results = {name: score(labels, s) for name, s in scores.items()}
        tag = f"{learn}_{test}"
        plot_roc_curves({n: (*r["_roc"], r["AUC_ROC"]) for n, r in results.items()}, args.out / f"roc_{tag}.png",
                        title=f"learn {learn} {start:g}-{end:g}, test {test}")  # fmt: skip
        plot_familiarity(args.out / f"familiarity_{tag}.png", scores, segment=(start, end),
                         title=f"Familiarity along {test} (learned on {learn})")  # fmt: skip
        row = {"learn": learn, "test": test, "seconds": round(time.perf_counter() - t0, 1)}
        row.update({n: {k: v for k, v in r.items() if not k.startswith("_")} for n, r in results.items()})
        row["MBSNN"]["auc_of_raw_rate_after"] = round(auc_roc(labels, -after), 6)
        rows.append(row)
        print(f"{learn}->{test}: MBSNN {row['MBSNN']['AUC_ROC']:.3f}  SeqSLAM {row['SeqSLAM']['AUC_ROC']:.3f}  "
              f"PerfectMemory {row['PerfectMemory']['AUC_ROC']:.3f}  ({row['seconds']} s)", flush=True)  # fmt: skip
    plot_summary(rows, args.out / "summary.png")
    means = {n: round(float(np.mean([r[n]["AUC_ROC"] for r in rows])), 4) for n in ("MBSNN", "SeqSLAM", "PerfectMemory")}
    summary = {
        "segment": [start, end], "stretch": args.stretch, "windows": args.windows, "n_kc": args.n_kc,
        "dt_ms": params.dt, "seed": args.seed,
        "pairs": rows, "mean_AUC_ROC": means, "total_seconds": round(time.perf_counter() - t_start, 1),
    }  # fmt: skip
    (args.out / "results.json").write_text(json.dumps(summary, indent=2), encoding="utf-8")
    print()
    print(f"{'pair':<12}{'MBSNN':>8}{'SeqSLAM':>9}{'PerfMem':>9}")
    for r in rows:
        print(f"{r['learn'] + '->' + r['test']:<12}{r['MBSNN']['AUC_ROC']:>8.3f}{r['SeqSLAM']['AUC_ROC']:>9.3f}"
              f"{r['PerfectMemory']['AUC_ROC']:>9.3f}")  # fmt: skip
    print(f"{'mean':<12}{means['MBSNN']:>8.3f}{means['SeqSLAM']:>9.3f}{means['PerfectMemory']:>9.3f}")
    print(f"written to {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
