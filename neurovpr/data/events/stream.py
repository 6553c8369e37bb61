"""The event-stream type: what an event camera emits, validated on construction.

An event is ``(x, y, t, p)``: the pixel column ``x`` and row ``y`` (0-based, row 0 at the
top as the sensor reads out), the time ``t`` in integer microseconds and the polarity
``p`` (1 = ON, the log intensity rose by one contrast step; 0 = OFF, it fell).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from neurovpr.errors import ValidationError
from neurovpr.ir.node import IRNode, freeze_array, param

__all__ = ["EventStream", "first_bad_record", "normalise_polarity"]


def normalise_polarity(p: np.ndarray) -> np.ndarray:
    """Map polarities given as bool, ``{0, 1}`` or ``{-1, +1}`` onto ``{0, 1}`` (int8).

    Values outside these sets are kept as they are (as int64) so that validation can
    name the first bad record.
    """
    arr = np.asarray(p)
    if arr.dtype == np.bool_:
        return arr.astype(np.int8)
    with np.errstate(invalid="ignore"):
        as_int = arr.astype(np.int64)
    if arr.size and np.issubdtype(arr.dtype, np.floating) and not np.array_equal(as_int, arr):
        return arr  # fractional polarities are reported by first_bad_record
    if as_int.size and as_int.min() == -1 and np.all((as_int == -1) | (as_int == 1)):
        return ((as_int + 1) // 2).astype(np.int8)
    if as_int.size == 0 or np.all((as_int == 0) | (as_int == 1)):
        return as_int.astype(np.int8)
    return as_int


def _num(value: object) -> str:
    """A number as a person writes it: ``400`` rather than ``400.0`` for whole floats."""
    number = float(value)  # type: ignore[arg-type]
    if np.isfinite(number) and number == int(number):
        return str(int(number))
    return repr(number) if np.isfinite(number) else str(number)


def first_bad_record(
    x: np.ndarray, y: np.ndarray, t: np.ndarray, p: np.ndarray, width: int, height: int
) -> str | None:
    """Describe the first record (0-based) that breaks an event stream's rules, or ``None``.

    The rules: ``0 <= x < width``, ``0 <= y < height``, ``t >= 0``, ``t`` integral and
    non-decreasing, ``p`` in ``{0, 1}``. The record checked first is the earliest one
    with any problem, so the message points at the first place to look in the file.
    """
    n = x.size
    if not (y.size == t.size == p.size == n):
        return f"x, y, t and p have different lengths ({x.size}, {y.size}, {t.size}, {p.size})"
    if n == 0:
        return None
    bad_x = (x < 0) | (x >= width)
    bad_y = (y < 0) | (y >= height)
    bad_int = np.zeros(n, dtype=bool)
    for coord in (x, y):
        if np.issubdtype(np.asarray(coord).dtype, np.floating):
            bad_int |= ~np.isfinite(coord) | (coord != np.floor(coord))
    t_float = np.asarray(t, dtype=np.float64)
    bad_tval = ~np.isfinite(t_float) | (t_float < 0)
    if np.issubdtype(np.asarray(t).dtype, np.floating):
        bad_tval |= np.isfinite(t_float) & (t_float != np.floor(t_float))
    bad_order = np.zeros(n, dtype=bool)
    bad_order[1:] = t_float[1:] < t_float[:-1]
    bad_p = (p != 0) & (p != 1)
    bad = bad_int | bad_x | bad_y | bad_tval | bad_order | bad_p
    if not bad.any():
        return None
    i = int(np.flatnonzero(bad)[0])
    if bad_int[i]:
        what = f"x={_num(x[i])}, y={_num(y[i])}, but pixel coordinates must be integers"
    elif bad_x[i]:
        what = f"x={_num(x[i])} outside 0..{width - 1} (sensor width {width})"
    elif bad_y[i]:
        what = f"y={_num(y[i])} outside 0..{height - 1} (sensor height {height})"
    elif bad_tval[i]:
        what = f"t={_num(t[i])} us, but times must be finite, integral and >= 0 us"
    elif bad_order[i]:
        what = f"t={_num(t[i])} us before the previous record's t={_num(t[i - 1])} us (times must be sorted)"
    else:
        what = f"p={_num(p[i])}, but the polarity must be 0 (OFF) or 1 (ON)"
    return f"record {i} (0-based) has {what}"


@dataclass(frozen=True, slots=True, kw_only=True, eq=False)
class EventStream(IRNode):
    """Events of one sensor, sorted by time.

    Parameters
    ----------
    width, height
        Sensor size in pixels (e.g. 346 x 260 for a DAVIS346).
    x, y
        Pixel column and row of each event, ``0 <= x < width``, ``0 <= y < height``.
    t
        Timestamps in integer microseconds, ``>= 0`` and non-decreasing.
    p
        Polarity: 1 = ON (brighter), 0 = OFF (darker); ``{-1, +1}`` and bools are accepted
        and stored as ``{0, 1}``.

    Notes
    -----
    Arrays are stored as read-only copies (``x``, ``y`` int32, ``t`` int64, ``p`` int8).
    An empty stream is refused: no reader or preprocessing step can use one.
    """

    width: int = param(unit="px", low=1, integer=True)
    height: int = param(unit="px", low=1, integer=True)
    x: np.ndarray
    y: np.ndarray
    t: np.ndarray
    p: np.ndarray

    def _validate(self) -> None:
        arrays = {}
        for name in ("x", "y", "t", "p"):
            arr = np.asarray(getattr(self, name))
            if arr.ndim != 1:
                raise ValidationError(f"EventStream.{name} must be a 1-D array, got shape {arr.shape}.")
            if not (np.issubdtype(arr.dtype, np.number) or arr.dtype == np.bool_) or np.iscomplexobj(arr):
                raise ValidationError(f"EventStream.{name} must hold real numbers, got dtype {arr.dtype}.")
            arrays[name] = normalise_polarity(arr) if name == "p" else arr
        if arrays["t"].size == 0:
            raise ValidationError("EventStream has no events; an empty stream cannot be used.")
        problem = first_bad_record(
            arrays["x"], arrays["y"], arrays["t"], arrays["p"], int(self.width), int(self.height)
        )
        if problem is not None:
            raise ValidationError(f"EventStream: {problem}.")
        for name, dtype in (("x", np.int32), ("y", np.int32), ("t", np.int64), ("p", np.int8)):
            object.__setattr__(self, name, freeze_array(arrays[name], dtype=dtype))

    def __len__(self) -> int:
        return int(self.t.size)

    @property
    def sensor_size(self) -> tuple[int, int]:
        """``(width, height)`` in pixels."""
        return int(self.width), int(self.height)

    @property
    def t_start(self) -> int:
        """Time of the first event (us)."""
        return int(self.t[0])

    @property
    def duration_us(self) -> int:
        """Time from the first to the last event (us)."""
        return int(self.t[-1] - self.t[0])

    def time_window(self, start_us: int, end_us: int) -> EventStream:
        """The events with ``start_us <= t < end_us`` (absolute times, us), as a new stream."""
        lo, hi = np.searchsorted(self.t, [start_us, end_us], side="left")
        if hi <= lo:
            raise ValidationError(
                f"EventStream.time_window: no events in [{start_us}, {end_us}) us; "
                f"the stream spans [{self.t_start}, {int(self.t[-1])}] us."
            )
        return EventStream(
            width=self.width, height=self.height,
            x=self.x[lo:hi], y=self.y[lo:hi], t=self.t[lo:hi], p=self.p[lo:hi],
        )
