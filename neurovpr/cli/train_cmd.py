"""``neurovpr train --model NAME --data PATH --out RUN_DIR [...]``: train a model into a run directory."""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Sequence
from pathlib import Path

from neurovpr.apps.modelapi import ModelPlugin, get_model, model_names
from neurovpr.apps.requests import TrainRequest
from neurovpr.cli.arguments import ModelHelp, model_options, parse_model_options, show_progress
from neurovpr.cli.main import _Parser
from neurovpr.fileio import remove_stale_temps


def _common(p: argparse.ArgumentParser) -> None:
    p.add_argument("--model", required=True, choices=model_names() or None, help="which model")
    p.add_argument("--data", type=Path, required=True, help="dataset path (or a recording for mbsnn)")
    p.add_argument("--out", type=Path, required=True, help="run directory to write")
    p.add_argument("--backend", default="reference", help="backend to train on (default: reference)")
    p.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    p.add_argument("--scheduler", default=None, help="Dask scheduler address for distributed training")
    p.add_argument("--resume", action="store_true", help="skip parts already finished in --out")
    p.add_argument("--json", action="store_true", help="print the summary as one JSON object")
    p.add_argument("--no-progress", action="store_true", help="no progress bars")


def _help(parser: argparse.ArgumentParser) -> None:
    def chosen(namespace: argparse.Namespace) -> argparse.ArgumentParser | None:
        name = getattr(namespace, "model", None)
        return None if name is None else _model_parser(get_model(name))

    hint = f"Each model has its own options: neurovpr train --model NAME --help (NAME: {', '.join(model_names())})."
    parser.add_argument("-h", "--help", action=ModelHelp, model_parser=chosen, hint=hint)


def _model_parser(plugin: ModelPlugin) -> argparse.ArgumentParser:
    parser = _Parser(prog="neurovpr train", add_help=False)
    _help(parser)
    _common(parser)
    plugin.add_train_arguments(parser.add_argument_group(f"{plugin.name} options"))  # type: ignore[arg-type]
    return parser


def add_parser(sub: argparse._SubParsersAction) -> None:
    """Register the subcommand; the chosen model's options are parsed (and listed by ``--help``) in :func:`run`."""
    p = sub.add_parser("train", help="train a model and write a run directory", add_help=False)
    _help(p)
    _common(p)
    p.set_defaults(handler=run, model_options=True)


def train_request(model: ModelPlugin | str, argv: Sequence[str]) -> tuple[ModelPlugin, TrainRequest, bool]:
    """``neurovpr train`` arguments ``argv`` (including ``--model``) as the chosen model's :class:`TrainRequest`.

    Models may declare the same flag with different defaults (``--dt``); the listing
    parser accepts them all, and this parse gives the chosen model its own defaults.
    Returns the model, the request and whether ``--json`` was given.
    """
    plugin = get_model(model) if isinstance(model, str) else model
    args = parse_model_options(_model_parser(plugin), argv, "train", plugin.name)
    request = TrainRequest(
        data=args.data, out=args.out, backend=args.backend, seed=args.seed, scheduler=args.scheduler,
        resume=args.resume, progress=show_progress(args), options=model_options(args, plugin.train_options),
    )  # fmt: skip
    return plugin, request, bool(args.json)


def run(args: argparse.Namespace) -> int:
    """Dispatch to the chosen model."""
    model, request, as_json = train_request(args.model, args.argv[1:])
    removed = remove_stale_temps(request.out)
    if removed:
        print(f"note: removed {len(removed)} temporary file(s) a killed run left in {request.out}.", file=sys.stderr)
    summary = model.train(request)
    if as_json:
        print(json.dumps(summary))
    else:
        for key, value in summary.items():
            print(f"{key}: {value}")
    return 0
