"""Perfect Memory: sum of squared differences to every stored reference image.

Zhu, Mangan & Webb (Science Robotics 2023) compare their mushroom-body model with
Perfect Memory, which stores every reference image and scores a query by the minimum
sum of squared differences (SSD) over the stored images. Here it returns the full SSD
matrix ``D[r, q] = sum_p (ref_r[p] - query_q[p])^2``; the minimum over ``r`` of column
``q`` is the Perfect Memory score of query ``q``. By default the images are the Modular
SNN's 28x28 patch-normalised inputs (:mod:`neurovpr.data.preprocess`), so the baselines
see the same data; pass ``preprocess=False`` for other features.
"""

from __future__ import annotations

import numpy as np

from neurovpr.data.traverse import Traverse
from neurovpr.errors import ValidationError

from .sad import ImagesLike, baseline_inputs

__all__ = ["perfect_memory_distances"]


def _ssd(reference: np.ndarray, query: np.ndarray) -> np.ndarray:
    if reference.shape[1] != query.shape[1]:
        raise ValidationError(
            f"reference images have {reference.shape[1]} values each but query images {query.shape[1]}; "
            "both must have the same size."
        )
    rr = np.einsum("ij,ij->i", reference, reference)
    qq = np.einsum("ij,ij->i", query, query)
    d = rr[:, None] + qq[None, :] - 2.0 * (reference @ query.T)
    return np.maximum(d, 0.0)


def perfect_memory_distances(
    reference: ImagesLike | Traverse, query: ImagesLike | None = None, *, preprocess: bool = True
) -> np.ndarray:
    """SSD distance matrix ``[reference, query]`` (Perfect Memory); same arguments as ``sad_distances``."""
    if isinstance(reference, Traverse):
        if query is not None:
            raise ValidationError("perfect_memory_distances takes either a Traverse or reference and query images, not both.")
        q = baseline_inputs(reference.query, preprocess=preprocess)
        mats = [_ssd(baseline_inputs(r, preprocess=preprocess), q) for r in reference.references]
        return np.minimum.reduce(mats)
    if query is None:
        raise ValidationError("perfect_memory_distances needs query images when the reference is not a Traverse.")
    return _ssd(baseline_inputs(reference, preprocess=preprocess), baseline_inputs(query, preprocess=preprocess))
