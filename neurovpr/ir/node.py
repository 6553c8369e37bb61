"""The base of every IR dataclass: validation and equality derived from the fields.

Each IR type is a ``@dataclass(frozen=True, slots=True, kw_only=True)`` subclass of
:class:`IRNode`. Constraints live in the field metadata (see :func:`param`), so the
validation, the documentation of units and the save/load code are all derived from
the same declaration and adding a parameter touches one line.
"""

from __future__ import annotations

import dataclasses
import inspect
import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from neurovpr.errors import ValidationError

__all__ = ["IRNode", "UnknownParameterError", "param", "freeze_array", "field_values"]


def param(
    default: Any = dataclasses.MISSING,
    *,
    unit: str = "",
    low: float | None = None,
    high: float | None = None,
    low_open: bool = False,
    integer: bool = False,
    array: bool = False,
    infinite: str = "",
    hint: str = "",
    doc: str = "",
) -> Any:
    """Declare a numeric IR field with its unit and allowed range.

    Parameters
    ----------
    default
        Default value (PyNN's default where PyNN has the parameter).
    unit
        Unit of the value (``ms``, ``mV``, ``nA``, ``nF``, ``uS``, ``Hz`` or ``""``).
    low, high
        Inclusive bounds; ``low_open=True`` makes the lower bound exclusive.
    integer
        The value must be integral.
    array
        The value may also be a 1-D array with one entry per neuron.
    infinite
        What ``+inf`` means for this field (e.g. ``"never fires"``); empty (the
        default): every value must be finite, so an ``inf`` typed by mistake is
        refused at construction instead of simulating as NaN.
    hint
        Added to the refusal of a non-finite value (e.g. the spelling of "no leak").
    doc
        One-line description, used in generated documentation and error messages.
    """
    meta = {
        "unit": unit,
        "low": low,
        "high": high,
        "low_open": low_open,
        "integer": integer,
        "array": array,
        "infinite": infinite,
        "hint": hint,
        "numeric": True,
        "doc": doc,
    }
    return dataclasses.field(default=default, metadata=meta)


def freeze_array(value: Any, *, dtype: Any = np.float64) -> np.ndarray:
    """Return a read-only, contiguous copy of ``value`` as an array of ``dtype``."""
    arr = np.array(value, dtype=dtype, copy=True, order="C")
    arr.setflags(write=False)
    return arr


def _fmt(value: Any) -> str:
    if isinstance(value, np.ndarray):
        return f"array of shape {value.shape}"
    return repr(value)


def _check_number(owner: str, name: str, value: float, meta: Mapping[str, Any]) -> None:
    if not math.isfinite(value) and not (value == math.inf and meta.get("infinite")):
        hint = f" ({meta['hint']})" if meta.get("hint") else ""
        raise ValidationError(f"{owner}.{name} must be a finite number, got {value!r}{hint}.")
    low, high = meta["low"], meta["high"]
    unit = f" {meta['unit']}" if meta["unit"] else ""
    if low is not None:
        if meta["low_open"] and not value > low:
            raise ValidationError(f"{owner}.{name} must be > {low}{unit}, got {value!r}.")
        if not meta["low_open"] and not value >= low:
            raise ValidationError(f"{owner}.{name} must be >= {low}{unit}, got {value!r}.")
    if high is not None and not value <= high:
        raise ValidationError(f"{owner}.{name} must be <= {high}{unit}, got {value!r}.")
    if meta["integer"] and value != int(value):
        raise ValidationError(f"{owner}.{name} must be an integer, got {value!r}.")


def _coerce_numeric(owner: str, name: str, value: Any, meta: Mapping[str, Any]) -> Any:
    if isinstance(value, bool):
        raise ValidationError(f"{owner}.{name} must be a number, got {value!r}.")
    if isinstance(value, (int, float, np.integer, np.floating)):
        number = float(value)
        _check_number(owner, name, number, meta)
        return int(number) if meta["integer"] else number
    if meta["array"] and isinstance(value, (np.ndarray, list, tuple)):
        try:
            arr = freeze_array(value)
        except (TypeError, ValueError):
            raise ValidationError(
                f"{owner}.{name} must be a number or a 1-D array of numbers, got {_fmt(value)}."
            ) from None
        if arr.ndim != 1 or arr.size == 0:
            raise ValidationError(
                f"{owner}.{name} must be a number or a non-empty 1-D array, got {_fmt(arr)}."
            )
        for i, item in enumerate(arr):
            try:
                _check_number(owner, name, float(item), meta)
            except ValidationError as exc:
                raise ValidationError(f"{exc} (element {i})".replace(". (", " (") + ".") from None
        return arr
    kind = "a number or a 1-D array" if meta["array"] else "a number"
    raise ValidationError(f"{owner}.{name} must be {kind}, got {_fmt(value)}.")


def _init_names(cls: type) -> frozenset[str]:
    """The keywords a dataclass's constructor takes: its init fields and its ``InitVar`` pseudo-fields."""
    params = inspect.signature(cls.__init__).parameters.values()  # type: ignore[misc]
    return frozenset(p.name for p in params if p.kind in (p.KEYWORD_ONLY, p.POSITIONAL_OR_KEYWORD) and p.name != "self")


class UnknownParameterError(ValidationError, TypeError):
    """A keyword an IR type does not have (a ``TypeError`` too, as Python raises for unknown keywords)."""


class IRNode:
    """Base class of the frozen IR dataclasses.

    Subclasses call ``super().__post_init__()`` implicitly through the dataclass
    machinery: numeric fields declared with :func:`param` are coerced and range
    checked, and :meth:`_validate` (overridable) performs cross-field checks.
    Equality compares field by field, arrays by value, so a network loaded from a
    file compares equal to the one that was saved.
    """

    __slots__ = ()

    def __new__(cls, *args: Any, **kwargs: Any) -> IRNode:
        names = _init_names(cls) if dataclasses.is_dataclass(cls) else frozenset()
        unknown = [k for k in kwargs if k not in names]
        if names and unknown:
            raise UnknownParameterError(
                f"{cls.__name__} has no parameter {unknown[0]!r}; its parameters are {', '.join(sorted(names))}."
            )
        return super().__new__(cls)

    def __post_init__(self) -> None:
        owner = type(self).__name__
        for f in dataclasses.fields(self):  # type: ignore[arg-type]
            if f.metadata.get("numeric"):
                value = _coerce_numeric(owner, f.name, getattr(self, f.name), f.metadata)
                object.__setattr__(self, f.name, value)
        self._validate()

    def _validate(self) -> None:
        """Cross-field validation; subclasses override it."""

    def __eq__(self, other: object) -> bool:
        if type(other) is not type(self):
            return NotImplemented
        for f in dataclasses.fields(self):  # type: ignore[arg-type]
            a, b = getattr(self, f.name), getattr(other, f.name)
            if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
                if not (isinstance(a, np.ndarray) and isinstance(b, np.ndarray)):
                    return False
                if a.shape != b.shape or a.dtype != b.dtype or not np.array_equal(a, b):
                    return False
            elif a != b:
                return False
        return True

    __hash__ = None  # type: ignore[assignment]

    def replace(self, **changes: Any) -> IRNode:
        """Return a copy with some fields changed (validated again)."""
        return dataclasses.replace(self, **changes)  # type: ignore[type-var]


def field_values(node: IRNode) -> dict[str, Any]:
    """Return the node's fields as a ``{name: value}`` dict (shallow)."""
    return {f.name: getattr(node, f.name) for f in dataclasses.fields(node)}  # type: ignore[arg-type]
