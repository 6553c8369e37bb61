"""Spike sources in the compiled loops: the random generator, the Poisson draws and their queue.

A xorshift64* generator held in a one-element array; a Poisson source of rate ``p`` per
step is a Bernoulli process, whose next spike is a geometric gap away. The float loop
(:mod:`.kernels`) and the integer loops (:mod:`.kernels_fixed`) draw the same spikes from
the same generator state: at step ``j`` every source whose next step is ``j`` or earlier
draws, in increasing source index. The integer loops find those sources by looking at every
source each step; the float loop keeps them in a binary heap ordered by next step
(:func:`queue_build`, :func:`queue_due`, :func:`queue_push`), so a step without spikes costs
one comparison instead of one per source, and takes the due ones in index order.
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


@njit(inline="always", _nrt=False)
def _sift_down(t: np.ndarray, k: np.ndarray, n: int, i: int) -> None:
    """Restore the heap order of ``t[:n]`` (payload ``k``) below position ``i``."""
    while True:
        child = 2 * i + 1
        if child >= n:
            return
        if child + 1 < n and t[child + 1] < t[child]:
            child += 1
        if t[child] >= t[i]:
            return
        t[i], t[child] = t[child], t[i]
        k[i], k[child] = k[child], k[i]
        i = child


@njit(_nrt=False)
def queue_build(nxt: np.ndarray, t: np.ndarray, k: np.ndarray, n: np.ndarray) -> None:
    """A min-heap ``t[:n[0]]`` of the next steps of the sources that will spike (``nxt != NEVER``), sources in ``k``."""
    m = 0
    for q in range(nxt.size):
        if nxt[q] != NEVER:
            t[m] = nxt[q]
            k[m] = q
            m += 1
    n[0] = m
    for i in range(m // 2 - 1, -1, -1):
        _sift_down(t, k, m, i)


@njit(inline="always", _nrt=False)
def queue_push(t: np.ndarray, k: np.ndarray, n: np.ndarray, step: np.int64, source: np.int64) -> None:
    """Add source ``source`` due at ``step`` to the heap."""
    i = n[0]
    n[0] = i + 1
    while i > 0:
        parent = (i - 1) // 2
        if t[parent] <= step:
            break
        t[i] = t[parent]
        k[i] = k[parent]
        i = parent
    t[i] = step
    k[i] = source


@njit(inline="always", _nrt=False)
def queue_due(j: np.int64, t: np.ndarray, k: np.ndarray, n: np.ndarray, due: np.ndarray) -> np.int64:
    """Take every source due at step ``j`` or before out of the heap into ``due``, in increasing index; their number."""
    m = 0
    while n[0] > 0 and t[0] <= j:
        due[m] = k[0]
        m += 1
        last = n[0] - 1
        n[0] = last
        if last > 0:
            t[0] = t[last]
            k[0] = k[last]
            _sift_down(t, k, last, 0)
    for a in range(1, m):  # insertion sort: a step has few due sources
        x = due[a]
        b = a - 1
        while b >= 0 and due[b] > x:
            due[b + 1] = due[b]
            b -= 1
        due[b + 1] = x
    return m
