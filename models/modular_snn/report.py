"""Scores of members, ensemble and baselines at several sequence lengths, and their plots.

Every method gives a ``[reference, query]`` distance matrix: the SNNs through
``D = max(S) - S`` (Eq. 11-12), SAD and Perfect Memory directly on the same 28x28
patch-normalised images. Sequence matching of length ``L`` (Eq. 13) convolves each
distance matrix with an ``L x L`` identity kernel (``valid`` mode, as VPRSNN), and the
ground truth is cropped to match (:mod:`neurovpr.evaluation.sequence`). Metrics come
from :func:`neurovpr.evaluation.metrics.evaluate` with zero tolerance (Eq. 14).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from neurovpr.evaluation.concentration import match_concentration
from neurovpr.evaluation.metrics import distance_from_similarity, evaluate, precision_recall, recall_at_n
from neurovpr.evaluation.plots import plot_distance_matrix, plot_pr_curves, plot_recall_at_n
from neurovpr.evaluation.sequence import crop_ground_truth, identity_kernel
from neurovpr.models.baselines import perfect_memory_distances, sad_distances

from .inference import ensemble_similarity

__all__ = ["N_VALUES", "method_distances", "evaluate_similarities", "write_plots"]

#: Recall@N values reported in JSON.
N_VALUES = (1, 5, 10)


def method_distances(similarities: Sequence[np.ndarray], reference: np.ndarray, query: np.ndarray) -> dict[str, Any]:
    """Distance matrices: ``members`` (list), ``ensemble``, ``SAD`` and ``Perfect Memory``."""
    ref = np.asarray(reference, dtype=np.float64).reshape(len(reference), -1)
    qry = np.asarray(query, dtype=np.float64).reshape(len(query), -1)
    return {
        "members": [distance_from_similarity(s) for s in similarities],
        "ensemble": distance_from_similarity(ensemble_similarity(similarities)),
        "SAD": sad_distances(ref, qry, preprocess=False),
        "Perfect Memory": perfect_memory_distances(ref, qry, preprocess=False),
    }


def _sequence(d: np.ndarray, gt: Any, seq_len: int) -> tuple[np.ndarray, np.ndarray]:
    if seq_len == 1:
        return d, crop_ground_truth(gt, d.shape, 1)
    return identity_kernel(d, seq_len, mode="valid"), crop_ground_truth(gt, d.shape, seq_len)


def _score(d: np.ndarray, gt: Any, seq_len: int) -> dict[str, float]:
    dd, gg = _sequence(d, gt, seq_len)
    return {k: round(float(v), 6) for k, v in evaluate(dd, gg, n_values=N_VALUES).items()}


def _concentration(d: np.ndarray, gt: Any, seq_len: int) -> dict[str, float]:
    return match_concentration(_sequence(d, gt, seq_len)[0])


def evaluate_similarities(
    similarities: Sequence[np.ndarray],
    reference: np.ndarray,
    query: np.ndarray,
    ground_truth: Any,
    *,
    seq_lens: Sequence[int] = (1,),
) -> dict[str, Any]:
    """Metrics of every member, their mean, the ensemble and the baselines at each sequence length.

    Returns
    -------
    dict
        ``{"by_seq_len": {"L": {"members": [...], "mean_of_members": {...},
        "ensemble": {...}, "baselines": {"SAD": {...}, "Perfect Memory": {...}},
        "concentration": {"members": [...], "ensemble": {...}, "SAD": {...}, "Perfect Memory": {...}}}},
        "distances": method_distances(...), "ground_truth": ground_truth}``; ``concentration``
        is :func:`neurovpr.evaluation.concentration.match_concentration` of each method.
    """
    dist = method_distances(similarities, reference, query)
    by_len: dict[str, Any] = {}
    for seq_len in seq_lens:
        members = [_score(d, ground_truth, seq_len) for d in dist["members"]]
        by_len[str(int(seq_len))] = {
            "members": members,
            "mean_of_members": {k: round(float(np.mean([m[k] for m in members])), 6) for k in members[0]},
            "ensemble": _score(dist["ensemble"], ground_truth, seq_len),
            "baselines": {name: _score(dist[name], ground_truth, seq_len) for name in ("SAD", "Perfect Memory")},
            "concentration": {
                "members": [_concentration(d, ground_truth, seq_len) for d in dist["members"]],
                **{name: _concentration(dist[name], ground_truth, seq_len) for name in ("ensemble", "SAD", "Perfect Memory")},
            },
        }
    return {"by_seq_len": by_len, "distances": dist, "ground_truth": ground_truth}


def write_plots(result: dict[str, Any], folder: str | Path, seq_len: int, *, tag: str) -> dict[str, Path]:
    """Distance matrix (ensemble), PR curves and Recall@N curves at ``seq_len``, as PNG files."""
    folder = Path(folder)
    dist, gt = result["distances"], result["ground_truth"]
    n_members = len(dist["members"])
    methods = {"Modular SNN": dist["members"][0]}
    if n_members > 1:
        methods[f"Ensemble ({n_members})"] = dist["ensemble"]
    methods.update({"SAD": dist["SAD"], "Perfect Memory": dist["Perfect Memory"]})
    seq = {name: _sequence(d, gt, seq_len) for name, d in methods.items()}
    main = f"Ensemble ({n_members})" if n_members > 1 else "Modular SNN"
    d_main, g_main = seq[main]
    files = {
        "distance_matrix": plot_distance_matrix(
            d_main, folder / f"distance_matrix_{tag}.png", ground_truth=g_main, title=f"{main}, sequence length {seq_len}"
        ),
        "pr_curve": plot_pr_curves(
            {name: precision_recall(d, g) for name, (d, g) in seq.items()},
            folder / f"pr_curve_{tag}.png",
            title=f"Precision-recall, sequence length {seq_len}",
        ),
    }
    n_max = d_main.shape[0]
    n_values = [n for n in (1, 2, 5, 10, 15, 20, 25) if n <= n_max] or [1]
    files["recall_at_n"] = plot_recall_at_n(
        {name: recall_at_n(d, g, n_values) for name, (d, g) in seq.items()},
        folder / f"recall_at_n_{tag}.png",
        title=f"Recall@N, sequence length {seq_len}",
    )
    return files
