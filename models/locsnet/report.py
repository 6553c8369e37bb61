"""Scoring an evaluation: metrics, the SAD baseline, plots and the activity record.

A method's answer for each query is a similarity per place (spike counts of the place
layer, or the rate model's place activations); its distance is ``max(S) - S``
(:func:`neurovpr.evaluation.distance_from_similarity`). The metrics are the paper's:
precision at 100% recall (each query's best place accepted in order of confidence),
the area under the precision-recall curve and Recall@N, with exact place labels.
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
from scipy.spatial.distance import cdist

from neurovpr.evaluation.metrics import PRCurve, distance_from_similarity, precision_recall, recall_at_n
from neurovpr.evaluation.plots import plot_pr_curves, plot_recall_at_n
from neurovpr.fileio import atomic_write_text

from .inference import QueryResult
from .places import PlaceLabels

__all__ = ["score", "sad_place_distances", "write_plots", "write_activity", "PLOT_N"]

#: N values of the Recall@N curve.
PLOT_N = (1, 2, 5, 10, 15, 20, 25, 50)


def score(distances: np.ndarray, ground_truth: np.ndarray) -> tuple[dict[str, float], PRCurve, dict[int, float]]:
    """Metrics (R@1, R@5, R@10, P@100R, R@100P, AUC_PR), PR curve and Recall@N curve of a ``[place, query]`` distance matrix."""
    n_values = [n for n in PLOT_N if n <= distances.shape[0]] or [1]
    recalls = recall_at_n(distances, ground_truth, n_values)
    curve = precision_recall(distances, ground_truth)
    metrics = {f"R@{n}": recalls[n] for n in (1, 5, 10) if n in recalls}
    metrics.update({"P@100R": curve.precision_at_100_recall, "R@100P": curve.recall_at_100_precision, "AUC_PR": curve.auc})
    return metrics, curve, recalls


def similarity_distances(similarity: np.ndarray) -> np.ndarray:
    """``max(S) - S`` of a ``[place, query]`` similarity matrix."""
    return distance_from_similarity(similarity)


def sad_place_distances(reference: np.ndarray, query: np.ndarray, labels: PlaceLabels) -> np.ndarray:
    """SAD between the network inputs, ``[place, query]``: each place keeps its closest reference frame.

    ``reference`` and ``query`` are the preprocessed (N, H, W) inputs; the distance is
    the mean absolute difference over pixels.
    """
    ref = np.asarray(reference, dtype=np.float64).reshape(reference.shape[0], -1)
    qry = np.asarray(query, dtype=np.float64).reshape(query.shape[0], -1)
    d = cdist(ref, qry, metric="cityblock") / ref.shape[1]
    out = np.full((labels.n_places, qry.shape[0]), np.inf)
    keep = labels.labels >= 0
    np.minimum.at(out, labels.labels[keep], d[keep])
    return out


def write_plots(
    folder: str | Path, curves: Mapping[str, PRCurve], recalls: Mapping[str, Mapping[int, float]], *, title: str
) -> list[str]:
    """``pr.png`` and ``recall_at_n.png`` in ``folder``; returns their paths."""
    folder = Path(folder)
    pr = plot_pr_curves(dict(curves), folder / "pr.png", title=f"Precision-recall, {title}")
    rn = plot_recall_at_n(dict(recalls), folder / "recall_at_n.png", title=f"Recall@N, {title}")
    return [str(pr), str(rn)]


def write_activity(run_dir: str | Path, result: QueryResult, dt_ms: float) -> dict[str, Any]:
    """Record the per-inference activity of an evaluation for ``neurovpr energy``.

    Uses :func:`neurovpr.hardware.energy.write_activity` (totals divided by the number
    of queries, spikes per population, CPU time) when the energy module is installed;
    otherwise writes ``RUN_DIR/activity.json`` with the per-inference counts itself.
    Returns what was written.
    """
    inferences = int(result.counts.shape[1])
    totals = dict(result.totals or {})
    keys = ("steps", "neuron_updates", "spikes", "synaptic_events", "plastic_updates")
    per_inference = {k: float(totals.get(k, 0)) / inferences for k in keys}
    try:
        from neurovpr.hardware.energy import write_activity as energy_write
    except ImportError:
        energy_write = None
    if energy_write is not None:
        population = {name: value * inferences for name, value in result.layer_spikes.items()}
        energy_write(run_dir, totals, inferences, dt_ms=dt_ms, population_spikes=population,
                     cpu_seconds=result.cpu_seconds)
        return {"writer": "neurovpr.hardware.energy", "inferences": inferences, **per_inference}
    record = {"inferences": inferences, **per_inference}
    atomic_write_text(Path(run_dir) / "activity.json", json.dumps(record, indent=2))
    return {"writer": "locsnet", **record}
