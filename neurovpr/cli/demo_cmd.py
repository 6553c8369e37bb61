"""``neurovpr demo``: a short tour of what neurovpr is for, on embedded data.

One network run on every installed backend, fit checks that fit and that fail with
what would make them fit, off- vs on-chip accuracy and energy of a small trained
LoCS-Net, and the Modular SNN next to SAD (:mod:`neurovpr.apps.tour`). Writes one HTML
report with the PNGs embedded, ``summary.json`` and the PNGs, and prints where.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any


def add_parser(sub: argparse._SubParsersAction) -> None:
    """Register the subcommand."""
    p = sub.add_parser("demo", help="a few-minute tour: backends, fit checks, on-chip accuracy, Modular SNN vs SAD")
    p.add_argument("--out", type=Path, default=Path("reports/demo"), help="report folder (default: reports/demo)")
    p.add_argument("--size", choices=("full", "tiny"), default="full",
                   help="full (the tour, a few minutes) or tiny (every part at toy sizes, about a minute)")  # fmt: skip
    p.add_argument("--workers", type=int, default=None, help="worker processes of the Modular SNN (default: the CPU cores)")
    p.add_argument("--seed", type=int, default=1, help="random seed (default 1)")
    p.add_argument("--json", action="store_true", help="print the summary as one JSON object")
    p.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    """Run the tour and print its tables and the report's path."""
    from neurovpr.apps.tour import TourSize, run_tour

    size = TourSize.tiny() if args.size == "tiny" else TourSize()
    log = None if args.json else (lambda text: print(f"neurovpr demo: {text}", file=sys.stderr, flush=True))
    summary = run_tour(args.out, size=size, seed=args.seed, workers=args.workers, log=log)
    if args.json:
        print(json.dumps(summary))
    else:
        _print(summary)
    return 0


def _print(summary: dict[str, Any]) -> None:
    out = sys.stdout
    b = summary["backends"]
    print(f"1. {b['network']}, {b['duration_ms']:g} ms, on every backend (agreement with {b['reference_backend']}):", file=out)
    for r in b["rows"]:
        corr = "-" if r["count_correlation"] is None else f"{r['count_correlation']:.3f}"
        print(f"   {r['backend']:<12} r(counts) {corr:>6}  identical {r['identical_counts']:.2f}"
              f"  {r['seconds_per_simulated_second']:.3g} s per simulated s", file=out)  # fmt: skip
    for name, why in b["refused"].items():
        print(f"   {name:<12} not run: {why}", file=out)
    print("2. fit checks:", file=out)
    for c in summary["fit"]:
        verdict = "fits" if c["fits"] else f"does not fit ({len(c['violations'])} limits broken)"
        print(f"   {c['network']:<8} on {c['hardware']:<11} {c['cores']:>4} cores {c['chips']:>2} chip(s): {verdict}", file=out)
        for v in c["violations"][:3]:
            print(f"      {v['message']} Would fit: {v['remedy']}.", file=out)
    o = summary["onchip"]
    print(f"3. off-chip vs on-chip (LoCS-Net, energy on {o['hardware']}):", file=out)
    for r in o["rows"]:
        joules = "-" if r["joules_per_inference"] is None else f"{r['joules_per_inference']:.3g} J"
        print(f"   {r['backend']:<12} R@1 {r['R@1']:.3f} (drop {r['R@1_drop']:+.3f})  {joules}", file=out)
    for name, why in o["refused"].items():
        print(f"   {name:<12} not run: {why}", file=out)
    m = summary["modular"]
    print(f"4. Modular SNN next to SAD ({m['plan']}):", file=out)
    for name, values in m["R@1"].items():
        print(f"   {name:<16}" + "".join(f"  R@1 {k} {v:.3f}" for k, v in values.items()), file=out)
    print(f"Took {summary['total_seconds']:.0f} s. Report: {summary['report']}", file=out)
