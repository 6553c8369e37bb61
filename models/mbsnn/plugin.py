"""``neurovpr train/eval --model mbsnn``: the mushroom body's command-line integration.

``train --data RECORDING --learn START:END`` learns that segment (fractions of the
recording's moving part) of one recording; ``eval --run DIR --data RECORDING`` scores
familiarity along another recording of the route, aligned by normalised time, with
the learned segment as positives, and reports ``AUC_ROC`` for the MBSNN and for the
SeqSLAM and Perfect Memory baselines.
"""

from __future__ import annotations

import argparse
import sys
from typing import Any

from neurovpr.apps.modelapi import ModelPlugin
from neurovpr.errors import ValidationError

from .network import MBSNNParameters

__all__ = ["MBSNNPlugin", "MODEL"]


def _positive_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not an integer") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"{value} is not >= 1")
    return value


def _add(parser: argparse._ActionsContainer, *flags: str, **kwargs: Any) -> None:
    """Add an option (absent from ``args`` unless given) unless another model already declared it."""
    try:
        parser.add_argument(*flags, default=argparse.SUPPRESS, **kwargs)
    except argparse.ArgumentError:
        pass


class MBSNNPlugin(ModelPlugin):
    """Train and evaluate the mushroom-body SNN from the command line."""

    name = "mbsnn"
    description = "Mushroom-body SNN (Zhu, Mangan & Webb 2023): route familiarity from event-camera spikes"

    def add_train_arguments(self, parser: argparse.ArgumentParser) -> None:
        defaults = MBSNNParameters()
        _add(parser, "--learn", metavar="START:END",
             help="mbsnn: the learned route segment as fractions of the recording (default 0.4:0.6)")
        _add(parser, "--n-kc", type=_positive_int, metavar="N",
             help=f"mbsnn: Kenyon cells, a multiple of the KC subgroups (default {defaults.n_kc})")
        _add(parser, "--kc-groups", type=_positive_int, metavar="N",
             help=f"mbsnn: KC subgroups of the KC->KC connections (default {defaults.kc_groups})")
        _add(parser, "--timestep", type=float, metavar="MS",
             help=f"mbsnn: simulation time step in ms, at most 1 (default {defaults.dt})")
        _add(parser, "--n-pn", type=_positive_int, metavar="N",
             help="mbsnn: projection neurons of a binned .mat recording (default: from the data)")
        _add(parser, "--keep-still", action="store_true",
             help="mbsnn: keep the standing-still start and end of recordings (default: trimmed)")
        _add(parser, "--stretch", type=float, metavar="F",
             help="mbsnn: stretch the recording's time axis by F (2 = half speed; default 1)")

    def add_eval_arguments(self, parser: argparse.ArgumentParser) -> None:
        _add(parser, "--windows", type=_positive_int, metavar="N",
             help="mbsnn: windows (equal shares of the route) that familiarity is scored in (default 100)")
        _add(parser, "--stretch", type=float, metavar="F",
             help="mbsnn: stretch the test recording's time axis by F (a speed change; default 1)")

    def train(self, args: argparse.Namespace) -> dict[str, Any]:
        from .training import parse_segment, train

        if getattr(args, "scheduler", None):
            print("neurovpr train: mbsnn trains one network in this process; --scheduler is not used.", file=sys.stderr)
        learn = parse_segment(getattr(args, "learn", "0.4:0.6"))
        timestep = float(getattr(args, "timestep", MBSNNParameters().dt))
        if not 0 < timestep <= 1.0:
            raise ValidationError(f"--timestep must be in (0, 1] ms, got {timestep!r}.")
        defaults = MBSNNParameters()
        params = MBSNNParameters(
            n_kc=getattr(args, "n_kc", defaults.n_kc), kc_groups=getattr(args, "kc_groups", defaults.kc_groups), dt=timestep
        )
        return train(
            args.data, args.out, learn=learn, params=params, backend=args.backend, seed=args.seed,
            trim=not getattr(args, "keep_still", False), stretch=float(getattr(args, "stretch", 1.0)),
            n_pn=getattr(args, "n_pn", None), resume=bool(getattr(args, "resume", False)),
            progress=not getattr(args, "json", False) or sys.stderr.isatty(),
        )  # fmt: skip

    def evaluate(self, args: argparse.Namespace, run_info: dict[str, Any]) -> dict[str, Any]:
        from .evaluation import evaluate

        seq_len = int(getattr(args, "seq_len", 1) or 1)
        if seq_len < 1:
            raise ValidationError(f"--seq-len must be >= 1, got {seq_len}.")
        return evaluate(
            args.run, run_info, data=args.data, backend=args.backend,
            windows=getattr(args, "windows", 100), stretch=float(getattr(args, "stretch", 1.0)),
            seq_len=seq_len if seq_len > 1 else 10,
            progress=not getattr(args, "json", False) or sys.stderr.isatty(),
        )  # fmt: skip


#: The object the ``neurovpr.models`` entry point ``mbsnn`` names.
MODEL = MBSNNPlugin()
