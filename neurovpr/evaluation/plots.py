"""PNG plots of evaluation results: distance matrix, precision-recall curves, Recall@N curves.

Figures are built with matplotlib's object API on the Agg canvas (no pyplot state), so
plotting works headless and from worker processes. Every function writes one PNG and
returns its path.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

import numpy as np

from neurovpr.errors import ValidationError
from neurovpr.evaluation.metrics import PRCurve, check_distances, ground_truth_matrix
from neurovpr.fileio import save_figure

__all__ = ["plot_distance_matrix", "plot_pr_curves", "plot_recall_at_n", "plot_roc_curves"]


def _figure(width: float = 5.0, height: float = 4.0):
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(width, height), dpi=100)
    FigureCanvasAgg(fig)
    return fig


def _save(fig, path: str | Path) -> Path:
    path = Path(path)
    if path.suffix.lower() != ".png":
        raise ValidationError(f"plot path {path} must end in .png.")
    fig.tight_layout()
    return save_figure(fig, path)


def plot_distance_matrix(distances: np.ndarray, path: str | Path, *, ground_truth=None, title: str = "Distance matrix") -> Path:
    """Heat map of a ``[reference, query]`` distance matrix, best match per query and ground truth overlaid."""
    d = check_distances(distances)
    fig = _figure(5.5, 4.5)
    ax = fig.add_subplot(1, 1, 1)
    finite = d[np.isfinite(d)]
    vmin, vmax = (float(finite.min()), float(finite.max())) if finite.size else (0.0, 1.0)
    im = ax.imshow(d, cmap="Blues_r", aspect="auto", interpolation="nearest", vmin=vmin, vmax=vmax)
    fig.colorbar(im, ax=ax, label="distance (lower = more alike)")
    q = np.arange(d.shape[1])
    ax.plot(q, np.argmin(d, axis=0), ".", color="tab:red", markersize=2, label="best match")
    if ground_truth is not None or d.shape[0] == d.shape[1]:
        gt = ground_truth_matrix(ground_truth, d.shape)
        r_gt, q_gt = np.nonzero(gt)
        ax.plot(q_gt, r_gt, ",", color="tab:orange", alpha=0.6, label="ground truth")
    ax.set_xlabel("query index")
    ax.set_ylabel("reference index")
    ax.set_title(title)
    ax.legend(loc="upper right", fontsize=7, markerscale=3)
    return _save(fig, path)


def plot_pr_curves(curves: Mapping[str, PRCurve], path: str | Path, *, title: str = "Precision-recall") -> Path:
    """One precision-recall curve per method, labelled with its AUC."""
    if not curves:
        raise ValidationError("plot_pr_curves needs at least one curve.")
    fig = _figure()
    ax = fig.add_subplot(1, 1, 1)
    for name, curve in curves.items():
        ax.plot(curve.recall, curve.precision, label=f"{name} (AUC {curve.auc:.3f})")
    ax.set_xlim(0.0, 1.02)
    ax.set_ylim(0.0, 1.02)
    ax.set_xlabel("recall")
    ax.set_ylabel("precision")
    ax.set_title(title)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    return _save(fig, path)


def plot_recall_at_n(recalls: Mapping[str, Mapping[int, float]], path: str | Path, *, title: str = "Recall@N") -> Path:
    """Recall@N against N, one line per method."""
    if not recalls:
        raise ValidationError("plot_recall_at_n needs at least one method.")
    fig = _figure()
    ax = fig.add_subplot(1, 1, 1)
    for name, values in recalls.items():
        ns = sorted(values)
        ax.plot(ns, [values[n] for n in ns], marker="o", label=name)
    ax.set_ylim(0.0, 1.02)
    ax.set_xlabel("N")
    ax.set_ylabel("Recall@N")
    ax.set_title(title)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    return _save(fig, path)


def plot_roc_curves(curves: Mapping[str, tuple[np.ndarray, np.ndarray, float]], path: str | Path, *, title: str = "ROC") -> Path:
    """ROC curves: ``{name: (false_positive_rate, true_positive_rate, auc)}``."""
    if not curves:
        raise ValidationError("plot_roc_curves needs at least one curve.")
    fig = _figure()
    ax = fig.add_subplot(1, 1, 1)
    for name, (fpr, tpr, area) in curves.items():
        ax.plot(fpr, tpr, label=f"{name} (AUC {area:.3f})")
    ax.plot([0, 1], [0, 1], "--", color="gray", linewidth=0.8)
    ax.set_xlabel("false positive rate")
    ax.set_ylabel("true positive rate")
    ax.set_title(title)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    return _save(fig, path)
