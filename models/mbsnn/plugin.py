"""``neurovpr train/eval --model mbsnn``: the mushroom body's model API and command-line options.

``train --data RECORDING --learn START:END`` learns that segment (fractions of the
recording's moving part) of one recording; ``eval --run DIR --data RECORDING`` scores
familiarity along another recording of the route, aligned by normalised time, with
the learned segment as positives, and reports ``AUC_ROC`` for the MBSNN and for the
SeqSLAM and Perfect Memory baselines.
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import dataclass
from typing import Any

from neurovpr.apps.modelapi import ModelPlugin
from neurovpr.apps.requests import EvalRequest, TrainRequest, check_fields
from neurovpr.errors import ValidationError

from .network import MBSNNParameters

__all__ = ["MBSNNPlugin", "MBSNNTrainOptions", "MBSNNEvalOptions", "MODEL"]


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


_DEFAULTS = MBSNNParameters()


@dataclass(frozen=True, slots=True, kw_only=True)
class MBSNNTrainOptions:
    """The mushroom body's own ``train`` options (see :class:`MBSNNPlugin`'s ``--help``)."""

    learn: str = "0.4:0.6"
    n_kc: int = _DEFAULTS.n_kc
    kc_groups: int = _DEFAULTS.kc_groups
    timestep: float = _DEFAULTS.dt
    n_pn: int | None = None
    keep_still: bool = False
    stretch: float = 1.0

    def __post_init__(self) -> None:
        from .training import parse_segment

        check_fields(self)
        parse_segment(self.learn)
        for name in ("n_kc", "kc_groups") + (("n_pn",) if self.n_pn is not None else ()):
            if getattr(self, name) < 1:
                raise ValidationError(f"MBSNNTrainOptions.{name} is {getattr(self, name)}; it must be >= 1.")
        if not 0 < self.timestep <= 1.0:
            raise ValidationError(f"--timestep must be in (0, 1] ms, got {self.timestep!r}.")


@dataclass(frozen=True, slots=True, kw_only=True)
class MBSNNEvalOptions:
    """The mushroom body's own ``eval`` options."""

    windows: int = 100
    stretch: float = 1.0

    def __post_init__(self) -> None:
        check_fields(self)


class MBSNNPlugin(ModelPlugin):
    """Train and evaluate the mushroom-body SNN from the command line."""

    name = "mbsnn"
    description = "Mushroom-body SNN (Zhu, Mangan & Webb 2023): route familiarity from event-camera spikes"
    train_options = MBSNNTrainOptions
    eval_options = MBSNNEvalOptions

    def add_train_arguments(self, parser: argparse.ArgumentParser) -> None:
        defaults = _DEFAULTS
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

    def run_train(self, request: TrainRequest) -> dict[str, Any]:
        from .training import parse_segment, train

        o: MBSNNTrainOptions = request.options
        if request.scheduler:
            print("neurovpr train: mbsnn trains one network in this process; --scheduler is not used.", file=sys.stderr)
        params = MBSNNParameters(n_kc=o.n_kc, kc_groups=o.kc_groups, dt=o.timestep)
        return train(
            request.data, request.out, learn=parse_segment(o.learn), params=params, backend=request.backend,
            seed=request.seed, trim=not o.keep_still, stretch=o.stretch, n_pn=o.n_pn, resume=request.resume,
            progress=request.progress,
        )  # fmt: skip

    def run_evaluate(self, request: EvalRequest, run_info: dict[str, Any]) -> dict[str, Any]:
        from .evaluation import evaluate

        o: MBSNNEvalOptions = request.options
        return evaluate(
            request.run, run_info, data=request.data, backend=request.backend, windows=o.windows, stretch=o.stretch,
            seq_len=request.seq_len if request.seq_len > 1 else 10, progress=request.progress,
        )  # fmt: skip


#: The object the ``neurovpr.models`` entry point ``mbsnn`` names.
MODEL = MBSNNPlugin()
