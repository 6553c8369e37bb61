"""The PNGs of :mod:`neurovpr.apps.compare`: accuracy, agreement, time per query and energy per backend,
and the confusion of predicted places between each backend and the reference backend."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from neurovpr.errors import ValidationError
from neurovpr.fileio import save_figure

if TYPE_CHECKING:
    from neurovpr.apps.compare_result import Comparison

__all__ = ["plot_comparison", "place_confusion", "plot_place_confusion"]


def _bars(ax: Any, x: np.ndarray, values: list[float | None], color: str, ylabel: str) -> None:
    """One bar per backend; a log axis when the values span more than a factor of 20."""
    heights = np.array([np.nan if v is None else v for v in values], dtype=np.float64)
    ax.bar(x, heights, 0.6, color=color)
    ax.set_ylabel(ylabel)
    positive = heights[np.isfinite(heights) & (heights > 0)]
    if positive.size and positive.max() > 20 * positive.min():
        ax.set_yscale("log")


def plot_comparison(comparison: Comparison, path: str | Path) -> Path:
    """Bar charts of accuracy, agreement and correlation, time per query and (with a hwspec) energy.

    Refused backends keep their place on the axis, marked "refused". Returns the PNG's path.
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    path = Path(path)
    if path.suffix.lower() != ".png":
        raise ValidationError(f"plot path {path} must end in .png.")
    rows = comparison.rows
    x = np.arange(len(rows))
    labels = [r.backend for r in rows]
    panels = 4 if comparison.hardware is not None else 3
    fig = Figure(figsize=(4.2 * panels, 4.0), dpi=100)
    FigureCanvasAgg(fig)
    axes = [fig.add_subplot(1, panels, i + 1) for i in range(panels)]

    def grouped(ax: Any, series: dict[str, list[float | None]], ylabel: str) -> None:
        width = 0.8 / max(len(series), 1)
        for k, (label, values) in enumerate(series.items()):
            heights = [np.nan if v is None else v for v in values]
            ax.bar(x - 0.4 + width * (k + 0.5), heights, width, label=label)
        ax.set_ylabel(ylabel)
        known = [v for vals in series.values() for v in vals if v is not None]
        ax.set_ylim(min([0.0, *known]), 1.05)
        if series:
            ax.legend(fontsize=7, loc="lower right")

    metrics = comparison.shown_metrics()
    grouped(axes[0], {m: [r.metrics.get(m) if r.ran else None for r in rows] for m in metrics}, "accuracy")
    axes[0].set_title(f"{comparison.model}: accuracy")
    ref = comparison.reference_backend or "-"
    grouped(
        axes[1],
        {
            "prediction agreement": [r.agreement for r in rows],
            "spike-count r": [r.spike_count_correlation for r in rows],
        },
        "agreement / Pearson r",
    )
    axes[1].set_title(f"against {ref}")
    secs = [r.seconds_per_query if r.ran else None for r in rows]
    _bars(axes[2], x, secs, "tab:gray", "seconds per query")
    axes[2].set_title("time per query (measured)")
    if comparison.hardware is not None:
        joules = [(r.energy or {}).get("joules_per_inference") if r.ran else None for r in rows]
        _bars(axes[3], x, joules, "tab:green", "joules per inference (estimated)")
        axes[3].set_title(f"energy on {comparison.hardware}")
    for ax in axes:
        ax.set_xticks(x)
        ax.set_xticklabels(labels, rotation=30, ha="right", fontsize=8)
        for i, row in enumerate(rows):
            if not row.ran:
                ax.text(i, 0.5, "refused", transform=ax.get_xaxis_transform(), ha="center", va="center",
                        rotation=90, color="tab:red", fontsize=8)  # fmt: skip
    fig.suptitle(f"{comparison.model} on {len(rows)} backends ({comparison.run})", fontsize=9)
    fig.tight_layout()
    return save_figure(fig, path)


def place_confusion(comparison: Comparison) -> dict[str, Any]:
    """Per backend, how its predicted places map onto the reference backend's, query by query.

    Returns the JSON object ``compare`` writes: ``reference_backend``, ``places`` (every place
    predicted by some backend, sorted) and per backend that ran ``{"agreement", "pairs"}``,
    where ``pairs`` lists ``[reference_place, place, queries]`` for every non-empty cell.
    """
    ran = [r for r in comparison.rows if r.ran and r.predictions is not None]
    ref = next((r for r in ran if r.backend == comparison.reference_backend), None)
    out: dict[str, Any] = {"reference_backend": None if ref is None else ref.backend, "places": [], "backends": {}}
    if ref is None:
        return out
    places = np.unique(np.concatenate([r.predictions for r in ran]))
    out["places"] = places.tolist()
    for row in ran:
        pairs, counts = np.unique(np.stack([ref.predictions, row.predictions], axis=1), axis=0, return_counts=True)
        out["backends"][row.backend] = {
            "agreement": row.agreement,
            "pairs": [[int(a), int(b), int(c)] for (a, b), c in zip(pairs, counts, strict=True)],
        }
    return out


def plot_place_confusion(confusion: dict[str, Any], path: str | Path, *, title: str = "Predicted places") -> Path:
    """One confusion panel per backend (reference backend's place down, this backend's across); returns the PNG."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    if Path(path).suffix.lower() != ".png":
        raise ValidationError(f"plot path {path} must end in .png.")
    backends = confusion["backends"]
    if not backends:
        raise ValidationError("plot_place_confusion: no backend ran, so there is no confusion to draw.")
    index = {p: i for i, p in enumerate(confusion["places"])}
    n = len(index)
    fig = Figure(figsize=(3.6 * len(backends) + 0.8, 4.0), dpi=100, layout="constrained")
    FigureCanvasAgg(fig)
    axes = fig.subplots(1, len(backends), squeeze=False)[0]
    for ax, (name, entry) in zip(axes, backends.items(), strict=True):
        mat = np.zeros((n, n), dtype=np.int64)
        for a, b, c in entry["pairs"]:
            mat[index[a], index[b]] += c
        image = ax.imshow(mat, cmap="viridis", interpolation="nearest", aspect="auto")
        agree = entry["agreement"]
        ax.set_title(f"{name}" + ("" if agree is None else f" (agreement {agree:.3f})"), fontsize=9)
        unit = ""
        if n <= 20:  # few places: name them on the axes; else axes count positions in the sorted "places"
            ax.set_xticks(range(n), [str(p) for p in confusion["places"]], fontsize=7)
            ax.set_yticks(range(n), [str(p) for p in confusion["places"]], fontsize=7)
        else:
            unit = " (rank among predicted places)"
        ax.set_xlabel(f"place predicted on {name}{unit}")
        ax.set_ylabel(f"place predicted on {confusion['reference_backend']}{unit}")
        fig.colorbar(image, ax=ax, label="queries", shrink=0.8)
    fig.suptitle(title)
    return save_figure(fig, path)
