"""Spike sources in the compiled loops: the random generator and the Poisson draws.

A xorshift64* generator held in a one-element array; a Poisson source of rate ``p`` per
step is a Bernoulli process, whose next spike is a geometric gap away. The float loop
(:mod:`.kernels`) and the integer loops (:mod:`.kernels_fixed`) draw the same spikes from
the same generator state.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .kernel_layout import NEVER


@njit(inline="always", _nrt=False)
def uniform(rng: np.ndarray) -> float:
    """A uniform draw in (0, 1] from a xorshift64* generator held in ``rng[0]``."""
    x = rng[0]
    x ^= x >> np.uint64(12)
    x ^= x << np.uint64(25)
    x ^= x >> np.uint64(27)
    rng[0] = x
    r = x * np.uint64(2685821657736338717)
    return float((r >> np.uint64(11)) + np.uint64(1)) * (1.0 / 9007199254740992.0)


@njit(_nrt=False)
def geometric_gap(rng: np.ndarray, log_q: float) -> np.int64:
    """Number of empty steps before the next spike of a Bernoulli(p) process, ``log_q = log(1 - p)``."""
    if log_q == 0.0:
        return NEVER
    gap = np.floor(np.log(uniform(rng)) / log_q)
    if gap > 2.0**61:
        return NEVER
    return np.int64(gap)
