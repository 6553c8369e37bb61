"""The per-neuron weight normalisation (:meth:`Simulation.normalise_weights`) in the reference backend's own storage.

The same numbers as :func:`neurovpr.runtime.weights.normalised` (the sums in connection
order, as ``np.bincount`` adds them; the same product and clip per weight), computed in
two passes over the stored weights instead of copying them out, scaling the copy and
writing it back: the sums (with each neuron's extreme weights, which give the new weights'
range, checked before anything is written), then the new weights in place.
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True, _nrt=False)
def scale_factors(store, pos, post, total, factor, extent, w_max, clip):  # type: ignore[no-untyped-def]
    """Fill ``factor`` with ``total / sum`` per neuron (1 where the sum is not positive); return the new weights' range.

    ``store[pos[k]]`` is connection ``k``'s weight and ``post[k]`` its target; ``factor``
    (one per target neuron) holds the sums first, ``extent`` (2 rows of the same length)
    each neuron's smallest and largest weight. Returns ``(lo, hi, finite)`` of the new
    weights (scaled, then clipped at ``w_max`` when ``clip``) without computing each one:
    a product with a positive factor is monotone in the weight (rounding included), and so is
    the clip, so the extremes come from each neuron's extreme weights; a NaN or infinite new
    weight makes one of them NaN or infinite too. Nothing is written to ``store``.
    """
    factor[:] = 0.0
    extent[0, :] = np.inf
    extent[1, :] = -np.inf
    for k in range(pos.size):
        i, w = post[k], store[pos[k]]
        factor[i] += w
        extent[0, i] = min(extent[0, i], w)
        extent[1, i] = max(extent[1, i], w)
    lo, hi, finite = np.inf, -np.inf, True
    for i in range(factor.size):
        s = factor[i]
        f = total / s if s > 0.0 else 1.0
        factor[i] = f
        if extent[0, i] > extent[1, i]:  # no connection onto this neuron
            continue
        for w in (extent[0, i], extent[1, i]):
            v = w * f
            v = w_max if clip and v > w_max else v
            finite &= np.isfinite(v)
            lo = min(lo, v)
            hi = max(hi, v)
    return lo, hi, finite


@njit(cache=True, _nrt=False)
def apply_factors(store, pos, post, factor, w_max, clip):  # type: ignore[no-untyped-def]
    """``store[pos[k]] *= factor[post[k]]``, then clipped at ``w_max`` when ``clip``."""
    for k in range(pos.size):
        v = store[pos[k]] * factor[post[k]]
        store[pos[k]] = w_max if clip and v > w_max else v
