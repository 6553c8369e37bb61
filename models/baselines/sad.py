"""Sum of absolute differences (SAD) between preprocessed images.

The Modular SNN paper (Hussaini, Milford & Fischer, T-RO 2024) compares against SAD
computed on the same 28x28 grayscale, 7x7 patch-normalised images the network sees
(:mod:`neurovpr.data.preprocess`): ``D[r, q] = sum_p |ref_r[p] - query_q[p]|`` over the
784 pixels, on the 0..255 values.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.distance import cdist

from neurovpr.data.preprocess import preprocess_images
from neurovpr.data.traverse import ImageSet, Traverse
from neurovpr.errors import ValidationError

__all__ = ["baseline_inputs", "sad_distances"]

ImagesLike = ImageSet | np.ndarray


def baseline_inputs(images: ImagesLike, *, preprocess: bool = True) -> np.ndarray:
    """Flattened float64 ``(N, pixels)`` inputs of a baseline.

    With ``preprocess=True`` (default) the images go through the paper's pipeline
    first; with ``False`` they are used as given (e.g. already preprocessed stacks).
    """
    if isinstance(images, ImageSet):
        stack = images.preprocessed() if preprocess else np.stack(images.images())
    else:
        arr = np.asarray(images)
        if arr.ndim < 2 or arr.shape[0] == 0:
            raise ValidationError(f"baseline input must be a non-empty stack of images, got shape {arr.shape}.")
        stack = preprocess_images(arr) if preprocess else arr
    flat = np.asarray(stack, dtype=np.float64).reshape(len(stack), -1)
    if not np.isfinite(flat).all():
        raise ValidationError("baseline input has NaN or infinite values.")
    return flat


def _pairwise(reference: np.ndarray, query: np.ndarray, metric: str) -> np.ndarray:
    if reference.shape[1] != query.shape[1]:
        raise ValidationError(
            f"reference images have {reference.shape[1]} values each but query images {query.shape[1]}; "
            "both must have the same size."
        )
    return cdist(reference, query, metric=metric)


def sad_distances(reference: ImagesLike | Traverse, query: ImagesLike | None = None, *, preprocess: bool = True) -> np.ndarray:
    """SAD distance matrix ``[reference, query]``.

    Pass two image sets/stacks, or one :class:`~neurovpr.data.traverse.Traverse`; with
    several reference traverses, each place keeps its smallest distance over them.
    """
    if isinstance(reference, Traverse):
        if query is not None:
            raise ValidationError("sad_distances takes either a Traverse or reference and query images, not both.")
        q = baseline_inputs(reference.query, preprocess=preprocess)
        mats = [_pairwise(baseline_inputs(r, preprocess=preprocess), q, "cityblock") for r in reference.references]
        return np.minimum.reduce(mats)
    if query is None:
        raise ValidationError("sad_distances needs query images when the reference is not a Traverse.")
    return _pairwise(
        baseline_inputs(reference, preprocess=preprocess), baseline_inputs(query, preprocess=preprocess), "cityblock"
    )
