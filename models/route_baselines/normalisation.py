"""Contrast enhancement and second-minimum normalisation shared by the route baselines.

* :func:`patch_normalise` - image contrast enhancement of SeqSLAM (Milford & Wyeth 2012):
  every ``patch x patch`` tile of a frame is shifted to zero mean and scaled to unit
  standard deviation, so overall brightness (or, for event frames, overall event rate,
  which follows the robot's speed) and slow gradients stop dominating the comparison.
  (SeqSLAM's tiles do not overlap; :func:`neurovpr.data.preprocess.patch_normalise` is
  the Modular SNN's variant, a window centred on every pixel, clipped to [-1, 1].)
* :func:`enhance_local_contrast` - SeqSLAM's local contrast enhancement of the
  difference matrix: each test frame's differences to the learned frames are z-scored
  within a sliding window of learned frames, then the whole matrix is shifted so its
  minimum is 0 (as OpenSeqSLAM does), keeping differences non-negative.
* :func:`second_min_familiarity` - second-minimum normalisation: a test frame's best
  (smallest) difference ``d1`` is compared with the best difference ``d2`` to learned
  frames outside a window around the best match; familiarity is ``1 - d1 / d2``. A frame
  from the learned stretch of route matches one place much better than every other
  (``d1 << d2``, familiarity near 1); a frame from elsewhere matches nothing distinctly
  (``d1 ~ d2``, familiarity near 0). The ratio removes the frame-to-frame scale of the
  differences (texture, event rate) that a raw threshold on ``d1`` would suffer from.
  This is SeqSLAM's uniqueness test (minimum over second minimum outside ``R_window``).
"""

from __future__ import annotations

import numpy as np

from neurovpr.errors import ValidationError

__all__ = ["patch_normalise", "enhance_local_contrast", "second_min_familiarity"]


def patch_normalise(frames: np.ndarray, patch: int) -> np.ndarray:
    """Normalise each ``patch x patch`` tile of each frame to zero mean and unit std.

    Parameters
    ----------
    frames
        ``(n, height, width)`` array. Tiles at the right and bottom edges may be smaller.
    patch
        Tile side in pixels; ``patch >= max(height, width)`` normalises whole frames.

    Returns
    -------
    numpy.ndarray
        Float array of the same shape; a flat tile (zero std) becomes 0.
    """
    frames = np.asarray(frames, dtype=np.float64)
    if frames.ndim != 3:
        raise ValidationError(f"patch_normalise: frames must be (n, height, width), got shape {frames.shape}.")
    if int(patch) != patch or patch < 1:
        raise ValidationError(f"patch_normalise: patch must be a positive integer, got {patch!r}.")
    patch = int(patch)
    out = np.empty_like(frames)
    _, height, width = frames.shape
    for r in range(0, height, patch):
        for c in range(0, width, patch):
            tile = frames[:, r : r + patch, c : c + patch]
            mean = tile.mean(axis=(1, 2), keepdims=True)
            std = tile.std(axis=(1, 2), keepdims=True)
            out[:, r : r + patch, c : c + patch] = np.where(std > 0, (tile - mean) / np.where(std > 0, std, 1.0), 0.0)
    return out


def enhance_local_contrast(differences: np.ndarray, window: int) -> np.ndarray:
    """SeqSLAM's local contrast enhancement of a ``(n_test, n_learned)`` difference matrix.

    Each entry becomes ``(D[i, j] - mean) / std`` over the learned frames
    ``j - window//2 .. j + window//2`` of the same test frame; the result is shifted so
    that its minimum is 0.
    """
    d = np.asarray(differences, dtype=np.float64)
    if d.ndim != 2 or d.size == 0:
        raise ValidationError(f"enhance_local_contrast: need a non-empty 2-D matrix, got shape {d.shape}.")
    if int(window) != window or window < 2:
        raise ValidationError(f"enhance_local_contrast: window must be an integer >= 2, got {window!r}.")
    n_learned = d.shape[1]
    half = int(window) // 2
    csum = np.concatenate([np.zeros((d.shape[0], 1)), np.cumsum(d, axis=1)], axis=1)
    csq = np.concatenate([np.zeros((d.shape[0], 1)), np.cumsum(d * d, axis=1)], axis=1)
    j = np.arange(n_learned)
    lo, hi = np.maximum(j - half, 0), np.minimum(j + half + 1, n_learned)
    count = (hi - lo).astype(np.float64)
    mean = (csum[:, hi] - csum[:, lo]) / count
    var = np.maximum((csq[:, hi] - csq[:, lo]) / count - mean * mean, 0.0)
    std = np.sqrt(var)
    scale = np.where(std > 1e-12 * (np.abs(mean) + 1.0), std, np.inf)
    enhanced = (d - mean) / scale
    return enhanced - enhanced.min()


def second_min_familiarity(differences: np.ndarray, exclusion: int) -> np.ndarray:
    """Familiarity ``1 - d1 / d2`` of each test frame (row) of a non-negative difference matrix.

    Parameters
    ----------
    differences
        ``(n_test, n_learned)``, non-negative; ``inf`` marks comparisons that could not
        be made (they are never the minimum).
    exclusion
        Half-width of the window of learned frames around the best match that the
        second minimum ignores (neighbouring learned frames look alike).

    Returns
    -------
    numpy.ndarray
        ``(n_test,)`` familiarity in ``[0, 1]``; higher means more familiar. A row with no
        finite difference scores 0.
    """
    d = np.asarray(differences, dtype=np.float64)
    if d.ndim != 2 or d.shape[1] == 0:
        raise ValidationError(f"second_min_familiarity: need a 2-D matrix with columns, got shape {d.shape}.")
    if np.any(d < 0):
        raise ValidationError("second_min_familiarity: differences must be >= 0.")
    n_learned = d.shape[1]
    if int(exclusion) != exclusion or exclusion < 0 or n_learned <= 2 * exclusion + 1:
        raise ValidationError(
            f"second_min_familiarity: {n_learned} learned frames leave none outside the exclusion window "
            f"of +-{exclusion} frames around the best match; learn more frames or lower the exclusion."
        )
    best = np.argmin(d, axis=1)
    d1 = d[np.arange(d.shape[0]), best]
    j = np.arange(n_learned)
    outside = np.abs(j[None, :] - best[:, None]) > int(exclusion)
    d2 = np.where(outside, d, np.inf).min(axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(d2 > 0, d1 / d2, 1.0)
    familiarity = 1.0 - ratio
    familiarity[~np.isfinite(d1) | ~np.isfinite(familiarity)] = 0.0
    return np.clip(familiarity, 0.0, 1.0)
