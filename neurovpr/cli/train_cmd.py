"""``neurovpr train --model NAME --data PATH --out RUN_DIR [...]``: train a model into a run directory."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from neurovpr.modelapi import get_model, model_names


def add_parser(sub: argparse._SubParsersAction) -> None:
    """Register the subcommand; each installed model adds its own options."""
    p = sub.add_parser("train", help="train a model and write a run directory")
    p.add_argument("--model", required=True, choices=model_names() or None, help="which model")
    p.add_argument("--data", type=Path, required=True, help="dataset path (or a recording for mbsnn)")
    p.add_argument("--out", type=Path, required=True, help="run directory to write")
    p.add_argument("--backend", default="reference", help="backend to train on (default: reference)")
    p.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    p.add_argument("--scheduler", default=None, help="Dask scheduler address for distributed training")
    p.add_argument("--resume", action="store_true", help="skip parts already finished in --out")
    p.add_argument("--json", action="store_true", help="print the summary as one JSON object")
    for name in model_names():
        group = p.add_argument_group(f"{name} options")
        try:
            get_model(name).add_train_arguments(group)  # type: ignore[arg-type]
        except Exception:
            continue
    p.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    """Dispatch to the chosen model."""
    summary = get_model(args.model).train(args)
    if args.json:
        print(json.dumps(summary))
    else:
        for key, value in summary.items():
            print(f"{key}: {value}", file=sys.stdout)
    return 0
