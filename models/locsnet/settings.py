"""LoCS-Net's training hyper-parameters and what a trainer returns (torch-free).

:class:`TrainingSettings` holds every hyper-parameter of :func:`.training.train` (torch)
and :func:`.nengo_training.train_nengo_dl` (NengoDL); the command line's training options
(``neurovpr train --model locsnet``) take their defaults from its fields, so each default
is written once. :class:`TrainingResult` is what both trainers return, and
:func:`check_labels` the label check both apply before training.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from neurovpr.errors import ValidationError

from .architecture import Architecture

__all__ = ["TrainingSettings", "TrainingResult", "check_labels", "PLACE_LOSSES", "DEFAULT_TRAINING"]

#: What the loss sees of the place layer: its input current, or its smoothed rate.
PLACE_LOSSES = ("current", "rate")


@dataclass(frozen=True, slots=True, kw_only=True)
class TrainingSettings:
    """Hyper-parameters of one training run (all have working defaults)."""

    epochs: int = 40
    batch_size: int = 64
    learning_rate: float = 5e-3
    weight_decay: float = 1e-5
    rate_penalty: float = 0.0
    quantise: str | None = None
    place_loss: str = "current"
    level_weight: float = 1.0
    place_drive: float = 6.0
    active_places: int = 10
    shift: int = 3
    contrast: float = 0.3
    brightness: float = 0.1
    noise: float = 0.05
    init_mean: float = 1.2
    init_std: float = 1.0
    seed: int = 0
    threads: int | None = 1

    def __post_init__(self) -> None:
        for name, low in (("epochs", 1), ("batch_size", 1), ("shift", 0), ("active_places", 1), ("seed", 0)):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or value < low:
                raise ValidationError(f"TrainingSettings.{name} must be an integer >= {low}, got {value!r}.")
        for name in ("learning_rate", "init_std"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) or value <= 0:
                raise ValidationError(f"TrainingSettings.{name} must be a positive number, got {value!r}.")
        for name in ("weight_decay", "rate_penalty", "level_weight", "contrast", "brightness", "noise", "init_mean"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) or value < 0:
                raise ValidationError(f"TrainingSettings.{name} must be a number >= 0, got {value!r}.")
        if not isinstance(self.place_drive, (int, float)) or not math.isfinite(self.place_drive) or self.place_drive <= 1:
            raise ValidationError(f"TrainingSettings.place_drive must be a number > 1 (threshold), got {self.place_drive!r}.")
        if self.place_loss not in PLACE_LOSSES:
            raise ValidationError(
                f"TrainingSettings.place_loss must be one of {', '.join(PLACE_LOSSES)}, got {self.place_loss!r}."
            )
        if self.threads is not None and (isinstance(self.threads, bool) or not isinstance(self.threads, int) or self.threads < 1):
            raise ValidationError(f"TrainingSettings.threads must be None or an integer >= 1, got {self.threads!r}.")

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready values."""
        return asdict(self)

    @classmethod
    def from_dict(cls, data: Any) -> TrainingSettings:
        """Rebuild from :meth:`to_dict` output (unknown keys refused)."""
        if not isinstance(data, dict):
            raise ValidationError(f"training settings must be a JSON object, got {type(data).__name__}.")
        unknown = sorted(set(data) - set(cls.__dataclass_fields__))  # type: ignore[attr-defined]
        if unknown:
            raise ValidationError(f"training settings have unknown field {unknown[0]!r}.")
        return cls(**data)


#: The defaults, for the options that show them.
DEFAULT_TRAINING = TrainingSettings()


@dataclass
class TrainingResult:
    """What a trainer returns (:func:`.training.train`, :func:`.nengo_training.train_nengo_dl`): arrays and record.

    ``parameters`` are the arrays the spiking network is built from (on the chip's
    grid when trained quantised, calibrated for ``place_loss="current"``);
    ``state_dict`` is the torch model before calibration (to resume or fine-tune), ``None``
    from the NengoDL trainer (its run has no ``model.pt``).
    """

    parameters: dict[str, np.ndarray]
    state_dict: dict[str, Any] | None
    history: list[dict[str, float]]
    calibration: dict[str, float]
    seconds: float
    cpu_seconds: float


def check_labels(arch: Architecture, labels: Any, n_images: int) -> np.ndarray:
    """``labels`` as int64 places, one per image, every place with at least one image (else a clear error)."""
    y = np.asarray(labels)
    if y.shape != (n_images,) or not np.issubdtype(y.dtype, np.integer):
        raise ValidationError(f"training labels must be {n_images} integers, one per image, got shape {y.shape}.")
    if y.size and (y.min() < 0 or y.max() >= arch.n_places):
        bad = int(y.min()) if y.min() < 0 else int(y.max())
        raise ValidationError(f"training label {bad} is outside the {arch.n_places} places (0..{arch.n_places - 1}).")
    counts = np.bincount(y, minlength=arch.n_places)
    if (counts == 0).any():
        empty = np.flatnonzero(counts == 0)
        raise ValidationError(
            f"place {int(empty[0])} has no training images ({empty.size} of {arch.n_places} places are empty); "
            "every place needs at least one."
        )
    return y.astype(np.int64)
