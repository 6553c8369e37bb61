"""PNG figures of a mushroom-body evaluation: MBON traces along the route, familiarity, ROC curves.

Figures use matplotlib's object API on the Agg canvas (no pyplot state). The learned
route segment is shaded in every panel drawn against normalised route position.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

import numpy as np

from neurovpr.evaluation.plots import plot_roc_curves
from neurovpr.fileio import save_figure

__all__ = ["plot_mbon_traces", "plot_roc_curves", "plot_familiarity"]

_SHADE = {"color": "tab:green", "alpha": 0.15, "linewidth": 0}


def _figure(width: float, height: float):
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(width, height), dpi=100)
    FigureCanvasAgg(fig)
    return fig


def _save(fig, path: str | Path) -> Path:
    fig.tight_layout()
    return save_figure(fig, path)


def _positions(n: int) -> np.ndarray:
    return (np.arange(n) + 0.5) / n


def _excerpt(ax, times: np.ndarray, before: np.ndarray, after: np.ndarray, centre_ms: float, width_ms: float,
             title: str) -> None:
    lo, hi = centre_ms - width_ms / 2, centre_ms + width_ms / 2
    keep = (times >= lo) & (times < hi)
    ax.plot(times[keep] - lo, before[keep], color="tab:gray", linewidth=0.6, label="before learning")
    ax.plot(times[keep] - lo, after[keep], color="tab:blue", linewidth=0.6, label="after learning")
    ax.set_title(title, fontsize=9)
    ax.set_xlabel(f"ms from {lo / 1000.0:.2f} s")
    ax.grid(alpha=0.3)


def plot_mbon_traces(
    path: str | Path,
    *,
    rates_before: np.ndarray,
    rates_after: np.ndarray,
    v_times_ms: np.ndarray,
    v_before_mv: np.ndarray,
    v_after_mv: np.ndarray,
    duration_ms: float,
    segment: tuple[float, float],
    title: str = "MBON",
    excerpt_ms: float = 100.0,
) -> Path:
    """MBON rate per window along the route before and after learning (learned segment
    shaded), and the MBON membrane potential in two excerpts of ``excerpt_ms``: at the
    centre of the learned segment and at the centre of the longer unlearned part."""
    fig = _figure(8.0, 6.0)
    ax1 = fig.add_subplot(2, 1, 1)
    x = _positions(len(rates_before))
    ax1.axvspan(*segment, **_SHADE, label="learned segment")
    ax1.plot(x, rates_before, color="tab:gray", label="before learning")
    ax1.plot(x, rates_after, color="tab:blue", label="after learning")
    ax1.set_xlabel("route position (normalised time)")
    ax1.set_ylabel("MBON rate (Hz)")
    ax1.set_xlim(0, 1)
    ax1.set_title(title)
    ax1.legend(fontsize=8, loc="upper right")
    ax1.grid(alpha=0.3)
    times = np.asarray(v_times_ms, dtype=np.float64)
    start, end = segment
    outside = start / 2 if start >= 1 - end else (1 + end) / 2
    width = min(excerpt_ms, duration_ms * (end - start))
    ax2 = fig.add_subplot(2, 2, 3)
    _excerpt(ax2, times, np.asarray(v_before_mv), np.asarray(v_after_mv), duration_ms * (start + end) / 2, width,
             "inside the learned segment")  # fmt: skip
    ax2.set_ylabel("MBON v (mV)")
    ax2.legend(fontsize=7, loc="lower right")
    ax3 = fig.add_subplot(2, 2, 4, sharey=ax2)
    _excerpt(ax3, times, np.asarray(v_before_mv), np.asarray(v_after_mv), duration_ms * outside, width,
             "outside it")  # fmt: skip
    return _save(fig, path)


def plot_familiarity(
    path: str | Path,
    scores: Mapping[str, np.ndarray],
    *,
    segment: tuple[float, float],
    title: str = "Familiarity along the route",
) -> Path:
    """Each method's familiarity per window (scaled to its own ``[0, 1]`` range) along the route."""
    fig = _figure(8.0, 3.5)
    ax = fig.add_subplot(1, 1, 1)
    ax.axvspan(*segment, **_SHADE, label="learned segment")
    for name, values in scores.items():
        s = np.asarray(values, dtype=np.float64)
        lo, hi = float(s.min()), float(s.max())
        scaled = (s - lo) / (hi - lo) if hi > lo else np.zeros_like(s)
        ax.plot(_positions(s.size), scaled, label=name, linewidth=1.0)
    ax.set_xlim(0, 1)
    ax.set_xlabel("route position (normalised time)")
    ax.set_ylabel("familiarity (min-max scaled)")
    ax.set_title(title)
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    return _save(fig, path)
