"""``neurovpr train/eval --model mbsnn``: the mushroom body's model API and command-line options.

``train --data RECORDING --learn START:END`` learns that segment (fractions of the
recording's moving part) of one recording; ``eval --run DIR --data RECORDING`` scores
familiarity along another recording of the route, aligned by normalised time, with
the learned segment as positives, and reports ``AUC_ROC`` for the MBSNN and for the
SeqSLAM and Perfect Memory baselines.
"""

from __future__ import annotations

import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from neurovpr.apps.modelapi import ModelPlugin, SamplePresentation
from neurovpr.apps.options import option
from neurovpr.apps.requests import EvalRequest, TrainRequest, check_fields
from neurovpr.errors import ValidationError

from .network import MBSNNParameters

__all__ = ["MBSNNPlugin", "MBSNNTrainOptions", "MBSNNEvalOptions", "MODEL"]


_DEFAULTS = MBSNNParameters()


@dataclass(frozen=True, slots=True, kw_only=True)
class MBSNNTrainOptions:
    """The mushroom body's own ``train`` options (network defaults: :class:`.network.MBSNNParameters`)."""

    learn: str = option("0.4:0.6", "the learned route segment as fractions of the recording", metavar="START:END")
    n_kc: int = option(_DEFAULTS.n_kc, "Kenyon cells, a multiple of the KC subgroups", metavar="N")
    kc_groups: int = option(_DEFAULTS.kc_groups, "KC subgroups of the KC->KC connections", metavar="N")
    timestep: float = option(_DEFAULTS.dt, "simulation time step in ms, at most 1", metavar="MS")
    n_pn: int | None = option(None, "projection neurons of a binned .mat recording", metavar="N", default_text="from the data")
    keep_still: bool = option(False, "keep the standing-still start and end of recordings (default: trimmed)")
    stretch: float = option(1.0, "stretch the recording's time axis by F (2 = half speed)", metavar="F")

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

    windows: int = option(100, "windows (equal shares of the route) that familiarity is scored in", metavar="N")
    stretch: float = option(1.0, "stretch the test recording's time axis by F (a speed change)", metavar="F")

    def __post_init__(self) -> None:
        check_fields(self)


class MBSNNPlugin(ModelPlugin):
    """Train and evaluate the mushroom-body SNN from the command line."""

    name = "mbsnn"
    description = "Mushroom-body SNN (Zhu, Mangan & Webb 2023): route familiarity from event-camera spikes"
    train_options = MBSNNTrainOptions
    eval_options = MBSNNEvalOptions

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
            backend_options=request.backend_options,
        )  # fmt: skip

    def sample_presentation(self, run_dir: Path, data: Path | None) -> SamplePresentation:
        """The trained mushroom body of ``run_dir`` played the first 500 ms of the recording ``data``."""
        from neurovpr.apps.rundir import RunDir

        from .evaluation import sample_presentation

        return sample_presentation(run_dir, RunDir(run_dir).read_info(), data)


#: The object the ``neurovpr.models`` entry point ``mbsnn`` names.
MODEL = MBSNNPlugin()
