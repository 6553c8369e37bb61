"""From spike counts to place similarities: assignment, hyperactive neurons, fusion, ensembles.

Notation: ``R`` reference places, ``Q`` query images, ``n`` excitatory neurons of one
module. Every function is a pure function of arrays. Defaults follow the authors' code
(QVPR/VPRSNN ``non_modular_snn/snn_model_evaluation.py`` and
``modular_snn/modular_snn_config_evaluation.py``).

- Assignment (Eq. 4): neuron ``i`` of a module is assigned to the place ``p`` of that
  module for which its response ``r_i(p)`` is largest (the code: its mean spike count
  over the last training presentations of ``p``, see :mod:`.training`); ties go to the
  first such place, and a neuron that fired for none of its module's places is left
  unassigned (-1), as VPRSNN's ``get_new_assignments`` does.
- Hyperactive neurons: a neuron that fired for at least ``theta`` reference images
  (``measure="images"``, VPRSNN's ``np.count_nonzero`` over its responses to every
  reference image) is hyperactive; ``theta = 0`` marks none, as in the code. ``theta`` is
  chosen per modular SNN (ensemble member) on calibration places, as the code does: the
  value of :data:`THRESHOLDS` with the best Recall@1 of the calibration modules on the
  calibration queries (:func:`calibrate_threshold`; ties go to the stricter threshold,
  :func:`best_threshold`: the smaller positive value, and 0, which marks none, last).
  ``measure="spikes"`` counts total spikes instead (the paper's text).
- Epochs: the authors' README names the epoch count a hyperparameter chosen on the
  calibration data like the threshold (their released Nordland members: 60 and 70);
  their code trains one count per run (``modular_snn/one_snn_module_processing.py``),
  so a member trained with several counts takes the count and threshold with the best
  calibration Recall@1 (:func:`calibrate_epochs`; ties go to fewer epochs).
- Module output (Eq. 7) and fusion (Eq. 9): the similarity of query ``q`` to place ``p``
  is the sum of the query spikes of the neurons assigned to ``p`` with the hyperactive
  ones' spikes set to 0, divided by the number of neurons assigned to ``p``, hyperactive
  ones included (``score="standard"``, VPRSNN's "standard" assignment); a place with no
  neuron scores 0. ``score="sum"`` is the paper's plain sum. Modules hold disjoint
  places, so fusing them is summing every module's contribution into one ``R x Q``
  matrix.
- Ensemble (Eq. 10): the members' similarity matrices are summed.
- Distance (Eq. 11-12): ``D = max(S) - S`` over the whole matrix
  (:func:`neurovpr.evaluation.metrics.distance_from_similarity`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import numpy as np

import neurovpr as nv
from neurovpr.data.ground_truth import GroundTruth
from neurovpr.evaluation.metrics import distance_from_similarity, recall_at_n

__all__ = [
    "THRESHOLDS",
    "SCORES",
    "assign_neurons",
    "reference_activity",
    "hyperactive_neurons",
    "module_similarity",
    "fuse_modules",
    "calibrate_threshold",
    "calibrate_epochs",
    "best_threshold",
    "ensemble_similarity",
    "distance_from_similarity",
]

#: The hyperactive thresholds (reference images fired for) VPRSNN's calibration tries
#: (``modular_snn/modular_snn_evaluation.py``).
THRESHOLDS = (0, 5, 10, 20, 40, 60, 80, 100, 120, 140, 160, 180, 200)
#: Place scores (see the module docstring).
SCORES = ("standard", "sum")


def assign_neurons(responses: np.ndarray, places: np.ndarray, order: np.ndarray | None = None) -> np.ndarray:
    """Place of each neuron (Eq. 4): ``places[argmax_p responses[p, i]]``, or -1 if it never fired.

    Parameters
    ----------
    responses
        ``(n_module_places, n)`` spike counts, one row per place of the module (in the
        order of ``places``).
    places
        Global indices of the module's places.
    order
        The order the places were shown in training (indices into ``places``, as
        :func:`.training.presentation_order` gives them); a neuron that fired equally for
        several places goes to the one shown first, as VPRSNN's ``get_new_assignments``
        (labels in presentation order, replaced only by a strictly higher rate). Default:
        row order. Spike counts tie often when the assignment window holds few
        presentations per place; breaking ties by place index instead favours the same places
        in every member, since the places' indices do not change between members.
    """
    r = np.asarray(responses)
    places = np.asarray(places, dtype=np.int64)
    if r.ndim != 2 or r.shape[0] != places.size or r.shape[0] == 0:
        raise nv.ValidationError(
            f"assignment needs one response row per module place: got shape {r.shape} for {places.size} places."
        )
    rank = np.arange(places.size) if order is None else np.asarray(order, dtype=np.int64)
    if rank.shape != (places.size,) or not np.array_equal(np.sort(rank), np.arange(places.size)):
        raise nv.ValidationError(
            f"the presentation order of a module of {places.size} places must be a permutation of 0..{places.size - 1}."
        )
    best = rank[np.argmax(r[rank], axis=0)]
    out = places[best]
    out[r.max(axis=0) <= 0] = -1
    return out


def reference_activity(reference_responses: np.ndarray, *, measure: str = "images") -> np.ndarray:
    """Activity of each neuron over the whole reference set, compared with theta.

    Parameters
    ----------
    reference_responses
        ``(R, n)`` spike counts of a module's neurons for every reference image.
    measure
        ``"images"`` (number of reference images with at least one spike, VPRSNN's
        code) or ``"spikes"`` (total spikes, the paper's text).
    """
    r = np.asarray(reference_responses)
    if r.ndim != 2:
        raise nv.ValidationError(f"reference responses must be a 2-D (places, neurons) array, got shape {r.shape}.")
    if measure == "spikes":
        return r.sum(axis=0, dtype=np.int64)
    if measure == "images":
        return np.count_nonzero(r, axis=0).astype(np.int64)
    raise nv.ValidationError(f"hyperactive measure must be 'spikes' or 'images', got {measure!r}.")


def hyperactive_neurons(activity: np.ndarray, theta: float) -> np.ndarray:
    """Boolean mask of the neurons to ignore: ``activity >= theta``, none for ``theta = 0`` (see :func:`reference_activity`)."""
    if not np.isfinite(theta) or theta < 0:
        raise nv.ValidationError(f"hyperactive threshold theta must be a finite number >= 0, got {theta!r}.")
    a = np.asarray(activity)
    if a.ndim != 1:
        raise nv.ValidationError(f"neuron activity must be 1-D (one value per neuron), got shape {a.shape}.")
    return a >= theta if theta > 0 else np.zeros(a.shape, dtype=bool)


def module_similarity(
    query_counts: np.ndarray,
    assignments: np.ndarray,
    n_reference: int,
    *,
    ignore: np.ndarray | None = None,
    score: str = "standard",
) -> np.ndarray:
    """One module's contribution to the ``(R, Q)`` similarity matrix (Eq. 7).

    Parameters
    ----------
    query_counts
        ``(Q, n)`` spike counts of the module's neurons for every query image.
    assignments
        ``(n,)`` global place of each neuron, -1 for unassigned.
    n_reference
        ``R``, the number of reference places.
    ignore
        ``(n,)`` mask of hyperactive neurons: their spikes count 0.
    score
        ``"standard"`` (sum divided by the number of neurons assigned to the place,
        hyperactive ones included, VPRSNN's standard assignment) or ``"sum"`` (the paper).
    """
    counts = np.asarray(query_counts, dtype=np.float64)
    a = np.asarray(assignments, dtype=np.int64)
    if counts.ndim != 2 or counts.shape[1] != a.size:
        raise nv.ValidationError(
            f"query counts of shape {counts.shape} do not match {a.size} neuron assignments (expected (Q, {a.size}))."
        )
    if a.size and a.max() >= n_reference:
        raise nv.ValidationError(f"a neuron is assigned to place {int(a.max())}, beyond the {n_reference} reference places.")
    if score not in SCORES:
        raise nv.ValidationError(f"place score must be one of {', '.join(SCORES)}, got {score!r}.")
    assigned = a >= 0
    keep = assigned.copy()
    if ignore is not None:
        ignore = np.asarray(ignore, dtype=bool)
        if ignore.shape != a.shape:
            raise nv.ValidationError(f"ignore mask has shape {ignore.shape}, expected ({a.size},).")
        keep &= ~ignore
    sim = np.zeros((int(n_reference), counts.shape[0]))
    np.add.at(sim, a[keep], counts[:, keep].T)
    if score == "standard":
        n_per_place = np.bincount(a[assigned], minlength=int(n_reference))
        sim /= np.maximum(n_per_place, 1)[:, None]
    return sim


def fuse_modules(contributions: Sequence[np.ndarray]) -> np.ndarray:
    """Modular fusion (Eq. 9): sum of the modules' ``(R, Q)`` contributions."""
    return _sum_same_shape(contributions, "module")


def calibrate_threshold(
    modules: Sequence[tuple[np.ndarray, np.ndarray, np.ndarray]],
    n_reference: int,
    places: np.ndarray,
    ground_truth: GroundTruth,
    *,
    score: str = "standard",
    thresholds: Sequence[float] = THRESHOLDS,
) -> tuple[float, dict[float, float]]:
    """The hyperactive threshold with the best calibration Recall@1, and the Recall@1 of each.

    Parameters
    ----------
    modules
        ``(query_counts, assignments, activity)`` of each calibration module: its spike
        counts for the calibration queries ``(Q_cal, n)``, its neurons' places and their
        reference activity (:func:`reference_activity`).
    n_reference
        ``R``, the number of reference places (assignments are global place indices).
    places
        The calibration places (rows of the calibration similarity), sorted.
    ground_truth
        ``[places, calibration queries]`` ground truth.
    score, thresholds
        The place score and the candidates; ties go to the stricter threshold
        (:func:`best_threshold`). A
        threshold that zeroes every calibration response is skipped, as the code's
        evaluation stops there ("All neurons are categorised as hyperactive").
    """
    places = np.asarray(places, dtype=np.int64)
    recall: dict[float, float] = {}
    for theta in sorted(thresholds):
        parts = [
            module_similarity(counts, assigned, n_reference, ignore=hyperactive_neurons(activity, theta), score=score)
            for counts, assigned, activity in modules
        ]
        fused = fuse_modules(parts)[places]
        if theta > 0 and not fused.any():
            continue  # every response zeroed: the code's evaluation gives no result at this threshold
        recall[theta] = recall_at_n(distance_from_similarity(fused), ground_truth, [1])[1]
    return best_threshold(recall), recall


def best_threshold(recall: Mapping[float, float]) -> float:
    """The hyperactive threshold with the best calibration Recall@1; 0 when none was evaluated.

    Ties go to the stricter threshold, the one that marks more neurons hyperactive: the
    smaller positive value, and 0 (which marks none, as in the code) only when no positive
    threshold does as well. The calibration modules hold few places; when none of their
    neurons fires for as many reference images as the candidates, 0 ties with them there
    while the reported modules hold neurons that would have been marked: counting 0 as the
    smallest threshold let a member on the 150 places of the comparison with the authors'
    code (``benchmarks/modular_snn_vs_authors.py --places 125``) keep every neuron and send
    nearly all its queries to a few places.

    Parameters
    ----------
    recall
        Calibration Recall@1 per threshold (reference images fired for; 0: none hyperactive).
    """
    return max(recall, key=lambda t: (recall[t], -t if t > 0 else -math.inf)) if recall else 0.0


def calibrate_epochs(calibration: Mapping[int, Mapping[float, float]]) -> tuple[int, float]:
    """The epoch count and hyperactive threshold with the best calibration Recall@1.

    ``calibration`` maps each epoch count a member was trained with to the calibration
    Recall@1 of each threshold (what :func:`calibrate_threshold` returns for that count).
    Ties go to fewer epochs; each count takes its threshold by :func:`best_threshold`. An
    epoch count with no threshold evaluated counts as Recall@1 0 at threshold 0, as
    :func:`calibrate_threshold` then uses 0.
    """
    if not calibration:
        raise nv.ValidationError("calibrate_epochs needs the calibration Recall@1 of at least one epoch count, got none.")
    candidates: list[tuple[float, int, float]] = []
    for epochs, recall in calibration.items():
        if int(epochs) != epochs or epochs < 1:
            raise nv.ValidationError(f"epoch count {epochs!r} in the calibration is not a whole number >= 1.")
        bad = [theta for theta, r in recall.items() if not (np.isfinite(r) and 0.0 <= r <= 1.0)]
        if bad:
            value = recall[bad[0]]
            raise nv.ValidationError(
                f"calibration Recall@1 of {epochs} epochs at threshold {bad[0]} is {value!r}, expected 0..1."
            )
        theta = best_threshold(recall)
        candidates.append((float(recall.get(theta, 0.0)), int(epochs), float(theta)))
    best = max(candidates, key=lambda c: (c[0], -c[1], -c[2]))
    return best[1], best[2]


def ensemble_similarity(members: Sequence[np.ndarray]) -> np.ndarray:
    """Ensemble (Eq. 10): sum of the members' ``(R, Q)`` similarity matrices."""
    return _sum_same_shape(members, "ensemble member")


def _sum_same_shape(arrays: Sequence[np.ndarray], what: str) -> np.ndarray:
    if len(arrays) == 0:
        raise nv.ValidationError(f"need at least one {what} similarity matrix to sum, got none.")
    first = np.asarray(arrays[0], dtype=np.float64)
    total = first.copy()
    for k, arr in enumerate(arrays[1:], start=1):
        arr = np.asarray(arr, dtype=np.float64)
        if arr.shape != first.shape:
            raise nv.ValidationError(f"{what} {k} similarity has shape {arr.shape}, expected {first.shape}.")
        total += arr
    return total
