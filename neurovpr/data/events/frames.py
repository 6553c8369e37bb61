"""Frames built from events or PN spikes, for frame-based methods (e.g. the route baselines).

Both functions cut the recording into consecutive time windows, either of a fixed length
or a fixed number of windows over the whole recording (equal fractions of it, which
aligns two recordings of the same route by normalised time), and count what falls into
each pixel (or mega-pixel) in each window.
"""

from __future__ import annotations

import numpy as np

from neurovpr.data.events.pn_spikes import PNSpikes
from neurovpr.data.events.stream import EventStream
from neurovpr.errors import ValidationError

__all__ = ["pn_frames", "event_frames"]


def _window_index(times: np.ndarray, start: float, duration: float, bin_len: float | None, n_frames: int | None,
                  caller: str) -> tuple[np.ndarray, int]:
    if (bin_len is None) == (n_frames is None):
        raise ValidationError(f"{caller}: give exactly one of the window length and n_frames.")
    if n_frames is not None:
        if int(n_frames) != n_frames or n_frames < 1:
            raise ValidationError(f"{caller}: n_frames must be a positive integer, got {n_frames!r}.")
        n = int(n_frames)
        bin_len = duration / n
    else:
        if not (bin_len is not None and np.isfinite(bin_len) and bin_len > 0):
            raise ValidationError(f"{caller}: the window length must be > 0, got {bin_len!r}.")
        n = max(int(np.ceil(duration / bin_len)), 1)
    which = np.floor((np.asarray(times, dtype=np.float64) - start) / bin_len).astype(np.int64)
    return np.clip(which, 0, n - 1), n


def pn_frames(
    spikes: PNSpikes,
    grid: tuple[int, int],
    *,
    bin_ms: float | None = None,
    n_frames: int | None = None,
) -> np.ndarray:
    """Count PN spikes in time windows into frames with one pixel per PN.

    Parameters
    ----------
    spikes
        The PN spikes.
    grid
        ``(n_rows, n_cols)`` of the mega-pixel grid (``binning.grid``); PN ``i`` is pixel
        ``(i % n_rows, i // n_rows)``, the numbering of
        :meth:`~neurovpr.data.events.MegaPixelBinning.pn_index`.
    bin_ms, n_frames
        Exactly one: windows of ``bin_ms`` ms (the last one may be shorter), or
        ``n_frames`` equal windows over the recording's duration.

    Returns
    -------
    numpy.ndarray
        ``(n_frames, n_rows, n_cols)`` float spike counts.
    """
    n_rows, n_cols = (int(v) for v in grid)
    if n_rows * n_cols != spikes.n_pn:
        raise ValidationError(
            f"pn_frames: grid {n_rows}x{n_cols} has {n_rows * n_cols} pixels but there are {spikes.n_pn} PNs."
        )
    which, n = _window_index(spikes.times_ms, 0.0, spikes.duration_ms, bin_ms, n_frames, "pn_frames")
    col, row = np.divmod(spikes.idx, n_rows)
    flat = (which * n_rows + row) * n_cols + col
    return np.bincount(flat, minlength=n * n_rows * n_cols).astype(np.float64).reshape(n, n_rows, n_cols)


def event_frames(
    stream: EventStream,
    *,
    window_us: float | None = None,
    n_frames: int | None = None,
    polarity: str = "both",
) -> np.ndarray:
    """Count events in time windows into ``(n_frames, height, width)`` frames.

    Windows start at the first event; give ``window_us`` or ``n_frames`` (see
    :func:`pn_frames`). ``polarity`` is ``"both"``, ``"on"`` or ``"off"``.
    """
    if polarity not in ("both", "on", "off"):
        raise ValidationError(f"event_frames: polarity {polarity!r} is not 'both', 'on' or 'off'.")
    keep = np.ones(len(stream), dtype=bool) if polarity == "both" else stream.p == (1 if polarity == "on" else 0)
    duration = float(stream.duration_us) + 1.0
    which, n = _window_index(stream.t[keep], float(stream.t_start), duration, window_us, n_frames, "event_frames")
    flat = (which * stream.height + stream.y[keep]) * stream.width + stream.x[keep]
    counts = np.bincount(flat, minlength=n * stream.height * stream.width)
    return counts.astype(np.float64).reshape(n, stream.height, stream.width)
