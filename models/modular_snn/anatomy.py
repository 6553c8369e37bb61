"""Why some reference places win many queries: the neurons behind each place's score.

With the "standard" place score (:mod:`.inference`) a place's similarity to a query is
the spike count of its kept (not hyperactive) neurons divided by all the neurons
assigned to it. Two properties of a place therefore raise its score for every query: a
large share of kept neurons (few of its neurons were zeroed as hyperactive), and kept
neurons that answer many images (broadly tuned ones, just below the hyperactive
threshold). A place that has either wins queries that are not its own; the best matches
concentrate on it (:mod:`neurovpr.evaluation.concentration`).

- :func:`place_anatomy`: per reference place, neurons assigned, neurons kept, and the
  mean activity (reference images fired for) of the kept ones;
- :func:`hub_anatomy`: the same figures for the most-chosen places of a distance matrix
  against all places, and the rank correlation (Spearman) of each place's number of wins
  with its kept share, its kept neurons' activity and its mean similarity.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from scipy.stats import spearmanr

import neurovpr as nv
from neurovpr.evaluation.concentration import most_chosen

from .inference import hyperactive_neurons

__all__ = ["place_anatomy", "hub_anatomy"]


def place_anatomy(modules: Sequence[tuple[np.ndarray, np.ndarray]], theta: float, n_reference: int) -> dict[str, np.ndarray]:
    """Per reference place: ``assigned``, ``kept`` and ``kept_activity`` (``(n_reference,)`` arrays).

    Parameters
    ----------
    modules
        ``(assignments, activity)`` of every module: the global place of each neuron (-1:
        unassigned) and its activity (reference images fired for, or spikes), as
        :func:`.inference.assign_neurons` and :func:`.inference.reference_activity` give them.
    theta
        The hyperactive threshold (:func:`.inference.hyperactive_neurons`; 0 marks none).
    n_reference
        The number of reference places.

    Returns
    -------
    dict
        ``assigned``: neurons assigned to the place; ``kept``: those not hyperactive;
        ``kept_activity``: the kept neurons' mean activity, NaN for a place with none.
    """
    assigned = np.zeros(int(n_reference), dtype=np.int64)
    kept = np.zeros(int(n_reference), dtype=np.int64)
    activity_sum = np.zeros(int(n_reference))
    for assignments, activity in modules:
        a = np.asarray(assignments, dtype=np.int64)
        act = np.asarray(activity, dtype=np.float64)
        if act.shape != a.shape:
            raise nv.ValidationError(f"place anatomy: activity of shape {act.shape} does not match {a.size} neuron assignments.")
        if a.size and a.max() >= n_reference:
            raise nv.ValidationError(f"place anatomy: a neuron is assigned to place {int(a.max())}, beyond {n_reference} places.")
        on = a >= 0
        keep = on & ~hyperactive_neurons(act, theta)
        assigned += np.bincount(a[on], minlength=int(n_reference))
        kept += np.bincount(a[keep], minlength=int(n_reference))
        activity_sum += np.bincount(a[keep], weights=act[keep], minlength=int(n_reference))
    with np.errstate(invalid="ignore", divide="ignore"):
        kept_activity = np.where(kept > 0, activity_sum / np.maximum(kept, 1), np.nan)
    return {"assigned": assigned, "kept": kept, "kept_activity": kept_activity}


def _rank_correlation(x: np.ndarray, y: np.ndarray) -> float | None:
    ok = np.isfinite(x) & np.isfinite(y)
    if ok.sum() < 3 or np.ptp(x[ok]) == 0 or np.ptp(y[ok]) == 0:
        return None
    return float(spearmanr(x[ok], y[ok]).statistic)


def hub_anatomy(distances: np.ndarray, anatomy: dict[str, np.ndarray], *, top_fraction: float = 0.02) -> dict[str, object]:
    """The neurons behind the most-chosen places of ``distances`` against those of all places.

    Parameters
    ----------
    distances
        ``[reference, query]`` distance matrix (lower = more alike), its rows the places of ``anatomy``.
    anatomy
        :func:`place_anatomy` of those places (each array indexed like the rows).
    top_fraction
        Which places count as the most chosen
        (:func:`neurovpr.evaluation.concentration.most_chosen`, as ``match_concentration``).

    Returns
    -------
    dict
        ``top_places``; ``top`` and ``all``: mean ``assigned``, ``kept_share`` (kept /
        assigned over places with neurons) and ``kept_activity`` of the most-chosen places
        and of every place; ``spearman_wins_vs``: rank correlation of each place's number
        of wins with its ``kept_share``, its ``kept_activity`` and its ``mean_similarity``
        (minus its mean distance), ``None`` where one side is constant.
    """
    d = np.asarray(distances, dtype=np.float64)
    n_ref = d.shape[0]
    for name in ("assigned", "kept", "kept_activity"):
        if np.shape(anatomy[name]) != (n_ref,):
            raise nv.ValidationError(f"hub anatomy: {name} has shape {np.shape(anatomy[name])}, expected ({n_ref},).")
    chosen, top = most_chosen(d, top_fraction=top_fraction)
    wins = chosen.astype(np.float64)
    assigned = np.asarray(anatomy["assigned"], dtype=np.float64)
    with np.errstate(invalid="ignore", divide="ignore"):
        share = np.where(assigned > 0, np.asarray(anatomy["kept"], dtype=np.float64) / assigned, np.nan)
    activity = np.asarray(anatomy["kept_activity"], dtype=np.float64)

    def _means(rows: np.ndarray) -> dict[str, float | None]:
        def _mean(x: np.ndarray) -> float | None:
            x = x[np.isfinite(x)]
            return float(x.mean()) if x.size else None

        return {"assigned": _mean(assigned[rows]), "kept_share": _mean(share[rows]), "kept_activity": _mean(activity[rows])}

    return {
        "top_places": int(top.size),
        "top_share": float(wins[top].sum() / d.shape[1]),
        "top": _means(top),
        "all": _means(np.arange(n_ref)),
        "spearman_wins_vs": {
            "kept_share": _rank_correlation(wins, share),
            "kept_activity": _rank_correlation(wins, activity),
            "mean_similarity": _rank_correlation(wins, -d.mean(axis=1)),
        },
    }
