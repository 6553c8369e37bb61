"""``neurovpr eval --run RUN_DIR [--data PATH] [--backend NAME] [--seq-len L] [--json]``."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from neurovpr.modelapi import get_model, model_names, read_run_info


def add_parser(sub: argparse._SubParsersAction) -> None:
    """Register the subcommand; each installed model adds its own options."""
    p = sub.add_parser("eval", help="evaluate a trained run")
    p.add_argument("--run", type=Path, required=True, help="run directory written by train")
    p.add_argument("--data", type=Path, default=None, help="dataset (default: the one trained on)")
    p.add_argument("--backend", default=None, help="backend to evaluate on (default: the training backend)")
    p.add_argument("--seq-len", type=int, default=1, help="sequence length for sequence matching (default 1)")
    p.add_argument("--json", action="store_true", help="print exactly one JSON object")
    for name in model_names():
        group = p.add_argument_group(f"{name} options")
        try:
            get_model(name).add_eval_arguments(group)  # type: ignore[arg-type]
        except Exception:
            continue
    p.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    """Dispatch to the model named in the run directory."""
    info = read_run_info(args.run)
    result = get_model(info["model"]).evaluate(args, info)
    if args.json:
        print(json.dumps(result))
    else:
        print(f"model: {result.get('model')}  backend: {result.get('backend')}")
        for key, value in result.get("metrics", {}).items():
            print(f"  {key}: {value}")
        for name, metrics in result.get("baselines", {}).items():
            print(f"  baseline {name}: " + ", ".join(f"{k}={v}" for k, v in metrics.items()))
    return 0
