"""Place-recognition metrics on a distance matrix.

Convention for the whole project: a distance matrix ``D`` is indexed
``[reference, query]`` (column ``q`` scores every reference place for query ``q``) and
lower means more alike. A spiking model's per-place spike sums form a similarity
matrix ``S`` of the same shape; its distance is ``D = max(S) - S`` (Hussaini et al.
2024, Eq. 11-12; :func:`distance_from_similarity`). Ground truth is anything
:func:`ground_truth_matrix` accepts; a query with no matching reference is left out of
Recall@N and of the precision-recall curve.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np

from neurovpr.data.ground_truth import GroundTruth
from neurovpr.errors import ValidationError

__all__ = [
    "distance_from_similarity",
    "check_distances",
    "ground_truth_matrix",
    "best_matches",
    "correct_top1",
    "recall_at_n",
    "PRCurve",
    "precision_recall",
    "roc",
    "auc_roc",
    "correct_match_sparsity",
    "evaluate",
]

GroundTruthLike = GroundTruth | np.ndarray | Sequence[int] | None
DEFAULT_N_VALUES = (1, 5, 10, 15, 20, 25)


def distance_from_similarity(similarity: np.ndarray) -> np.ndarray:
    """``max(S) - S``: the distance matrix of a similarity matrix (Eq. 12; VPRSNN's ``invert_dMat``)."""
    s = np.asarray(similarity, dtype=np.float64)
    if s.ndim != 2 or s.size == 0:
        raise ValidationError(f"similarity matrix must be a non-empty 2-D [reference, query] array, got {s.shape}.")
    if np.isnan(s).any():
        raise ValidationError("similarity matrix has NaN entries.")
    return s.max() - s


def check_distances(distances: np.ndarray, name: str = "distance matrix") -> np.ndarray:
    """Return ``distances`` as a float64 ``[reference, query]`` array; refuse NaN, empty or non-2-D input."""
    d = np.asarray(distances, dtype=np.float64)
    if d.ndim != 2 or d.shape[0] == 0 or d.shape[1] == 0:
        raise ValidationError(f"{name} must be a non-empty 2-D [reference, query] array, got shape {d.shape}.")
    if np.isnan(d).any():
        raise ValidationError(f"{name} has {int(np.isnan(d).sum())} NaN entries.")
    return d


def ground_truth_matrix(ground_truth: GroundTruthLike, shape: tuple[int, int], tolerance: int = 0) -> np.ndarray:
    """Boolean ``[reference, query]`` match matrix of the given ``shape``.

    ``ground_truth`` may be a :class:`~neurovpr.data.ground_truth.GroundTruth`, a
    boolean matrix, a 1-D array giving each query's matching reference index, or
    ``None`` (query ``i`` matches reference ``i``). ``tolerance`` widens every match by
    that many reference indices either side (0 = exact, as in the paper).
    """
    n_ref, n_q = shape
    if ground_truth is None:
        if n_ref != n_q:
            raise ValidationError(f"without a ground truth query i matches reference i, but the matrix is {n_ref} x {n_q}.")
        gt = GroundTruth.aligned(n_ref)
    elif isinstance(ground_truth, GroundTruth):
        gt = ground_truth
    else:
        arr = np.asarray(ground_truth)
        if arr.ndim == 2:
            if arr.dtype != np.bool_:
                raise ValidationError(f"a ground-truth matrix must be boolean, got dtype {arr.dtype}.")
            gt = GroundTruth(matrix=arr)
        elif arr.ndim == 1 and np.issubdtype(arr.dtype, np.integer):
            if arr.size != n_q:
                raise ValidationError(f"ground truth lists {arr.size} reference indices for {n_q} queries.")
            gt = GroundTruth.from_pairs(enumerate(arr.tolist()), n_ref, n_q)
        else:
            raise ValidationError(
                f"ground truth must be a GroundTruth, a boolean matrix or one reference index per query, got an "
                f"array of shape {arr.shape} and dtype {arr.dtype}."
            )
    if gt.shape != (n_ref, n_q):
        raise ValidationError(f"ground truth has shape {gt.shape} [reference, query] but the distance matrix is {n_ref} x {n_q}.")
    return gt.with_tolerance(tolerance).matrix


def best_matches(distances: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Index and distance of each query's closest reference (ties: the lowest index)."""
    d = check_distances(distances)
    idx = np.argmin(d, axis=0)
    return idx, d[idx, np.arange(d.shape[1])]


def _first_correct_rank(d: np.ndarray, gt: np.ndarray, ties: str) -> np.ndarray:
    """0-based rank of the best-ranked matching reference per query (``inf`` when none matches)."""
    has = gt.any(axis=0)
    rank = np.full(d.shape[1], np.inf)
    if ties == "index":
        order = np.argsort(d, axis=0, kind="stable")
        hit = np.take_along_axis(gt, order, axis=0)
        rank[has] = np.argmax(hit, axis=0)[has]
    elif ties == "pessimistic":
        best = np.where(gt, d, np.inf).min(axis=0)
        better = (d < best[None, :]).sum(axis=0)
        tied_wrong = ((d == best[None, :]) & ~gt).sum(axis=0)
        rank[has] = (better + tied_wrong)[has]
    else:
        raise ValidationError(f"ties must be 'index' or 'pessimistic', got {ties!r}.")
    return rank


def correct_top1(distances: np.ndarray, ground_truth: GroundTruthLike = None, *, tolerance: int = 0) -> np.ndarray:
    """Boolean per query: its closest reference (lowest index on ties) is a match."""
    d = check_distances(distances)
    gt = ground_truth_matrix(ground_truth, d.shape, tolerance)
    idx = np.argmin(d, axis=0)
    return gt[idx, np.arange(d.shape[1])]


def recall_at_n(
    distances: np.ndarray,
    ground_truth: GroundTruthLike = None,
    n_values: Sequence[int] = DEFAULT_N_VALUES,
    *,
    tolerance: int = 0,
    ties: Literal["index", "pessimistic"] = "index",
) -> dict[int, float]:
    """Recall@N: fraction of queries (with a match) whose N closest references include a match (Eq. 14).

    ``tolerance`` counts a reference within that many indices of a true match as
    correct (0 = exact, the paper's setting). ``ties="index"`` ranks equal distances by
    reference index, as ``np.argsort`` does in the VPRSNN code; ``"pessimistic"`` ranks
    every wrong reference tied with the best match ahead of it.
    """
    d = check_distances(distances)
    gt = ground_truth_matrix(ground_truth, d.shape, tolerance)
    n_values = [int(n) for n in n_values]
    if not n_values or min(n_values) < 1:
        raise ValidationError(f"Recall@N needs N values >= 1, got {n_values}.")
    has = gt.any(axis=0)
    if not has.any():
        raise ValidationError("Recall@N needs at least one query with a matching reference; the ground truth has none.")
    rank = _first_correct_rank(d, gt, ties)[has]
    return {n: float(np.mean(rank < n)) for n in n_values}


@dataclass(frozen=True, slots=True, kw_only=True, eq=False)
class PRCurve:
    """A precision-recall curve, points in order of increasing acceptance threshold.

    ``precision[0] = 1, recall[0] = 0`` is the point where no query is accepted;
    ``thresholds[k]`` is the distance threshold of point ``k + 1``.
    """

    precision: np.ndarray
    recall: np.ndarray
    thresholds: np.ndarray

    @property
    def auc(self) -> float:
        """Area under the curve (trapezoid rule over recall, ``sklearn.metrics.auc``)."""
        from sklearn.metrics import auc

        if self.recall.size < 2:
            return 0.0
        return float(auc(self.recall, self.precision))

    @property
    def precision_at_100_recall(self) -> float:
        """Highest precision among the points with recall 1 (0 when recall 1 is never reached)."""
        full = self.recall >= 1.0
        return float(self.precision[full].max()) if full.any() else 0.0

    @property
    def recall_at_100_precision(self) -> float:
        """Highest recall among the points with precision 1 other than the no-acceptance point."""
        exact = self.precision[1:] >= 1.0
        return float(self.recall[1:][exact].max()) if exact.any() else 0.0


def precision_recall(distances: np.ndarray, ground_truth: GroundTruthLike = None, *, tolerance: int = 0) -> PRCurve:
    """Precision-recall curve of accepting each query's best match when its distance is at most a threshold.

    The definition of place recognition's papers, and of the Modular SNN authors'
    published evaluation (QVPR/VPRSNN, ``get_precision_recall_f1_score``): each query
    with a ground-truth match proposes its closest reference; at threshold ``t`` the
    queries whose best distance is at most ``t`` are accepted. An accepted query whose
    proposal matches is a true positive (TP), one whose proposal does not is a false
    positive (FP), and a rejected query is a false negative (FN), since every query has
    a place it should have been matched to. Precision = TP / (TP + FP), recall =
    TP / (TP + FN); the thresholds are the distinct best-match distances.

    Accepting every query gives recall 1 at precision = R@1, so precision at 100%
    recall equals R@1 (with the same tie rule). Queries without a ground-truth match
    are left out.
    """
    d = check_distances(distances)
    gt = ground_truth_matrix(ground_truth, d.shape, tolerance)
    has = gt.any(axis=0)
    if not has.any():
        raise ValidationError("a precision-recall curve needs at least one query with a matching reference.")
    idx, best = best_matches(d)
    correct = gt[idx, np.arange(d.shape[1])][has]
    dist = best[has]
    order = np.argsort(dist, kind="stable")
    dist, correct = dist[order], correct[order]
    last = np.r_[dist[1:] != dist[:-1], True]  # the last query of each run of equal distances
    tp = np.cumsum(correct)[last].astype(np.float64)
    accepted = (np.arange(dist.size) + 1)[last].astype(np.float64)
    fn = dist.size - accepted
    with np.errstate(divide="ignore", invalid="ignore"):
        precision = tp / accepted
        recall = np.where(tp > 0, tp / (tp + fn), 0.0)
    return PRCurve(precision=np.r_[1.0, precision], recall=np.r_[0.0, recall], thresholds=dist[last].astype(np.float64))


def roc(labels: np.ndarray, scores: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """ROC curve ``(false_positive_rate, true_positive_rate, thresholds)``; higher score = more likely positive.

    For familiarity (MBSNN), ``labels`` marks the frames inside the learned route
    segment and ``scores`` is the familiarity of each frame.
    """
    from sklearn.metrics import roc_curve

    y, s = _binary_scores(labels, scores)
    fpr, tpr, thr = roc_curve(y, s)
    return fpr, tpr, thr


def auc_roc(labels: np.ndarray, scores: np.ndarray) -> float:
    """Area under the ROC curve (``sklearn.metrics.roc_auc_score``)."""
    from sklearn.metrics import roc_auc_score

    y, s = _binary_scores(labels, scores)
    return float(roc_auc_score(y, s))


def _binary_scores(labels: np.ndarray, scores: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    y = np.asarray(labels)
    s = np.asarray(scores, dtype=np.float64)
    if y.ndim != 1 or s.shape != y.shape or y.size == 0:
        raise ValidationError(f"ROC needs equal-length 1-D labels and scores, got {y.shape} and {s.shape}.")
    if not np.isfinite(s).all():
        raise ValidationError("ROC scores must be finite, got NaN or infinity.")
    if not np.isin(y, (0, 1, True, False)).all():
        raise ValidationError("ROC labels must be 0/1 or boolean.")
    y = y.astype(bool)
    if y.all() or not y.any():
        raise ValidationError("ROC needs both positive and negative labels, got only one class.")
    return y.astype(int), s


def correct_match_sparsity(
    distances: np.ndarray, ground_truth: GroundTruthLike = None, *, tolerance: int = 0
) -> dict[str, float | np.ndarray]:
    """How concentrated each query's similarity is, split by whether its best match is correct.

    Definition used by neurovpr (the text of the paper's Eq. 15-17 could not be checked
    here, so this is stated in full rather than attributed to it):

    1. Similarity per query: ``s_q = max(D) - D[:, q]`` (the inverse of Eq. 12, so for a
       spiking model ``s_q`` is its per-place spike sum up to a constant).
    2. Sparsity of ``s_q`` by Hoyer's measure (Hoyer 2004, JMLR 5:1457),
       ``h_q = (sqrt(R) - |s_q|_1 / |s_q|_2) / (sqrt(R) - 1)``, in [0, 1]: 1 when a
       single reference holds all the similarity, 0 when all are equal (an all-zero
       column counts as 0). ``R`` is the number of references.
    3. Correct-match indicator ``c_q`` = 1 when the best match of ``q`` is correct; the
       summary is the mean ``h_q`` over correctly matched queries, over the others,
       and over all queries with a match.

    A spiking network's output is sparse (few places collect any spikes), so a high
    value among correct matches means the network answers confidently when right;
    summing sparse outputs of ensemble members then reinforces their agreements.

    Returns
    -------
    dict
        ``"per_query"`` (h_q, NaN for queries without a match), ``"correct"`` (c_q as
        0/1 floats), ``"sparsity_correct"``, ``"sparsity_incorrect"``, ``"sparsity_all"``
        (NaN where the group is empty).
    """
    d = check_distances(distances)
    gt = ground_truth_matrix(ground_truth, d.shape, tolerance)
    has = gt.any(axis=0)
    if not has.any():
        raise ValidationError("correct-match sparsity needs at least one query with a matching reference.")
    if not np.isfinite(d).all():
        raise ValidationError("correct-match sparsity needs a finite distance matrix.")
    s = d.max() - d
    n_ref = d.shape[0]
    l1 = np.abs(s).sum(axis=0)
    l2 = np.sqrt((s * s).sum(axis=0))
    if n_ref == 1:
        h = np.ones(d.shape[1])
    else:
        with np.errstate(divide="ignore", invalid="ignore"):
            h = (np.sqrt(n_ref) - l1 / l2) / (np.sqrt(n_ref) - 1.0)
        h[l2 == 0] = 0.0
    h = np.clip(h, 0.0, 1.0)
    correct = gt[np.argmin(d, axis=0), np.arange(d.shape[1])]
    per_query = np.where(has, h, np.nan)

    def mean(mask: np.ndarray) -> float:
        return float(h[mask].mean()) if mask.any() else float("nan")

    return {
        "per_query": per_query,
        "correct": np.where(has, correct.astype(float), np.nan),
        "sparsity_correct": mean(has & correct),
        "sparsity_incorrect": mean(has & ~correct),
        "sparsity_all": mean(has),
    }


def evaluate(
    distances: np.ndarray,
    ground_truth: GroundTruthLike = None,
    *,
    n_values: Sequence[int] = (1, 5, 10),
    tolerance: int = 0,
) -> dict[str, float]:
    """The standard summary: ``R@N`` for each N, ``P@100R``, ``R@100P`` and ``AUC_PR``."""
    out = {f"R@{n}": r for n, r in recall_at_n(distances, ground_truth, n_values, tolerance=tolerance).items()}
    curve = precision_recall(distances, ground_truth, tolerance=tolerance)
    out["P@100R"] = curve.precision_at_100_recall
    out["R@100P"] = curve.recall_at_100_precision
    out["AUC_PR"] = curve.auc
    return out
