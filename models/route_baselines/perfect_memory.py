"""Perfect Memory: store every learned frame, score a test frame by its closest stored frame.

The familiarity baseline of the mushroom-body papers (Ardin et al. 2016; Zhu et al. 2023):
the learned segment's frames are all kept; a test frame's difference to each is the sum
of squared differences (SSD) of the contrast-enhanced frames, and its familiarity comes
from the minimum SSD with second-minimum normalisation
(:func:`~neurovpr.models.route_baselines.normalisation.second_min_familiarity`).
"""

from __future__ import annotations

from typing import Literal

import numpy as np

from neurovpr.errors import ValidationError

from .normalisation import patch_normalise, second_min_familiarity

__all__ = ["sum_squared_differences", "perfect_memory_familiarity", "check_frames"]


def check_frames(reference: np.ndarray, test: np.ndarray, caller: str) -> tuple[np.ndarray, np.ndarray]:
    """Validate two ``(n, height, width)`` frame stacks of the same frame size; return them as float."""
    ref = np.asarray(reference, dtype=np.float64)
    tst = np.asarray(test, dtype=np.float64)
    for name, arr in (("reference", ref), ("test", tst)):
        if arr.ndim != 3 or arr.shape[0] == 0:
            raise ValidationError(f"{caller}: {name} frames must be a non-empty (n, height, width) array, "
                                  f"got shape {arr.shape}.")
        if not np.all(np.isfinite(arr)):
            raise ValidationError(f"{caller}: {name} frames contain NaN or infinite values.")
    if ref.shape[1:] != tst.shape[1:]:
        raise ValidationError(
            f"{caller}: reference frames are {ref.shape[1]}x{ref.shape[2]} but test frames are "
            f"{tst.shape[1]}x{tst.shape[2]}."
        )
    return ref, tst


def sum_squared_differences(reference: np.ndarray, test: np.ndarray) -> np.ndarray:
    """``(n_test, n_reference)`` sums of squared pixel differences between two frame stacks."""
    ref = reference.reshape(reference.shape[0], -1)
    tst = test.reshape(test.shape[0], -1)
    ssd = (tst * tst).sum(axis=1)[:, None] + (ref * ref).sum(axis=1)[None, :] - 2.0 * tst @ ref.T
    return np.maximum(ssd, 0.0)


def perfect_memory_familiarity(
    reference: np.ndarray,
    test: np.ndarray,
    *,
    patch: int | None = 8,
    normalisation: Literal["second_min", "none"] = "second_min",
    exclusion: int = 5,
) -> np.ndarray:
    """Familiarity of each test frame with the learned (reference) frames.

    Parameters
    ----------
    reference
        ``(n_learned, height, width)`` frames of the learned route segment.
    test
        ``(n_test, height, width)`` frames to score.
    patch
        Tile side of the patch normalisation (contrast enhancement); ``None`` skips it.
    normalisation
        ``"second_min"``: ``1 - d1 / d2`` (see the module documentation);
        ``"none"``: ``-d1``, the negated minimum SSD.
    exclusion
        Half-width, in learned frames, of the window around the best match that the
        second minimum ignores.

    Returns
    -------
    numpy.ndarray
        ``(n_test,)`` scores, higher = more familiar.
    """
    ref, tst = check_frames(reference, test, "perfect_memory_familiarity")
    if patch is not None:
        ref, tst = patch_normalise(ref, patch), patch_normalise(tst, patch)
    ssd = sum_squared_differences(ref, tst)
    if normalisation == "second_min":
        return second_min_familiarity(ssd, exclusion)
    if normalisation == "none":
        return -ssd.min(axis=1)
    raise ValidationError(
        f"perfect_memory_familiarity: normalisation {normalisation!r} is not 'second_min' or 'none'."
    )
