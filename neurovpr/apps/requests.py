"""Typed requests to a model: what ``train`` and ``evaluate`` are asked to do, free of any command line.

:class:`TrainRequest` and :class:`EvalRequest` hold the fields every model shares;
``options`` holds the model's own, a frozen dataclass the model declares
(:attr:`~neurovpr.apps.modelapi.ModelPlugin.train_options`). Both are validated on
construction by :func:`check_fields`: each field against its type hint (``int``,
``float``, ``bool``, ``str``, ``Path``, ``Literal[...]``, ``X | None``, a union of such
classes, ``tuple[X, ...]``, ``Mapping[K, V]``) and, by name, against the ranges of :data:`NUMBERS`, so the
command line and a notebook refuse the same values with the same sentence.
"""

from __future__ import annotations

import dataclasses
import math
import os
import types
import typing
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

from neurovpr.errors import ValidationError

__all__ = ["Number", "NUMBERS", "BackendOption", "TrainRequest", "EvalRequest", "check_fields"]

#: The value of one backend option (``neurovpr.compile(..., name=value)``).
BackendOption = bool | int | float | str | None

_MAX_SEED = 2**63 - 1


@dataclass(frozen=True, slots=True)
class Number:
    """The allowed range of one numeric option (``low``/``high`` inclusive unless ``low_open``)."""

    low: float
    high: float = math.inf
    integer: bool = True
    low_open: bool = False
    unit: str = ""
    shown_high: str = ""

    def check(self, option: str, value: object) -> None:
        """Refuse ``value`` outside the range, naming ``option``."""
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise ValidationError(f"{option} must be a number, got {value!r}.")
        unit = f" {self.unit}" if self.unit else ""
        kind = "an integer" if self.integer else "a number"
        low = f"> {self.low:g}" if self.low_open else f">= {self.low:g}"
        high = f" and <= {self.shown_high or format(self.high, 'g')}{unit}" if math.isfinite(self.high) else unit
        ok = math.isfinite(value) and (value > self.low if self.low_open else value >= self.low) and value <= self.high
        if not ok or (self.integer and value != int(value)):
            shown = format(value, "g") if isinstance(value, float) else str(value)
            raise ValidationError(f"{option} is {shown}; it must be {kind} {low}{high}.")


_COUNT = Number(1)
#: Numeric options by name, for every command, request and model option that declares them.
NUMBERS: dict[str, Number] = {
    "seed": Number(0, _MAX_SEED, shown_high="2**63 - 1"),
    "workers": Number(1, 1024),
    "threads": Number(1, 1024),
    "seq_len": Number(1, 100_000),
    "windows": Number(1, 1_000_000),
    "members": Number(1, 1000),
    "members_used": Number(1, 1000),
    "epochs": Number(1, 1_000_000),
    "module_size": Number(1, 1_000_000),
    "neurons": Number(1, 100_000),
    "places": _COUNT,
    "max_modules": _COUNT,
    "queries": _COUNT,
    "batch_size": _COUNT,
    "frames_per_place": _COUNT,
    "calibration_images": _COUNT,
    "duration": Number(0, 1e9, integer=False, low_open=True, unit="ms"),
    "presentation": Number(0, 1e9, integer=False, low_open=True, unit="ms"),
    "dt": Number(0, 10, integer=False, low_open=True, unit="ms"),
    "timestep": Number(0, 10, integer=False, low_open=True, unit="ms"),
    "rate": Number(0, 1e6, integer=False, unit="Hz"),
    "input_rate": Number(0, 1e6, integer=False, unit="Hz"),
    "stretch": Number(0, 1e6, integer=False, low_open=True),
    "theta": Number(0, 1e9, integer=False),
    "tau_syn": Number(0, 1e9, integer=False, low_open=True, unit="ms"),
    "tile_size": Number(0, 1e12, integer=False, low_open=True, unit="m"),
    "learning_rate": Number(0, 1e3, integer=False, low_open=True),
    "weight_decay": Number(0, 1e3, integer=False),
    "rate_penalty": Number(0, 1e6, integer=False),
}


def _coerce(owner: str, name: str, hint: Any, value: Any) -> Any:
    """``value`` checked against ``hint`` (a ``str`` becomes a ``Path`` where one is asked for); else one sentence."""
    origin, args = typing.get_origin(hint), typing.get_args(hint)
    if origin in (typing.Union, types.UnionType):
        if value is None and type(None) in args:
            return None
        inner = [a for a in args if a is not type(None)]
        if len(inner) == 1:
            return _coerce(owner, name, inner[0], value)
        if all(isinstance(a, type) for a in inner) and not isinstance(value, tuple(inner)):
            allowed = ", ".join(a.__name__ for a in inner) + (" or None" if type(None) in args else "")
            raise ValidationError(f"{owner}.{name} is {value!r}; it must be a {allowed}.")
        return value
    if origin is Literal:
        if value not in args:
            raise ValidationError(f"{owner}.{name} is {value!r}; it must be one of {', '.join(map(repr, args))}.")
        return value
    if origin is tuple:
        if isinstance(value, (str, os.PathLike)) or not isinstance(value, (list, tuple)):
            raise ValidationError(f"{owner}.{name} must be a sequence, got {value!r}.")
        return tuple(_coerce(owner, name, args[0], v) for v in value)
    if origin is Mapping:
        if not isinstance(value, Mapping):
            raise ValidationError(f"{owner}.{name} must be a mapping, got {value!r}.")
        key_hint, value_hint = args
        checked = {
            _coerce(owner, f"{name} key", key_hint, key): _coerce(owner, f"{name}[{key!r}]", value_hint, item)
            for key, item in value.items()
        }
        return types.MappingProxyType(checked)
    if hint is Path:
        if not isinstance(value, (str, os.PathLike)):
            raise ValidationError(f"{owner}.{name} must be a path, got {value!r}.")
        return Path(value)
    if hint is bool:
        if not isinstance(value, bool):
            raise ValidationError(f"{owner}.{name} must be True or False, got {value!r}.")
        return value
    if hint in (int, float):
        if isinstance(value, bool) or not isinstance(value, (int, float)) or (hint is int and value != int(value)):
            raise ValidationError(f"{owner}.{name} must be {'an integer' if hint is int else 'a number'}, got {value!r}.")
        return hint(value)
    if hint is str and not isinstance(value, str):
        raise ValidationError(f"{owner}.{name} must be a string, got {value!r}.")
    return value


def check_fields(obj: Any) -> None:
    """Check (and normalise: ``str`` to ``Path``, ``int`` to ``float``) every field of the dataclass ``obj``.

    Called from ``__post_init__`` of the requests and of every model's options, so
    an object that exists is valid.
    """
    owner = type(obj).__name__
    hints = typing.get_type_hints(type(obj))
    for field in dataclasses.fields(obj):
        value = _coerce(owner, field.name, hints[field.name], getattr(obj, field.name))
        if value is not None and field.name in NUMBERS:
            NUMBERS[field.name].check(f"{owner}.{field.name}", value)
        object.__setattr__(obj, field.name, value)


@dataclass(frozen=True, slots=True, kw_only=True)
class TrainRequest:
    """Train a model on ``data`` into the run directory ``out``.

    Parameters
    ----------
    data
        The dataset (or, for ``mbsnn``, a recording).
    out
        The run directory to write.
    backend, seed
        Where and with which seed to train.
    scheduler
        A Dask scheduler address for distributed training (models that support it).
    resume
        Keep the parts already finished in ``out``.
    progress
        Show progress bars.
    options
        The model's own options (an instance of its ``train_options``); ``None`` for its defaults.
    """

    data: Path
    out: Path
    backend: str = "reference"
    seed: int = 0
    scheduler: str | None = None
    resume: bool = False
    progress: bool = True
    options: Any = None

    def __post_init__(self) -> None:
        check_fields(self)


@dataclass(frozen=True, slots=True, kw_only=True)
class EvalRequest:
    """Evaluate the trained run in ``run``.

    Parameters
    ----------
    run
        The run directory ``train`` wrote.
    data
        The dataset to evaluate on (default: the one trained on).
    backend
        The backend (default: the training backend).
    seq_len
        Sequence length of sequence matching.
    scheduler
        A Dask scheduler address (models that support it).
    progress
        Show progress bars.
    options
        The model's own options (an instance of its ``eval_options``); ``None`` for its defaults.
    backend_options
        Options of the backend (``neurovpr.compile(..., **backend_options)``, e.g. the torch
        backend's ``dtype``, ``fuse``), each a bool, number, string or ``None``; the backend
        refuses names it does not have.
    """

    run: Path
    data: Path | None = None
    backend: str | None = None
    seq_len: int = 1
    scheduler: str | None = None
    progress: bool = True
    options: Any = None
    backend_options: Mapping[str, BackendOption] = dataclasses.field(default_factory=dict)

    def __post_init__(self) -> None:
        check_fields(self)
