"""Sequence matching on any ``[reference, query]`` distance matrix (SNN or baseline).

Two methods:

- :func:`identity_kernel` -- the Modular SNN paper's Eq. 13: convolve the distance
  matrix with an ``L x L`` identity kernel, i.e. sum the distances along the diagonal
  of ``L`` consecutive reference/query pairs. VPRSNN (``ens_seq/process_seqmatch.py``)
  does this with ``torch.nn.functional.conv2d`` and no padding, so the result is
  ``(R - L + 1, Q - L + 1)`` and entry ``[i, j]`` scores the sequence that *starts* at
  reference ``i`` and query ``j``: ``sum_k D[i + k, j + k]``. That is ``mode="valid"``
  (the default). ``mode="same"`` keeps the input shape: near the last rows/columns the
  sequence is cut short and the sum of the available terms is scaled by
  ``L / n_terms``, so it is comparable with the full sums. Evaluate the ``"valid"``
  result against :func:`crop_ground_truth` (the sequence starting at query ``j`` is
  correct when its first pair matches, as in VPRSNN).
- :func:`seqslam` -- SeqSLAM's search (Milford & Wyeth, ICRA 2012): for each reference
  and query, the mean distance along straight trajectories through ``L`` consecutive
  queries at several velocities (references per query), keeping the best velocity;
  optionally after SeqSLAM's local contrast enhancement (:func:`local_contrast`).

Both return a matrix in the same convention (lower = better), so every metric in
:mod:`neurovpr.evaluation.metrics` applies to the result.
"""

from __future__ import annotations

from typing import Literal

import numpy as np

from neurovpr.data.ground_truth import GroundTruth
from neurovpr.errors import ValidationError
from neurovpr.evaluation.metrics import check_distances, ground_truth_matrix

__all__ = ["identity_kernel", "crop_ground_truth", "local_contrast", "seqslam"]


def _check_len(seq_len: int, shape: tuple[int, int]) -> int:
    n_seq = int(seq_len)
    if n_seq < 1:
        raise ValidationError(f"sequence length must be >= 1, got {seq_len}.")
    if n_seq > min(shape):
        raise ValidationError(
            f"sequence length {n_seq} is longer than the {shape[0]} x {shape[1]} distance matrix allows (at most {min(shape)})."
        )
    return n_seq


def identity_kernel(distances: np.ndarray, seq_len: int, *, mode: Literal["valid", "same"] = "valid") -> np.ndarray:
    """Sum of distances along diagonals of length ``seq_len`` (Eq. 13); see the module docstring."""
    d = check_distances(distances)
    n_seq = _check_len(seq_len, d.shape)
    n_r, n_q = d.shape
    if mode == "valid":
        out = np.zeros((n_r - n_seq + 1, n_q - n_seq + 1))
        for k in range(n_seq):
            out += d[k : k + n_r - n_seq + 1, k : k + n_q - n_seq + 1]
        return out
    if mode == "same":
        total = np.zeros((n_r, n_q))
        count = np.zeros((n_r, n_q))
        for k in range(n_seq):
            total[: n_r - k, : n_q - k] += d[k:, k:]
            count[: n_r - k, : n_q - k] += 1.0
        return total * (n_seq / count)
    raise ValidationError(f"identity_kernel mode must be 'valid' or 'same', got {mode!r}.")


def crop_ground_truth(ground_truth: GroundTruth | np.ndarray | None, shape: tuple[int, int], seq_len: int) -> np.ndarray:
    """Ground truth of the ``"valid"`` identity-kernel result: first ``R - L + 1`` references, ``Q - L + 1`` queries."""
    gt = ground_truth_matrix(ground_truth, shape)
    n_seq = _check_len(seq_len, shape)
    return gt[: shape[0] - n_seq + 1, : shape[1] - n_seq + 1]


def local_contrast(distances: np.ndarray, window: int = 10) -> np.ndarray:
    """SeqSLAM's local contrast enhancement along the reference axis.

    Each entry becomes ``(D[r, q] - mean) / std`` over references
    ``max(0, r - window//2) .. min(R - 1, r + window//2)`` of the same query (sample
    std, ``ddof=1``, as MATLAB's ``std`` in OpenSeqSLAM; a zero std gives 0), and the
    whole matrix is then shifted so its minimum is 0.
    """
    d = check_distances(distances)
    if not np.isfinite(d).all():
        raise ValidationError("local contrast enhancement needs a finite distance matrix.")
    w = int(window)
    if w < 2:
        raise ValidationError(f"contrast window must be >= 2 references, got {window}.")
    n_r = d.shape[0]
    half = w // 2
    c1 = np.vstack([np.zeros((1, d.shape[1])), np.cumsum(d, axis=0)])
    c2 = np.vstack([np.zeros((1, d.shape[1])), np.cumsum(d * d, axis=0)])
    r = np.arange(n_r)
    lo = np.maximum(0, r - half)
    hi = np.minimum(n_r - 1, r + half) + 1
    n = (hi - lo).astype(np.float64)[:, None]
    s1 = c1[hi] - c1[lo]
    s2 = c2[hi] - c2[lo]
    mean = s1 / n
    with np.errstate(invalid="ignore", divide="ignore"):
        var = np.maximum(s2 - n * mean * mean, 0.0) / (n - 1.0)
        out = (d - mean) / np.sqrt(var)
    out[~np.isfinite(out)] = 0.0
    return out - out.min()


def seqslam(
    distances: np.ndarray,
    seq_len: int,
    *,
    v_min: float = 0.8,
    v_max: float = 1.2,
    n_velocities: int = 5,
    contrast_window: int | None = None,
    anchor: Literal["start", "centre", "end"] = "start",
) -> np.ndarray:
    """SeqSLAM trajectory search; returns a ``[reference, query]`` score matrix of the input's shape.

    Parameters
    ----------
    distances
        ``[reference, query]`` distance matrix.
    seq_len
        Number of consecutive queries ``L`` in a trajectory.
    v_min, v_max, n_velocities
        Velocities (reference steps per query step) tried, ``linspace(v_min, v_max,
        n_velocities)``; OpenSeqSLAM's defaults are 0.8..1.2 in steps of 0.1.
    contrast_window
        Apply :func:`local_contrast` with this window first (``None``: no enhancement).
    anchor
        Where query ``q`` sits in its trajectory: ``"start"`` (queries ``q .. q+L-1``,
        like :func:`identity_kernel`), ``"centre"`` (SeqSLAM's original) or ``"end"``
        (queries ``q-L+1 .. q``, usable online).

    Notes
    -----
    Along a trajectory at velocity ``v`` the query offset ``t`` pairs with reference
    offset ``round(v * t)`` from ``(r, q)``. Reference indices past either end are
    clamped to the first/last reference, as OpenSeqSLAM does; query offsets past the
    ends of the query traverse are left out. The score is the mean distance over the
    pairs used (the pair ``(r, q)`` always is), minimised over velocities. Away from
    the borders, ``v_min = v_max = 1`` with ``anchor="start"`` gives
    ``identity_kernel(D, L) / L``.
    """
    d = check_distances(distances)
    if not np.isfinite(d).all():
        raise ValidationError("seqslam needs a finite distance matrix.")
    n_seq = _check_len(seq_len, d.shape)
    if not (0 < v_min <= v_max and np.isfinite(v_max)):
        raise ValidationError(f"seqslam needs 0 < v_min <= v_max, got v_min={v_min}, v_max={v_max}.")
    if int(n_velocities) < 1:
        raise ValidationError(f"seqslam needs n_velocities >= 1, got {n_velocities}.")
    if contrast_window is not None:
        d = local_contrast(d, contrast_window)
    if anchor == "start":
        offsets = np.arange(n_seq)
    elif anchor == "centre":
        offsets = np.arange(n_seq) - (n_seq - 1) // 2
    elif anchor == "end":
        offsets = np.arange(n_seq) - (n_seq - 1)
    else:
        raise ValidationError(f"seqslam anchor must be 'start', 'centre' or 'end', got {anchor!r}.")
    n_r, n_q = d.shape
    velocities = np.linspace(v_min, v_max, int(n_velocities)) if v_max > v_min else np.array([v_min])
    best = np.full((n_r, n_q), np.inf)
    for v in velocities:
        total = np.zeros((n_r, n_q))
        count = np.zeros((n_r, n_q))
        for t in offsets:
            dr = int(np.floor(v * t + 0.5))
            dq = int(t)
            # out[r, q] += d[clip(r + dr), q + dq] for the queries inside the matrix
            q0, q1 = max(0, -dq), min(n_q, n_q - dq)
            if q0 >= q1:
                continue
            rows = np.clip(np.arange(n_r) + dr, 0, n_r - 1)
            total[:, q0:q1] += d[rows, q0 + dq : q1 + dq]
            count[:, q0:q1] += 1.0
        np.minimum(best, total / count, out=best)
    return best
