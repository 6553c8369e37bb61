"""Times on the step grid of docs/semantics.md: delays and spike stamps in whole steps."""

from __future__ import annotations

import math

import numpy as np

__all__ = ["delay_steps", "grid_steps", "window_steps"]

#: Slack when a time that should lie on the grid is divided by the step (float round-off).
_GRID_SLACK = 1e-9


def delay_steps(delay_ms: np.ndarray | float, dt: float) -> np.ndarray:
    """Delays in whole steps: ``round(delay / dt)``, at least one, except a zero delay (zero steps).

    Parameters
    ----------
    delay_ms
        Delays (ms), one value or an array.
    dt
        The time step (ms).

    Returns
    -------
    numpy.ndarray
        ``int64`` steps, the shape of ``delay_ms``.
    """
    delay = np.asarray(delay_ms, dtype=np.float64)
    return np.where(delay == 0, 0, np.maximum(np.rint(delay / dt), 1)).astype(np.int64)


def grid_steps(times_ms: np.ndarray, dt: float) -> np.ndarray:
    """The step each time is stamped at: ``round(t / dt)`` (how a ``SpikeSourceArray`` spike is placed)."""
    return np.rint(np.asarray(times_ms, dtype=np.float64) / dt).astype(np.int64)


def window_steps(start_ms: float, duration_ms: float, dt: float) -> tuple[int, float]:
    """Steps ``[first, end)`` whose start time lies in ``[start, start + duration)``.

    ``end`` is ``math.inf`` for an unbounded window; both bounds tolerate the round-off of
    a window edge that lies on the grid.
    """
    first = math.ceil(start_ms / dt - _GRID_SLACK)
    stop = start_ms + duration_ms
    end = math.inf if math.isinf(stop) else float(math.ceil(stop / dt - _GRID_SLACK))
    return first, end
