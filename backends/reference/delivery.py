"""Static synapses in the order the reference kernels deliver them.

Two paths (see :mod:`.kernels`): structured convolutions, delivered from their kernel
(:mod:`.convolution`), and every other static synapse, grouped per presynaptic neuron
into segments of one delay and receptor (:func:`static_delivery`). :func:`split_static`
splits the static CSR arrays between the two; the simulation calls it again when set
weights no longer share a kernel.
"""

from __future__ import annotations

import numpy as np

from .convolution import ConvSpec, conv_tables
from .kernel_layout import BLOCK_SHIFT

__all__ = ["BLOCK_SHIFT", "split_static", "static_delivery"]



def split_static(
    n: int,
    s_ptr: np.ndarray,
    s_post: np.ndarray,
    s_w: np.ndarray,
    s_delay: np.ndarray,
    s_inh: np.ndarray,
    specs: list[ConvSpec],
    proj_static: dict[str, np.ndarray],
) -> dict[str, object]:
    """The static synapses of the structured convolutions ``specs`` as kernels, all others in delivery order.

    Returns the ``d_*`` and ``cv_*`` fields of :class:`.translation.Layout` and ``conv_specs``;
    ``d_of_s`` is -1 at the CSR positions of structured synapses.
    """
    keep = np.ones(s_post.size, dtype=bool)
    for spec in specs:
        for name in spec.names:
            keep[proj_static[name]] = False
    if keep.all():
        out = static_delivery(n, s_ptr, s_post, s_w, s_delay, s_inh)
    else:
        pre = np.repeat(np.arange(n, dtype=np.int64), np.diff(s_ptr))[keep]
        ptr = np.concatenate([[0], np.cumsum(np.bincount(pre, minlength=n))]).astype(np.int64)
        out = static_delivery(n, ptr, s_post[keep], s_w[keep], s_delay[keep], s_inh[keep])
        d_of_s = np.full(s_post.size, -1, dtype=np.int64)
        d_of_s[keep] = out["d_of_s"]
        out["d_of_s"] = d_of_s
    return {**out, **conv_tables(specs, n, s_w, proj_static), "conv_specs": list(specs)}


def static_delivery(
    n: int, s_ptr: np.ndarray, s_post: np.ndarray, s_w: np.ndarray, s_delay: np.ndarray, s_inh: np.ndarray
) -> dict[str, object]:
    """The static synapses in delivery order, as the ``d_*`` fields of :class:`.translation.Layout`.

    Each presynaptic row is sorted stably by (delay, receptor): the synapses adding to one
    ring-buffer entry (slot, receptor, neuron) keep their order, so the sums are the same
    bit for bit. A spike then adds each segment's weights into one buffer row without
    per-synapse delay or receptor look-ups, and marks the segment's blocks of neurons.
    ``d_seg`` holds per segment its delay, receptor and, when its targets are consecutive
    neurons (a dense row), the first of them (else -1): the kernels then add the weights
    to a slice of the row without reading the targets.
    """
    m = s_post.size
    pre = np.repeat(np.arange(n, dtype=np.int64), np.diff(s_ptr))
    rec = s_inh.astype(np.int64)
    order = np.lexsort((np.arange(m), rec, s_delay, pre))
    same = bool(np.array_equal(order, np.arange(m)))
    d_of_s = np.empty(m, dtype=np.int64)
    d_of_s[order] = np.arange(m)
    pre_d, delay_d, rec_d, post_d = pre[order], s_delay[order], rec[order], s_post[order]
    new_seg = np.ones(m, dtype=bool)
    new_seg[1:] = (pre_d[1:] != pre_d[:-1]) | (delay_d[1:] != delay_d[:-1]) | (rec_d[1:] != rec_d[:-1])
    first = np.flatnonzero(new_seg)
    n_blocks = -(-max(n, 1) >> BLOCK_SHIFT)
    seg_of = np.repeat(np.arange(first.size, dtype=np.int64), np.diff(np.append(first, m)))
    blocks = np.unique(seg_of * n_blocks + (post_d >> BLOCK_SHIFT))
    blk_ptr = np.concatenate([[0], np.cumsum(np.bincount(blocks // n_blocks, minlength=first.size))])
    step = np.diff(post_d) == 1  # step[k]: synapse k + 1 targets the neuron after synapse k's
    breaks = np.concatenate([[0], np.cumsum(~step)])  # broken steps before each synapse
    last = np.append(first[1:], m) - 1
    run = np.where(breaks[last] == breaks[first], post_d[first] if m else first, -1)
    return {
        "d_seg_ptr": np.concatenate([[0], np.cumsum(np.bincount(pre_d[first], minlength=n))]).astype(np.int64),
        "d_seg_start": np.append(first, m).astype(np.int64),
        "d_seg": np.ascontiguousarray(np.stack([delay_d[first], rec_d[first], run], axis=1).astype(np.int64)),
        "d_post": post_d.astype(np.uint32) if n < 2**32 else post_d,
        "d_w": s_w if same else s_w[order],
        "d_of_s": d_of_s,
        "d_blk_ptr": blk_ptr.astype(np.int64),
        "d_blk": (blocks % n_blocks).astype(np.uint32),
        "n_blocks": n_blocks,
    }
