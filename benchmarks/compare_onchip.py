"""Off-chip versus on-chip accuracy of LoCS-Net and the Modular SNN on real Nordland data.

Builds a subset of ``../shared/datasets/nordland64`` (``--places`` consecutive summer
frames from ``--start`` as reference, ``--queries`` evenly spaced winter frames of the same places as
query, ground truth query -> same place, zero tolerance), trains the model on the
reference backend (or takes ``--run``), and runs ``neurovpr compare`` on it across
``--backends``: off-chip ``reference``, ``nengo`` and ``lava`` (floating point) against
on-chip ``nengo-loihi`` (NengoLoihi's Loihi emulator, as the paper's Kapoho Bay) and
``lava-fixed`` (bit-accurate Loihi 2). Prints the comparison table and the off-chip ->
on-chip differences next to the LoCS-Net paper's Nordland figures (P@100R 78.6% off-chip,
71.1% on Loihi), and writes ``results.json`` and ``compare.png`` to ``--out``.

The Modular SNN's conductance-based, adaptive-threshold neurons have no Nengo or Lava
equivalent, so those backends refuse it (the table says so) and it runs off-chip only.

Train LoCS-Net with ``--train-args "--input-coding regular"`` to compare the backends'
numerics on identical input spikes: with Poisson input every backend draws its own
spikes, and over a 30 ms window the place layer's argmax then differs between backends
for most queries whatever the numerics. ``lava`` and ``lava-fixed`` run the paper-sized
LoCS-Net at a fraction of a second per query (the Lava runtime is compiled once and reset
per query).

Usage (from the repository root)::

    python benchmarks/compare_onchip.py --model locsnet                   # 600 places, 200 queries
    python benchmarks/compare_onchip.py --model locsnet --places 2400 --queries 300 \
        --train-args "--input-coding regular"
    python benchmarks/compare_onchip.py --model modular --places 50 --train-args "--epochs 10"
"""

from __future__ import annotations

import argparse
import json
import shlex
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

from neurovpr.apps.compare import compare_model
from neurovpr.apps.compare_plots import plot_comparison
from neurovpr.apps.options import options_from_namespace
from neurovpr.apps.requests import TrainRequest
from neurovpr.apps.rundir import RunDir
from neurovpr.data.generic import open_traverse, write_generic
from neurovpr.fileio import atomic_write_text
from neurovpr.paths import shared_datasets

#: The LoCS-Net paper's Nordland precision at 100% recall (Akcal et al. 2025): off-chip, on Loihi.
PAPER_P100R = {"off-chip": 0.786, "on-chip (Loihi)": 0.711}
#: Off-chip -> on-chip pairs: the same numerics family, without and with the chip's formats.
PAIRS = (("nengo", "nengo-loihi"), ("lava", "lava-fixed"), ("reference", "nengo-loihi"), ("reference", "lava-fixed"))


def _plugin(name: str) -> Any:
    if name == "locsnet":
        from neurovpr.models.locsnet.plugin import MODEL
    else:
        from neurovpr.models.modular_snn.plugin import MODEL
    return MODEL


def _subset(data: Path, start: int, places: int, queries: int, out: Path) -> Path:
    """Write ``places`` places from ``start`` with ``queries`` evenly spaced queries in the generic layout."""
    traverse = open_traverse(data)
    if start < 0 or places < 1 or start + places > traverse.n_reference:
        raise SystemExit(f"--start {start} --places {places}: {data} has {traverse.n_reference} places")
    q = start + np.unique(np.linspace(0, places - 1, min(queries, places)).astype(int))
    sub = traverse.subset(slice(start, start + places), q)
    return write_generic(sub, out, overwrite=True)


def _train(plugin: Any, data: Path, run: Path, seed: int, extra: list[str]) -> dict[str, Any]:
    """Train with the model's typed API on the reference backend; ``--train-args`` parsed by the model's own flags."""
    parser = argparse.ArgumentParser(prog="--train-args", add_help=False)
    plugin.add_train_arguments(parser)
    parser.add_argument("--no-progress", action="store_true")
    args = parser.parse_args(extra)
    request = TrainRequest(data=data, out=run, seed=seed, progress=not args.no_progress,
                           options=options_from_namespace(args, plugin.train_options))  # fmt: skip
    start = time.perf_counter()
    summary = plugin.train(request)
    summary["wall_seconds"] = time.perf_counter() - start
    return summary


def _pairs(result: dict[str, Any], metric: str) -> list[dict[str, Any]]:
    rows = result["backends"]
    out = []
    for off, on in PAIRS:
        a, b = rows.get(off, {}), rows.get(on, {})
        if "metrics" in a and "metrics" in b and a["metrics"].get(metric) is not None and b["metrics"].get(metric) is not None:
            out.append({"off_chip": off, "on_chip": on, metric: [a["metrics"][metric], b["metrics"][metric]],
                        "difference_points": 100 * (b["metrics"][metric] - a["metrics"][metric])})  # fmt: skip
    return out


def main() -> int:
    """Build the subset, train (or reuse a run), compare, print and save."""
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--model", choices=("locsnet", "modular"), default="locsnet")
    p.add_argument("--data", type=Path, default=None, help="dataset (default ../shared/datasets/nordland64)")
    p.add_argument("--places", type=int, default=600, help="N consecutive places of the route (default 600)")
    p.add_argument("--start", type=int, default=0, help="index of the first place (default 0)")
    p.add_argument("--queries", type=int, default=200, help="evenly spaced queries among them (default 200)")
    p.add_argument("--backends", default="reference,nengo,nengo-loihi,lava,lava-fixed")
    p.add_argument("--hw", default="kapoho-bay", help="hwspec for the energy estimate (default kapoho-bay)")
    p.add_argument("--run", type=Path, default=None, help="compare this run instead of training one")
    p.add_argument("--train-args", default="", help="extra options for train, e.g. \"--epochs 20\"")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--out", type=Path, default=None, help="output folder (default reports/compare_onchip/MODEL)")
    args = p.parse_args()
    shared = shared_datasets()
    data = args.data or (None if shared is None else shared / "nordland64")
    if data is None or not data.is_dir():
        raise SystemExit("nordland64 not found: pass --data or provide ../shared/datasets")
    out = args.out or Path("reports/compare_onchip") / args.model
    out.mkdir(parents=True, exist_ok=True)
    plugin = _plugin(args.model)
    subset = _subset(data, args.start, args.places, args.queries, out / "data")
    info: dict[str, Any] = {"dataset": str(data.name), "start": args.start, "places": args.places,
                            "queries": len(open_traverse(subset).query)}  # fmt: skip
    run = args.run
    if run is None:
        run = out / "run"
        if RunDir(run).finished:
            print(f"reusing the trained run in {run}", file=sys.stderr)
        else:
            info["training"] = _train(plugin, subset, run, args.seed, shlex.split(args.train_args))
    start = time.perf_counter()
    comparison = compare_model(run, subset, args.backends, hardware=args.hw, seed=args.seed, model=plugin)
    info["compare_wall_seconds"] = time.perf_counter() - start
    plot = plot_comparison(comparison, out / "compare.png")
    result = {**comparison.as_dict(), "subset": info, "plot": str(plot)}
    result["off_vs_on_chip"] = {m: _pairs(result, m) for m in ("P@100R", "R@1")}
    result["paper_locsnet_nordland_P@100R"] = PAPER_P100R
    atomic_write_text(out / "results.json", json.dumps(result, indent=1, default=str))
    print(comparison.table())
    print(f"\nsubset: places {args.start}..{args.start + args.places - 1} of {data.name}, {info['queries']} queries; "
          f"{info['compare_wall_seconds']:.0f} s")  # fmt: skip
    for metric, pairs in result["off_vs_on_chip"].items():
        for pair in pairs:
            a, b = pair[metric]
            print(f"{metric}: {pair['off_chip']} {100 * a:.1f}% -> {pair['on_chip']} {100 * b:.1f}% "
                  f"({pair['difference_points']:+.1f} points)")  # fmt: skip
    print("LoCS-Net paper, Nordland P@100R: 78.6% off-chip -> 71.1% on Loihi (-7.5 points)")
    print(f"results: {out / 'results.json'}; plot: {plot}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
