"""Spikes in the float step loop: recording, scheduling into the delay ring, and the static arrivals of a slot."""

from __future__ import annotations

import numpy as np
from numba import njit

from .kernel_layout import (
    BLOCK_SHIFT,
    CV_DELAY,
    CV_KH,
    CV_KW,
    CV_O,
    CV_OH,
    CV_OW,
    CV_POST0,
    CV_REC,
    CV_SH,
    CV_SW,
    CV_WOFF,
    EV_SHIFT,
    ST_SPIKES,
    ST_SYN_EVENTS,
)


@njit(inline="always", _nrt=False)
def later_slot(at, delay, ring):
    """The ring slot ``delay`` steps after slot ``at``: ``(at + delay) % ring`` without a division.

    A delay is shorter than the ring, so one subtraction is enough.
    """
    due = at + delay
    return due - ring if due >= ring else due


@njit(inline="always", _nrt=False)
def convolve(k, at, width, conv, arrivals):
    """Schedule a spike through the structured convolution entry at ``conv.index[k:k + 3]``; return the synapses reached.

    For every output position whose receptive field holds the neuron, all output
    channels receive the kernel's weights for that field position (see
    :mod:`.convolution`, whose ``geometry`` packs the neuron's position and reach). The
    buffer row's range of touched neurons grows to the whole output population.
    """
    cv_index, cv_par, cv_w = conv
    buf, row_any, row_range, ring = arrivals.buf, arrivals.row_any, arrivals.row_range, arrivals.ev_n.size
    p, a, b = cv_index[k], cv_index[k + 1], cv_index[k + 2]
    n = 0
    o, ow, kh, kw = cv_par[p, CV_O], cv_par[p, CV_OW], cv_par[p, CV_KH], cv_par[p, CV_KW]
    sh, sw, post0, plane = cv_par[p, CV_SH], cv_par[p, CV_SW], cv_par[p, CV_POST0], cv_par[p, CV_OH] * ow
    c, yy, xx = a & 0xFFFFF, (a >> 20) & 0xFFFFF, a >> 40
    oy_lo, oy_end, ox_lo, ox_end = b & 0xFFFF, (b >> 16) & 0xFFFF, (b >> 32) & 0xFFFF, b >> 48
    row = cv_par[p, CV_REC] * ring + later_slot(at, cv_par[p, CV_DELAY], ring)
    row_any[row] = True
    row_range[0, row] = min(row_range[0, row], post0)
    row_range[1, row] = max(row_range[1, row], post0 + o * plane)
    base = row * width + post0
    w0 = cv_par[p, CV_WOFF] + c * kh * kw * o
    for oy in range(oy_lo, oy_end):
        for ox in range(ox_lo, ox_end):
            wb = w0 + ((yy - oy * sh) * kw + xx - ox * sw) * o
            pb = base + oy * ow + ox
            for oc in range(o):
                buf[np.uint64(pb + oc * plane)] += cv_w[np.uint64(wb + oc)]
            n += o
    return n


@njit(inline="always", _nrt=False)
def record_spike(i, stamp, counts, stats, record):
    """Count the spike of neuron ``i`` at step ``stamp`` and, when ``i`` is recorded, add it to ``record`` (a ``SpikeRecord``)."""
    counts[i] += 1
    stats[ST_SPIKES] += 1
    if record.mask[i]:
        n = record.n[0]
        record.t[n] = stamp
        record.i[n] = i
        record.n[0] = n + 1


@njit(inline="always", _nrt=False)
def emit(i, stamp, at, width, counts, stats, record, static, arrivals, conv, syn):
    """Record the spike of neuron ``i`` at step ``stamp`` and schedule its arrivals.

    Each static segment (one delay and receptor) adds its weights into one row of the
    ring buffer ``buf`` (row ``receptor * ring + slot``, flattened, ``width`` entries
    each) and marks the neuron blocks it touches in ``dirty`` (``row_any`` says that a
    row has marks); each structured convolution the neuron feeds adds through
    :func:`convolve`. ``at`` is ``stamp``'s ring slot (``stamp % ring``), so that the
    slot of an arrival needs no division. ``record``, ``static``, ``arrivals``, ``conv`` and
    ``syn`` are a ``SpikeRecord``, ``StaticTables``, ``Arrivals``,
    ``ConvTables`` and ``PlasticTables`` (:mod:`.kernel_layout`). Each plastic segment
    is queued with its projection and synapse range (read here in order, not at the
    arrival from scattered segments).
    """
    record_spike(i, stamp, counts, stats, record)
    d_seg_ptr, d_seg_start, d_seg, d_post, d_w, d_blk_ptr, d_blk = static
    buf, dirty, row_any, ev, ev_n = arrivals.buf, arrivals.dirty, arrivals.row_any, arrivals.ev, arrivals.ev_n
    cv_index = conv.index
    ring = ev_n.size
    n_blocks = width >> BLOCK_SHIFT
    for g in range(d_seg_ptr[i], d_seg_ptr[i + 1]):
        row = d_seg[g, 1] * ring + later_slot(at, d_seg[g, 0], ring)
        row_any[row] = True
        base = np.uint64(row * width)  # unsigned indices: no negative-index wrap
        lo, hi = np.uint64(d_seg_start[g]), np.uint64(d_seg_start[g + 1])
        if d_seg[g, 2] >= 0:  # consecutive targets: a slice of the row, no target look-ups
            dst = base + np.uint64(d_seg[g, 2]) - lo
            for k in range(lo, hi):
                buf[dst + k] += d_w[k]
        else:
            for k in range(lo, hi):
                buf[base + d_post[k]] += d_w[k]
        marks = np.uint64(row * n_blocks)
        for b in range(np.uint64(d_blk_ptr[g]), np.uint64(d_blk_ptr[g + 1])):
            dirty[marks + d_blk[b]] = True
    stats[ST_SYN_EVENTS] += d_seg_start[d_seg_ptr[i + 1]] - d_seg_start[d_seg_ptr[i]]
    first = counts.size + 1  # cv_index: pointers, then entries of three values
    for e in range(cv_index[i], cv_index[i + 1]):
        stats[ST_SYN_EVENTS] += convolve(first + 3 * e, at, width, conv, arrivals)
    seg_start, seg_proj, seg_delay = syn.seg_start, syn.seg_proj, syn.seg_delay
    for g in range(syn.row_seg_ptr[i], syn.row_seg_ptr[i + 1]):  # plastic segments: what their arrival reads
        due = later_slot(at, seg_delay[g], ring)
        k = ev_n[due]
        ev[due, k, 0] = g | (seg_proj[g] << EV_SHIFT)
        ev[due, k, 1] = seg_start[g]
        ev[due, k, 2] = seg_start[g + 1]
        ev_n[due] = k + 1


@njit(inline="always", _nrt=False)
def add_and_clear(buf, base, isyn, r, lo, hi):
    """Add buffer entries ``base + lo .. base + hi`` to ``isyn[r, lo:hi]`` and set them to 0.

    An entry that is exactly 0 leaves its synaptic state as it is (adding +0.0 would
    turn a -0.0 into +0.0).
    """
    for q in range(np.uint64(lo), np.uint64(hi)):
        x = buf[base + q]
        s = isyn[r, q]
        isyn[r, q] = s + x if x != 0.0 else s
        buf[base + q] = 0.0


@njit(inline="always", _nrt=False)
def deliver_static(slot, n, arrivals, isyn):
    """Add the static arrivals of ring slot ``slot`` to ``isyn`` and clear them.

    First the row's range of neurons reached by structured convolutions, then the
    marked blocks (entries the range has cleared add nothing), each with
    :func:`add_and_clear`. ``arrivals`` is an ``Arrivals``.
    """
    buf, dirty, dirty_words = arrivals.buf, arrivals.dirty, arrivals.dirty_words
    row_any, row_range = arrivals.row_any, arrivals.row_range
    ring = arrivals.ev_n.size
    width = buf.size // row_any.size
    n_blocks = dirty.size // row_any.size
    block = width // n_blocks
    for r in range(2):
        row = r * ring + slot
        if not row_any[row]:
            continue
        row_any[row] = False
        base = np.uint64(row * width)
        if row_range[0, row] < row_range[1, row]:
            add_and_clear(buf, base, isyn, r, row_range[0, row], row_range[1, row])
            row_range[0, row], row_range[1, row] = n, 0
        marks = row * n_blocks
        for word in range(marks >> 3, (marks + n_blocks) >> 3):
            if dirty_words[word] == 0:
                continue
            dirty_words[word] = 0
            for b in range((word << 3) - marks, (word << 3) - marks + 8):
                lo = b * block
                add_and_clear(buf, base, isyn, r, lo, max(lo, min(lo + block, n)))
