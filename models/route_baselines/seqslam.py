"""SeqSLAM (Milford & Wyeth 2012) adapted to output a familiarity score per test frame.

SeqSLAM compares short sequences instead of single frames:

1. contrast enhancement of the frames by patch normalisation;
2. a difference matrix of sums of absolute differences, test frames x learned frames;
3. local contrast enhancement of that matrix (z-scores within a window of learned frames);
4. for each test frame ``i`` (the end of the sequence of the last ``seq_len`` test
   frames) and learned frame ``j``, the mean enhanced difference along straight lines
   ``(i - k, j - v k)``, ``k = 0 .. seq_len - 1``, minimised over velocities ``v`` in
   ``[v_min, v_max]`` (learned frames per test frame);
5. in place of SeqSLAM's match decision, a familiarity per test frame by second-minimum
   normalisation of the best sequence score over learned frames
   (:func:`~neurovpr.models.route_baselines.normalisation.second_min_familiarity`):
   ``1 - best / second best outside a window around the best match``.

Sequences only look back in time, so the score of frame ``i`` uses frames up to ``i``,
as a robot driving the route would. The first test frames use the shorter sequences
available; a line whose learned frames fall off the start of the learned segment is
kept when at least half of its points lie inside it.
"""

from __future__ import annotations

from typing import Literal

import numpy as np

from neurovpr.errors import ValidationError

from .normalisation import (
    enhance_local_contrast,
    patch_normalise,
    second_min_familiarity,
)
from .perfect_memory import check_frames

__all__ = ["sum_absolute_differences", "sequence_scores", "seqslam_familiarity"]


def sum_absolute_differences(reference: np.ndarray, test: np.ndarray, *, chunk: int = 64) -> np.ndarray:
    """``(n_test, n_reference)`` sums of absolute pixel differences, computed in chunks of test frames."""
    ref = reference.reshape(reference.shape[0], -1)
    tst = test.reshape(test.shape[0], -1)
    out = np.empty((tst.shape[0], ref.shape[0]))
    for start in range(0, tst.shape[0], chunk):
        block = tst[start : start + chunk]
        out[start : start + chunk] = np.abs(block[:, None, :] - ref[None, :, :]).sum(axis=2)
    return out


def sequence_scores(differences: np.ndarray, seq_len: int, velocities: np.ndarray) -> np.ndarray:
    """Best mean difference along a straight line ending at each (test ``i``, learned ``j``).

    Parameters
    ----------
    differences
        ``(n_test, n_learned)`` non-negative (enhanced) differences.
    seq_len
        Number of test frames in a sequence.
    velocities
        Learned frames advanced per test frame, one line per value.

    Returns
    -------
    numpy.ndarray
        ``(n_test, n_learned)``; ``inf`` where no line has enough points inside the matrix.
    """
    d = np.asarray(differences, dtype=np.float64)
    n_test, n_learned = d.shape
    j = np.arange(n_learned)
    available = np.minimum(np.arange(n_test) + 1, seq_len)[:, None]
    needed = (available + 1) // 2
    best = np.full(d.shape, np.inf)
    for v in np.asarray(velocities, dtype=np.float64).tolist():
        total = np.zeros(d.shape)
        count = np.zeros(d.shape, dtype=np.int64)
        for k in range(min(seq_len, n_test)):
            jj = j - round(v * k)
            inside = jj >= 0
            total[k:, inside] += d[: n_test - k, jj[inside]]
            count[k:, inside] += 1
        with np.errstate(invalid="ignore", divide="ignore"):
            mean = np.where(count >= needed, total / np.maximum(count, 1), np.inf)
        best = np.minimum(best, mean)
    return best


def seqslam_familiarity(
    reference: np.ndarray,
    test: np.ndarray,
    *,
    patch: int | None = 8,
    enhance_window: int | None = 10,
    seq_len: int = 10,
    v_min: float = 0.8,
    v_max: float = 1.25,
    n_velocities: int = 5,
    normalisation: Literal["second_min", "none"] = "second_min",
    exclusion: int = 5,
) -> np.ndarray:
    """Familiarity of each test frame with the learned (reference) frames, by SeqSLAM.

    Parameters
    ----------
    reference, test
        ``(n, height, width)`` frames of the learned segment and of the recording to score.
    patch
        Tile side of the patch normalisation; ``None`` skips it.
    enhance_window
        Window (learned frames) of the local contrast enhancement; ``None`` skips it.
    seq_len
        Test frames per sequence.
    v_min, v_max, n_velocities
        Range and number of line slopes (learned frames per test frame).
    normalisation
        ``"second_min"`` (``1 - best / second best``) or ``"none"`` (negated best score).
    exclusion
        Half-width of the window around the best learned frame ignored by the second minimum.

    Returns
    -------
    numpy.ndarray
        ``(n_test,)`` scores, higher = more familiar.
    """
    ref, tst = check_frames(reference, test, "seqslam_familiarity")
    if int(seq_len) != seq_len or seq_len < 1:
        raise ValidationError(f"seqslam_familiarity: seq_len must be a positive integer, got {seq_len!r}.")
    if not (0 < v_min <= v_max) or int(n_velocities) != n_velocities or n_velocities < 1:
        raise ValidationError(
            f"seqslam_familiarity: need 0 < v_min <= v_max and n_velocities >= 1, got v_min={v_min}, "
            f"v_max={v_max}, n_velocities={n_velocities}."
        )
    if normalisation not in ("second_min", "none"):
        raise ValidationError(f"seqslam_familiarity: normalisation {normalisation!r} is not 'second_min' or 'none'.")
    if patch is not None:
        ref, tst = patch_normalise(ref, patch), patch_normalise(tst, patch)
    diff = sum_absolute_differences(ref, tst)
    if enhance_window is not None:
        diff = enhance_local_contrast(diff, enhance_window)
    scores = sequence_scores(diff, int(seq_len), np.linspace(v_min, v_max, int(n_velocities)))
    if normalisation == "second_min":
        return second_min_familiarity(scores, exclusion)
    best = scores.min(axis=1)
    return np.where(np.isfinite(best), -best, -np.finfo(np.float64).max)
