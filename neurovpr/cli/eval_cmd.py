"""``neurovpr eval --run RUN_DIR [--data PATH] [--backend NAME] [--backend-option KEY=VALUE ...] [--seq-len L] [--json]``.

(and ``[--activity-plots DIR]``.)
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from neurovpr.apps.activity import plot_sample_activity
from neurovpr.apps.modelapi import get_model, read_run_info
from neurovpr.apps.requests import EvalRequest
from neurovpr.cli.arguments import ModelHelp, backend_options, model_options, parse_model_options, show_progress
from neurovpr.cli.main import _Parser
from neurovpr.evaluation.neurobench import neurobench_block


def _common(p: argparse.ArgumentParser) -> None:
    p.add_argument("--run", type=Path, required=True, help="run directory written by train")
    p.add_argument("--data", type=Path, default=None, help="dataset (default: the one trained on)")
    p.add_argument("--backend", default=None, help="backend to evaluate on (default: the training backend)")
    p.add_argument("--backend-option", action="append", default=None, metavar="KEY=VALUE",
                   help="an option of the backend, repeatable (e.g. torch: dtype=float32, fuse=true)")  # fmt: skip
    p.add_argument("--seq-len", type=int, default=1, help="sequence length for sequence matching (default 1)")
    p.add_argument("--json", action="store_true", help="print exactly one JSON object")
    p.add_argument("--activity-plots", type=Path, default=None, metavar="DIR",
                   help="simulate the first query once: its spike raster, rate histograms and summary into DIR")  # fmt: skip
    p.add_argument("--no-progress", action="store_true", help="no progress bars")


def add_parser(sub: argparse._SubParsersAction) -> None:
    """Register the subcommand; the run's model options are parsed in :func:`run`."""
    p = sub.add_parser("eval", help="evaluate a trained run", add_help=False)
    hint = "The run's model has its own options: neurovpr eval --run RUN_DIR --help lists them."
    p.add_argument("-h", "--help", action=ModelHelp, model_parser=lambda ns: _model_parser(ns.run) if ns.run else None, hint=hint)
    _common(p)
    p.set_defaults(handler=run, model_options=True)


def _model_parser(run_dir: Path) -> argparse.ArgumentParser:
    """The eval options of the model that wrote ``run_dir`` (named in its ``run.json``)."""
    name = read_run_info(run_dir)["model"]
    parser = _Parser(prog="neurovpr eval")
    _common(parser)
    get_model(name).add_eval_arguments(parser.add_argument_group(f"{name} options"))  # type: ignore[arg-type]
    return parser


def run(args: argparse.Namespace) -> int:
    """Dispatch to the model named in the run directory, parsing that model's options only."""
    info = read_run_info(args.run)
    model = get_model(info["model"])
    args = parse_model_options(_model_parser(args.run), args.argv[1:], "eval", info["model"])
    request = EvalRequest(
        run=args.run, data=args.data, backend=args.backend, seq_len=args.seq_len, progress=show_progress(args),
        options=model_options(args, model.eval_options), backend_options=backend_options(args.backend_option),
    )
    result = model.evaluate(request, info)
    result.setdefault("neurobench", neurobench_block(args.run))
    if args.activity_plots is not None:
        backend = result.get("backend") or args.backend or info.get("backend") or "reference"
        paths = plot_sample_activity(model, args.run, args.data, str(backend), args.activity_plots)
        result["activity_plots"] = {key: str(path) for key, path in paths.items()}
    if args.json:
        print(json.dumps(result))
    else:
        print(f"model: {result.get('model')}  backend: {result.get('backend')}")
        for key, value in result.get("metrics", {}).items():
            print(f"  {key}: {value}")
        for name, metrics in result.get("baselines", {}).items():
            print(f"  baseline {name}: " + ", ".join(f"{k}={v}" for k, v in metrics.items()))
        if "activity_plots" in result:
            print(f"  activity plots: {result['activity_plots']['raster']}, {result['activity_plots']['rates']}")
    return 0
