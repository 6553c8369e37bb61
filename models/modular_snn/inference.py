"""From spike counts to place similarities: assignment, hyperactive neurons, fusion, ensembles.

Notation: ``R`` reference places, ``Q`` query images, ``n`` excitatory neurons of one
module. Every function is a pure function of arrays.

- Assignment (Eq. 4): neuron ``i`` of a module is assigned to the place ``p`` of that
  module for which its (learning-off) response ``r_i(p)`` is largest; ties go to the
  first such place, and a neuron that fired for none of its module's places is left
  unassigned (-1), as VPRSNN's ``get_new_assignments`` does.
- Hyperactive neurons: a neuron whose total spike count over the whole reference set
  is at least ``theta`` is ignored (its query spikes are dropped). ``theta`` is drawn
  once per modular SNN (ensemble member) from U(40, 100) for reference sets below 1000
  places and from U(600, 800) from 1000 places on (:func:`draw_hyperactive_threshold`).
  ``measure="images"`` counts the reference images a neuron fired for instead of its
  spikes (VPRSNN's ``np.count_nonzero`` over the reference responses). With several
  training traverses the responses and activity are taken over all of them
  (:mod:`.runs` says how).
- Module output (Eq. 7) and fusion (Eq. 9): the similarity of query ``q`` to place ``p``
  is the sum of the query spikes of the neurons assigned to ``p``; modules hold disjoint
  places, so fusing them is summing every module's contribution into one ``R x Q``
  matrix. ``score="mean"`` divides each place's sum by its number of assigned neurons
  (VPRSNN's "standard" assignment).
- Ensemble (Eq. 10): the members' similarity matrices are summed.
- Distance (Eq. 11-12): ``D = max(S) - S`` over the whole matrix
  (:func:`neurovpr.evaluation.metrics.distance_from_similarity`).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

import neurovpr as nv
from neurovpr.evaluation.metrics import distance_from_similarity

__all__ = [
    "assign_neurons",
    "draw_hyperactive_threshold",
    "reference_activity",
    "hyperactive_neurons",
    "module_similarity",
    "fuse_modules",
    "ensemble_similarity",
    "distance_from_similarity",
    "LARGE_REFERENCE_SET",
]

#: From this many reference places on, theta is drawn from U(600, 800) instead of U(40, 100).
LARGE_REFERENCE_SET = 1000


def assign_neurons(responses: np.ndarray, places: np.ndarray) -> np.ndarray:
    """Place of each neuron (Eq. 4): ``places[argmax_p responses[p, i]]``, or -1 if it never fired.

    Parameters
    ----------
    responses
        ``(n_module_places, n)`` spike counts, one row per place of the module (in the
        order of ``places``).
    places
        Global indices of the module's places.
    """
    r = np.asarray(responses)
    places = np.asarray(places, dtype=np.int64)
    if r.ndim != 2 or r.shape[0] != places.size or r.shape[0] == 0:
        raise nv.ValidationError(
            f"assignment needs one response row per module place: got shape {r.shape} for {places.size} places."
        )
    best = np.argmax(r, axis=0)
    out = places[best]
    out[r.max(axis=0) <= 0] = -1
    return out


def draw_hyperactive_threshold(n_reference: int, rng: np.random.Generator) -> float:
    """Draw theta: U(40, 100) below :data:`LARGE_REFERENCE_SET` reference places, else U(600, 800)."""
    if int(n_reference) < 1:
        raise nv.ValidationError(f"hyperactive threshold needs at least one reference place, got {n_reference}.")
    low, high = (40.0, 100.0) if n_reference < LARGE_REFERENCE_SET else (600.0, 800.0)
    return float(rng.uniform(low, high))


def reference_activity(reference_responses: np.ndarray, *, measure: str = "spikes") -> np.ndarray:
    """Activity of each neuron over the whole reference set, compared with theta.

    Parameters
    ----------
    reference_responses
        ``(R, n)`` spike counts of a module's neurons for every reference image.
    measure
        ``"spikes"`` (total spikes, the paper) or ``"images"`` (number of reference
        images with at least one spike, VPRSNN's code).
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
    """Boolean mask of the neurons to ignore: ``activity >= theta`` (see :func:`reference_activity`)."""
    if not np.isfinite(theta) or theta < 0:
        raise nv.ValidationError(f"hyperactive threshold theta must be a finite number >= 0, got {theta!r}.")
    a = np.asarray(activity)
    if a.ndim != 1:
        raise nv.ValidationError(f"neuron activity must be 1-D (one value per neuron), got shape {a.shape}.")
    return a >= theta


def module_similarity(
    query_counts: np.ndarray,
    assignments: np.ndarray,
    n_reference: int,
    *,
    ignore: np.ndarray | None = None,
    score: str = "sum",
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
        ``(n,)`` mask of neurons to drop (hyperactive neurons).
    score
        ``"sum"`` (the paper) or ``"mean"`` (sum divided by the place's number of
        counted neurons, VPRSNN's standard assignment).
    """
    counts = np.asarray(query_counts, dtype=np.float64)
    a = np.asarray(assignments, dtype=np.int64)
    if counts.ndim != 2 or counts.shape[1] != a.size:
        raise nv.ValidationError(
            f"query counts of shape {counts.shape} do not match {a.size} neuron assignments (expected (Q, {a.size}))."
        )
    if a.size and a.max() >= n_reference:
        raise nv.ValidationError(f"a neuron is assigned to place {int(a.max())}, beyond the {n_reference} reference places.")
    keep = a >= 0
    if ignore is not None:
        ignore = np.asarray(ignore, dtype=bool)
        if ignore.shape != a.shape:
            raise nv.ValidationError(f"ignore mask has shape {ignore.shape}, expected ({a.size},).")
        keep &= ~ignore
    sim = np.zeros((int(n_reference), counts.shape[0]))
    np.add.at(sim, a[keep], counts[:, keep].T)
    if score == "mean":
        n_per_place = np.bincount(a[keep], minlength=int(n_reference))
        sim /= np.maximum(n_per_place, 1)[:, None]
    elif score != "sum":
        raise nv.ValidationError(f"place score must be 'sum' or 'mean', got {score!r}.")
    return sim


def fuse_modules(contributions: Sequence[np.ndarray]) -> np.ndarray:
    """Modular fusion (Eq. 9): sum of the modules' ``(R, Q)`` contributions."""
    return _sum_same_shape(contributions, "module")


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
