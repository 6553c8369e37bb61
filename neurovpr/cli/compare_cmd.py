"""``neurovpr compare --run RUN_DIR --data PATH --backends A,B,... [--hw NAME] [--json]``.

Runs the trained model of a run on each backend and compares accuracy, agreement with
the first backend that ran, output spike-count correlation, time per query and (with
``--hw``) energy per inference; writes a PNG. Exit 0 when at least one backend ran, 1
when every backend was refused, 2 on bad input.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

PLOT_FILE = "compare.png"


def add_parser(sub: argparse._SubParsersAction) -> None:
    """Register the subcommand."""
    p = sub.add_parser(
        "compare",
        help="run a trained model on several backends and compare accuracy, agreement, time and energy",
        description=(
            "Run the trained model of RUN_DIR on the query set of PATH with each backend (off-chip simulators and "
            "on-chip emulators) and compare its accuracy, the agreement of its predictions and the correlation of "
            "its output spike counts with the first backend that ran, the time per query and, with --hw, the "
            "estimated energy per inference. A backend other than the training backend runs the trained weights "
            "with plasticity off; a backend that cannot run the model is listed with the reason. Exit 0 when at "
            "least one backend ran, 1 when none could, 2 on bad input."
        ),
    )
    p.add_argument("--run", type=Path, required=True, metavar="RUN_DIR", help="run directory written by train")
    p.add_argument("--data", type=Path, required=True, metavar="PATH", help="dataset whose query set is run")
    p.add_argument("--backends", required=True, metavar="A,B,...",
                   help="comma-separated backend names; the first that runs is the reference of comparison")  # fmt: skip
    p.add_argument("--hw", default=None, metavar="NAME", help="also estimate energy per inference on this hwspec")
    p.add_argument("--seed", type=int, default=0, help="seed of the inference (Poisson input; default 0)")
    p.add_argument("--plot", type=Path, default=None, metavar="PNG",
                   help=f"where to write the plot (default RUN_DIR/{PLOT_FILE})")  # fmt: skip
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.add_argument("--json", action="store_true", help="print exactly one JSON object")
    p.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    """Compare, print the table or JSON, write the plot."""
    from neurovpr.apps.compare import compare_model
    from neurovpr.apps.compare_plots import plot_comparison

    plot = args.plot if args.plot is not None else Path(args.run) / PLOT_FILE
    if plot.suffix.lower() != ".png":
        from neurovpr.errors import ValidationError

        raise ValidationError(f"--plot {str(plot)!r} must end in .png.")
    comparison = compare_model(
        args.run, args.data, args.backends, hardware=args.hw, seed=args.seed, progress=not args.no_progress
    )
    written = plot_comparison(comparison, plot)
    confusion = _write_confusion(comparison, plot)
    if args.json:
        out = comparison.as_dict()
        out["plot"] = str(written)
        out["confusion"] = confusion
        print(json.dumps(out))
    else:
        print(f"model: {comparison.model}  run: {comparison.run}  trained on: {comparison.trained_on or 'unknown'}")
        print(comparison.table())
        print(f"plot: {written}")
        if confusion:
            print(f"confusion of predicted places: {confusion['plot']} ({confusion['json']})")
    if not comparison.any_ran:
        print("neurovpr compare: no backend could run the model.", file=sys.stderr)
        return 1
    return 0


def _write_confusion(comparison, plot: Path) -> dict[str, str]:
    """Write the predicted-place confusion beside the plot (PNG + JSON); ``{}`` when no backend ran."""
    from neurovpr.apps.compare_plots import place_confusion, plot_place_confusion
    from neurovpr.fileio import atomic_write_text

    data = place_confusion(comparison)
    if not data["backends"]:
        return {}
    png = plot.with_name(f"{plot.stem}_confusion.png")
    js = png.with_suffix(".json")
    plot_place_confusion(data, png, title=f"{comparison.model}: predicted places against {data['reference_backend']}")
    atomic_write_text(js, json.dumps(data, indent=2) + "\n")
    return {"plot": str(png), "json": str(js)}
