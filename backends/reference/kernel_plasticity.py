"""Plastic synapses in the float step loop: arrivals (depression, delivery, pre traces), potentiation, post traces."""

from __future__ import annotations

import numpy as np
from numba import njit

from .kernel_layout import (
    EV_SEG,
    EV_SHIFT,
    R_DEP,
    R_KIND,
    R_MU,
    R_POT,
    R_TAU_POST2,
    R_TAU_PRE,
    R_W_MAX,
    R_W_MIN,
    R_X_TAR,
    RULE_ADDITIVE,
    RULE_DIEHL_COOK,
    RULE_MULTIPLICATIVE,
    ST_PLASTIC_UPDATES,
    ST_SYN_EVENTS,
)
from .libm import exp
from .prefetch import prefetch


@njit(inline="always", _nrt=False)
def table_decay(x, steps, table, r, dt, tau):
    """``x * exp(-steps * dt / tau)`` with the factor from rule ``r``'s table when it holds it.

    Past the table, a row ending in 0 has decayed to exactly 0 (``exp`` is monotone,
    see :func:`.translation.extend_pre_table`).
    """
    if x == 0.0:
        return 0.0
    width = table.shape[1]
    if steps < width:
        return x * table[r, steps]
    if table[r, width - 1] == 0.0:
        return x * 0.0
    return x * exp(-steps * dt / tau)


#: Segments of at most this many synapses are listed (:func:`arrive_slot`).
SHORT = 8


@njit(inline="always", _nrt=False)
def arrive_slot(slot, n_ev, ev, j, dt, plastic_on, syn, stdp, isyn, listed, stats):
    """The plastic events of ring slot ``slot`` (``ev[slot, :n_ev]``) at step ``j``: depress, deliver, update pre traces.

    Each event is a segment (one presynaptic spike, projection and delay) of synapses
    ``lo:hi``; every synapse is first depressed by its postsynaptic trace (its value at
    time ``j``) and then delivers its new weight to ``isyn[0]`` (excitatory) or
    ``isyn[1]`` (inhibitory), in event order. The synapses of consecutive short events (at
    most ``SHORT`` synapses) of one projection are listed first (``listed``, a whole block of
    ``SHORT`` positions written per event, so the listing has no branch that depends on a
    segment's length) and then handled in one loop: segments of the Modular SNN hold about
    4 synapses each, and a loop per segment would mispredict its end at almost every one.
    A longer segment is handled on its own, after the list. The segment's presynaptic trace
    is updated when it is seen (the depression does not read it).
    """
    rules, seg_xpre, seg_last = stdp.rules, stdp.seg_xpre, stdp.seg_last
    room = listed.size - SHORT
    m = 0
    r_run = -1
    for e in range(n_ev):
        code, lo, hi = ev[slot, e, 0], ev[slot, e, 1], ev[slot, e, 2]
        g, r = code & EV_SEG, code >> EV_SHIFT
        n = hi - lo
        if m > 0 and (r != r_run or n > SHORT or m + n > room):
            stats[ST_PLASTIC_UPDATES] += arrive_synapses(listed, 0, m, False, r_run, plastic_on, syn, stdp, isyn)
            m = 0
        if n > SHORT:
            stats[ST_PLASTIC_UPDATES] += arrive_synapses(listed, lo, n, True, r, plastic_on, syn, stdp, isyn)
        else:
            at = np.uint64(m)
            for t in range(SHORT):
                listed[at + np.uint64(t)] = np.uint64(lo + t)
            m += n
            r_run = r
        stats[ST_SYN_EVENTS] += n
        if rules[r, R_KIND] == RULE_DIEHL_COOK:
            seg_xpre[g] = 1.0
        else:
            seg_xpre[g] = table_decay(seg_xpre[g], j - seg_last[g], stdp.pre_table, r, dt, rules[r, R_TAU_PRE]) + 1.0
        seg_last[g] = j
    if m > 0:
        stats[ST_PLASTIC_UPDATES] += arrive_synapses(listed, 0, m, False, r_run, plastic_on, syn, stdp, isyn)


@njit(inline="always", _nrt=False)
def arrive_synapses(listed, lo, m, direct, r, plastic_on, syn, stdp, isyn):
    """Depress and deliver ``m`` synapses of projection ``r`` in order; return the weight updates.

    The synapses are ``lo .. lo + m`` when ``direct``, else ``listed[:m]`` (``direct`` is a
    constant at each call, so each loop reads its synapses one way).
    """
    p_post, p_w = syn.p_post, syn.p_w
    rules, xpost1 = stdp.rules, stdp.xpost1
    rk = rules[r, R_KIND]
    shift = stdp.tr_shift[r]  # trace of post neuron i: i + shift (>= 0)
    w_min, w_max, dep = rules[r, R_W_MIN], rules[r, R_W_MAX], rules[r, R_DEP]
    target = np.uint64(1 if syn.proj_inh[r] else 0)
    base = np.uint64(lo)  # unsigned indices: no negative-index wrap
    if not plastic_on:
        for t in range(np.uint64(m)):
            q = base + t if direct else listed[t]
            isyn[target, p_post[q]] += p_w[q]
        return 0
    if rk == RULE_MULTIPLICATIVE:
        return depress(listed, base, m, direct, shift, target, dep, dep, w_min, w_max, p_post, p_w, xpost1, isyn, True)
    step = dep * w_max if rk == RULE_ADDITIVE else dep  # additive: w - dep w_max x_post; Diehl & Cook: w - dep x_post
    return depress(listed, base, m, direct, shift, target, step, dep, w_min, w_max, p_post, p_w, xpost1, isyn, False)


@njit(inline="always", _nrt=False)
def depress(listed, base, m, direct, shift, target, step, dep, w_min, w_max, p_post, p_w, xpost1, isyn, mult):
    """Depress ``m`` synapses (see :func:`arrive_synapses`) by their postsynaptic traces and deliver them; return the updates.

    ``w - step x_post`` (additive, Diehl & Cook), or ``w - dep (w - w_min) x_post`` when
    ``mult`` (a constant at each call, so each loop computes one form), clipped to
    ``[w_min, w_max]``, without branches: a zero trace keeps the weight.
    """
    updates = 0
    for t in range(np.uint64(m)):
        q = base + t if direct else listed[t]
        post = p_post[q]
        x_post = xpost1[np.uint64(post + shift)]
        w = p_w[q]
        rate = dep * (w - w_min) if mult else step
        moved = min(max(w - rate * x_post, w_min), w_max)
        w = moved if x_post != 0.0 else w
        p_w[q] = w
        updates += x_post != 0.0
        isyn[target, post] += w
    return updates


@njit(_nrt=False)
def potentiate(i, t, dt, syn, stdp):
    """Potentiate the plastic synapses onto neuron ``i``, which spikes at step ``t``; return the updates.

    The presynaptic traces are gathered first (into ``x_pre``, one per incoming synapse)
    while the weights are prefetched, so the scattered weight updates that follow do not
    wait on one another. When all the synapses follow one rule (``post_rule[i] >= 0``)
    whose decay table ends in 0, the gathering has no branches (a look-up clamped to
    the table's end is :func:`table_decay`); when that rule is additive, neither has
    the update loop. ``syn`` and ``stdp`` are a ``PlasticTables`` and ``Traces`` (:mod:`.kernel_layout`).
    """
    post_ptr, post_syn, post_seg, post_rule = syn.post_ptr, syn.post_syn, syn.post_seg, syn.post_rule
    seg_proj, p_w = syn.seg_proj, syn.p_w
    seg_xpre, seg_last, rules, pre_table = stdp.seg_xpre, stdp.seg_last, stdp.rules, stdp.pre_table
    tr_shift, xpost2, x_pre = stdp.tr_shift, stdp.xpost2, stdp.x_pre
    lo = post_ptr[i]
    n = post_ptr[i + 1] - lo
    if n == 0:
        return 0
    r0 = post_rule[i]
    base = np.uint64(lo)  # unsigned indices: no negative-index wrap
    last = pre_table.shape[1] - 1
    if r0 >= 0 and pre_table[r0, last] == 0.0:
        for q in range(np.uint64(n)):
            prefetch(p_w, post_syn[base + q])  # the weights load while the traces are computed
            g = np.uint64(post_seg[base + q])
            x_pre[q] = seg_xpre[g] * pre_table[r0, min(t - seg_last[g], last)]
    elif r0 >= 0:
        tau = rules[r0, R_TAU_PRE]
        for q in range(np.uint64(n)):
            prefetch(p_w, post_syn[base + q])
            g = np.uint64(post_seg[base + q])
            x_pre[q] = table_decay(seg_xpre[g], t - seg_last[g], pre_table, r0, dt, tau)
    else:
        for q in range(np.uint64(n)):
            prefetch(p_w, post_syn[base + q])
            g = np.uint64(post_seg[base + q])
            r = seg_proj[g]
            x_pre[q] = table_decay(seg_xpre[g], t - seg_last[g], pre_table, r, dt, rules[r, R_TAU_PRE])
    updates = 0
    if r0 >= 0 and rules[r0, R_KIND] == RULE_ADDITIVE:
        w_min, w_max = rules[r0, R_W_MIN], rules[r0, R_W_MAX]
        step = rules[r0, R_POT] * w_max
        for q in range(np.uint64(n)):
            x = x_pre[q]
            k = np.uint64(post_syn[base + q])
            w = p_w[k]
            moved = min(max(w + step * x, w_min), w_max)
            p_w[k] = moved if x != 0.0 else w
            updates += x != 0.0
        return updates
    if r0 >= 0 and rules[r0, R_KIND] == RULE_DIEHL_COOK:
        return potentiate_diehl_cook(i, base, n, r0, p_w, post_syn, rules, x_pre, xpost2, tr_shift)
    for q in range(n):
        x = x_pre[q]
        k = post_syn[lo + q]
        r = seg_proj[post_seg[lo + q]]
        rk = rules[r, R_KIND]
        w = p_w[k]
        w_min, w_max = rules[r, R_W_MIN], rules[r, R_W_MAX]
        if rk == RULE_ADDITIVE:  # without branches: a zero trace keeps the weight
            moved = min(max(w + rules[r, R_POT] * w_max * x, w_min), w_max)
            p_w[k] = moved if x != 0.0 else w
            updates += x != 0.0
            continue
        if rk == RULE_MULTIPLICATIVE:
            if x == 0.0:
                continue
            w += rules[r, R_POT] * (w_max - w) * x
        else:
            factor = (x - rules[r, R_X_TAR]) * (w_max - w) ** rules[r, R_MU]
            if rules[r, R_TAU_POST2] > 0.0:
                factor *= xpost2[i + tr_shift[r]]
            if factor == 0.0:
                continue
            w += rules[r, R_POT] * factor
        p_w[k] = min(max(w, w_min), w_max)
        updates += 1
    return updates


@njit(inline="always", _nrt=False)
def potentiate_diehl_cook(i, base, n, r, p_w, post_syn, rules, x_pre, xpost2, tr_shift):
    """:func:`potentiate`'s update loop when every synapse onto neuron ``i`` follows Diehl & Cook rule ``r``.

    The same arithmetic as the general loop, without branches per synapse: a zero factor
    keeps the weight, ``(w_max - w) ** mu`` is taken as exactly 1 for ``mu = 0`` and as
    ``w_max - w`` for ``mu = 1`` (what ``pow`` returns for those exponents; each case its own
    loop, so that no ``pow`` is computed there), and a rule without the second
    postsynaptic trace multiplies by nothing.
    """
    mu = rules[r, R_MU]
    if mu == 0.0:
        return diehl_cook_loop(i, base, n, r, p_w, post_syn, rules, x_pre, xpost2, tr_shift, 0)
    if mu == 1.0:
        return diehl_cook_loop(i, base, n, r, p_w, post_syn, rules, x_pre, xpost2, tr_shift, 1)
    return diehl_cook_loop(i, base, n, r, p_w, post_syn, rules, x_pre, xpost2, tr_shift, 2)


@njit(inline="always", _nrt=False)
def diehl_cook_loop(i, base, n, r, p_w, post_syn, rules, x_pre, xpost2, tr_shift, form):
    """The loop of :func:`potentiate_diehl_cook` for ``mu = 0`` (``form`` 0), ``mu = 1`` (1) or any ``mu`` (2)."""
    w_min, w_max, pot, x_tar, mu = rules[r, R_W_MIN], rules[r, R_W_MAX], rules[r, R_POT], rules[r, R_X_TAR], rules[r, R_MU]
    post2 = rules[r, R_TAU_POST2] > 0.0
    x_post2 = xpost2[i + tr_shift[r]]
    updates = 0
    for q in range(np.uint64(n)):
        k = np.uint64(post_syn[base + q])
        w = p_w[k]
        room = w_max - w
        scale = 1.0 if form == 0 else (room if form == 1 else room**mu)
        factor = (x_pre[q] - x_tar) * scale
        factor = factor * x_post2 if post2 else factor
        moved = min(max(w + pot * factor, w_min), w_max)
        p_w[k] = moved if factor != 0.0 else w
        updates += factor != 0.0
    return updates


@njit(inline="always", _nrt=False)
def post_traces(i, stdp):
    """Update the postsynaptic traces of neuron ``i`` for its spike (traces are at its time already)."""
    post_tr_ptr, post_tr_idx, trace_proj, rules = stdp.post_tr_ptr, stdp.post_tr_idx, stdp.trace_proj, stdp.rules
    xpost1, xpost2 = stdp.xpost1, stdp.xpost2
    for q in range(post_tr_ptr[i], post_tr_ptr[i + 1]):
        tr = post_tr_idx[q]
        if rules[trace_proj[tr], R_KIND] == RULE_DIEHL_COOK:
            xpost1[tr] = 1.0
            xpost2[tr] = 1.0
        else:
            xpost1[tr] += 1.0


@njit(inline="always", _nrt=False)
def decay_post_traces(stdp):
    """Advance every postsynaptic trace by one step.

    The second trace is only ever non-zero under the Diehl & Cook rule, so only those
    projections decay it.
    """
    rules, tr_lo, tr_hi, xpost1, xpost2 = stdp.rules, stdp.tr_lo, stdp.tr_hi, stdp.xpost1, stdp.xpost2
    post_decay1, post_decay2 = stdp.post_decay1, stdp.post_decay2
    for r in range(tr_lo.size):
        lo, hi = tr_lo[r], tr_hi[r]
        if hi == lo:
            continue
        d1 = post_decay1[lo]
        for q in range(np.uint64(lo), np.uint64(hi)):
            xpost1[q] *= d1
        if rules[r, R_KIND] == RULE_DIEHL_COOK:
            d2 = post_decay2[lo]
            for q in range(np.uint64(lo), np.uint64(hi)):
                xpost2[q] *= d2
