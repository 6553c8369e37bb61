"""The compiled step loop of the reference backend, and everything it calls.

One ``numba.njit`` function advances the whole network over a range of steps with
no Python in the loop. The order within step ``j`` follows docs/semantics.md:

1. sources emit their spikes stamped ``j`` (scheduled into the delay ring);
2. arrivals for step ``j``: plastic synapses' events (depression, pre traces) and
   the static ring slot, added to synaptic currents/conductances;
3. each neuron: exact propagation of the membrane over the step with the
   synaptic state at its start, decay of the synaptic state, threshold, reset,
   refractoriness (one step counter per neuron: the membrane is held while more
   than the lockout's extra steps remain, and a spike needs the counter at 0),
   adaptation, and on a spike the potentiation of its incoming plastic synapses
   and the scheduling of its outgoing spikes (stamped ``j + 1``);
4. recording of state variables at the end of the step.

Neurons are updated in *groups* of identical parameters (scalars, so the loops
compile to vector instructions), leaving out terms that are exactly ``+0.0`` for a
group (subtracting them is the identity: results are the same bit for bit). A group's
spikes are then handled in increasing neuron index, as a neuron-by-neuron loop would
(a spike only changes its own neuron and steps after ``j + 1``). Static arrivals are
summed per (receptor, ring slot, neuron): a spike adds each of its static segments (one
delay and receptor, see :func:`.delivery.static_delivery`) into one buffer row and
marks the blocks of neurons the segment reaches, so that delivery visits marked blocks
only. Convolutions are delivered from their kernel (:mod:`.convolution`): a spike's
targets and weights are computed from its position, and the buffer row records the range
of neurons reached. Within a buffer entry the contributions keep the order of a
synapse-by-synapse loop, so the sums are the same bit for bit. Pair STDP is
all-to-all with traces that jump by 1 (set to 1 for Diehl & Cook); all synapses of a
segment (one presynaptic neuron, projection and delay) see the same arrivals, so
their presynaptic trace is held once per segment (``seg_xpre``, decayed lazily from
its last arrival ``seg_last``); postsynaptic traces decay every step.

Everything ``run_steps`` computes with lives in this module, because numba's on-disk
cache of a function is only invalidated when its own source file changes (the
prefetch hint in :mod:`.prefetch` cannot change a result). The kernels allocate
nothing, so they are compiled without numba's reference counting (``_nrt=False``),
which would cost atomic operations at every call.

The loop returns early (before starting a step) when the spike record buffer may
overflow; the caller grows the buffer and calls again from that step.
"""

from __future__ import annotations

from collections import namedtuple

import numpy as np
from numba import njit

from .prefetch import prefetch

# The layouts of the arrays the kernels read, defined here (not imported) so that a change
# to any of them changes this file and so invalidates numba's cache of the kernels;
# translation.py, convolution.py and delivery.py import them from here.

# Neuron kinds.
KIND_CURR, KIND_COND, KIND_POISSON, KIND_ARRAY = 0, 1, 2, 3

# Columns of the neuron parameter table.
(
    C_V_REST,
    C_V_RESET,
    C_V_THRESH,
    C_I_OFFSET,
    C_P22,  # exp(-dt/tau_m)
    C_P20,  # (tau_m/cm)(1 - P22): i_offset -> v
    C_P11E,  # exp(-dt/tau_syn_E)
    C_P11I,
    C_P21E,  # I_E(t) -> v over one step (current-based)
    C_P21I,
    C_FE,  # mean of a decaying conductance over one step, relative to its start value
    C_FI,
    C_GL,  # leak conductance cm/tau_m
    C_CM,
    C_E_REV_E,
    C_E_REV_I,
    C_THETA_PLUS,
    C_THETA_DECAY,  # exp(-dt/tau_theta)
    C_P11CA,  # exp(-dt/tau_ca2)
    C_P21CA,  # I_ca2 -> v
    C_I_ALPHA,
    C_REFRAC,  # refractory steps (membrane held at v_reset)
    C_LOCK,  # steps after the refractory ones in which the membrane integrates but may not fire (tau_lockout)
    C_V_INIT,
    C_I_CA_INIT,
    N_COLS,
) = range(26)

# Columns that hold initial values, not parameters of the dynamics.
INIT_COLS = (C_V_INIT, C_I_CA_INIT)

# Columns of the group table, and the group flags.
G_LO, G_HI, G_KIND, G_FLAGS, N_GROUP_COLS = range(5)
#: The group receives inhibitory synapses (otherwise its inhibitory current stays 0).
F_INH = 1
#: The group has the Ca2+ adaptation current (otherwise it stays 0).
F_CA = 2
#: The group has an adaptive threshold.
F_ADAPTIVE = 4

# Rule kinds and columns of the plasticity rule table.
RULE_ADDITIVE, RULE_MULTIPLICATIVE, RULE_DIEHL_COOK = 0, 1, 2
(R_KIND, R_POT, R_DEP, R_W_MIN, R_W_MAX, R_TAU_PRE, R_TAU_POST, R_MU, R_X_TAR, R_TAU_POST2, N_RULE_COLS) = range(11)


# Columns of the per-projection parameter table ``cv_par``.
(CV_PRE0, CV_C, CV_H, CV_W, CV_O, CV_OH, CV_OW, CV_KH, CV_KW, CV_SH, CV_SW, CV_PH, CV_PW, CV_POST0, CV_DELAY, CV_REC,
 CV_WOFF) = range(17)  # fmt: skip
N_CV_COLS = 17

#: Static arrivals are tracked per block of ``1 << BLOCK_SHIFT`` consecutive neurons.
BLOCK_SHIFT = 6

# Codes of the recordable variables (the kernel's recording step switches on them).
VAR_V, VAR_EXC, VAR_INH, VAR_THETA, VAR_CA = range(5)
VAR_CODES = {
    "v": VAR_V,
    "isyn_exc": VAR_EXC,
    "gsyn_exc": VAR_EXC,
    "isyn_inh": VAR_INH,
    "gsyn_inh": VAR_INH,
    "theta": VAR_THETA,
    "i_ca2": VAR_CA,
}

NEVER = np.int64(2**62)

# The arrays the kernels work on, bundled by role (numba passes a tuple of arrays as one
# argument; the simulation builds them, see :meth:`.simulation.ReferenceSimulation._run`).
#: Neurons: groups of identical parameters (``G_*`` columns), the parameter table (``C_*``
#: columns), and the state: membrane, synaptic state ``isyn`` (``ie``, ``ii`` are its rows),
#: adaptive threshold, Ca2+ current, refractory counters, spike flags (one byte per neuron,
#: all 0 between steps; ``flag_words`` is the same memory as 64-bit words) and spike counts.
Neurons = namedtuple("Neurons", "groups params v isyn ie ii theta ica refr flag flag_words counts")
#: The spike record: which neurons are recorded, the spike steps and neurons, the count.
SpikeRecord = namedtuple("SpikeRecord", "mask t i n")
#: Static delivery (:func:`.delivery.static_delivery`): segments per neuron, their synapses and neuron blocks.
StaticTables = namedtuple("StaticTables", "seg_ptr seg_start seg post w blk_ptr blk")
#: The ring of arrivals: static sums, their block marks (also as 64-bit words), the rows
#: holding marks and the neuron range convolutions reached per row; the plastic events per slot.
Arrivals = namedtuple("Arrivals", "buf dirty dirty_words row_any row_range ev ev_n")
#: Structured convolutions (:mod:`.convolution`): per-neuron entries, parameters, transposed kernels.
ConvTables = namedtuple("ConvTables", "index par w")
#: Plastic synapses: per neuron its outgoing segments; per segment its first synapse, delay
#: and projection; per synapse its target and weight; per neuron its incoming synapses (their
#: positions, segments, and the one rule they all follow or -1); per projection its receptor.
PlasticTables = namedtuple(
    "PlasticTables", "row_seg_ptr seg_start seg_delay seg_proj p_post p_w post_ptr post_syn post_seg post_rule proj_inh"
)
#: STDP: the rule table (``R_*`` columns) and presynaptic decay table; the presynaptic trace
#: per segment and its last arrival; the postsynaptic traces (per projection their range,
#: per neuron its traces) and their decays; scratch for one neuron's presynaptic traces.
Traces = namedtuple(
    "Traces",
    "rules pre_table seg_xpre seg_last tr_lo tr_hi tr_shift post_tr_ptr post_tr_idx trace_proj post_decay1 post_decay2 "
    "xpost1 xpost2 x_pre",
)
#: Spike sources: Poisson neurons (index, log(1 - p), next spike step, window) and their
#: generator; the spike array events (steps, neurons) and the next one to emit.
Sources = namedtuple("Sources", "pois_idx pois_logq pois_next pois_start pois_end arr_step arr_neuron arr_ptr rng")
#: Recorded state variables: neuron, variable code (``VAR_*``), and the output rows per step.
VarRecord = namedtuple("VarRecord", "idx code out")

# Indices of the activity counters.
ST_STEPS, ST_NEURON_UPDATES, ST_SPIKES, ST_SYN_EVENTS, ST_PLASTIC_UPDATES = range(5)


@njit(cache=True, inline="always", _nrt=False)
def uniform(rng: np.ndarray) -> float:
    """A uniform draw in (0, 1] from a xorshift64* generator held in ``rng[0]``."""
    x = rng[0]
    x ^= x >> np.uint64(12)
    x ^= x << np.uint64(25)
    x ^= x >> np.uint64(27)
    rng[0] = x
    r = x * np.uint64(2685821657736338717)
    return float((r >> np.uint64(11)) + np.uint64(1)) * (1.0 / 9007199254740992.0)


@njit(cache=True, _nrt=False)
def geometric_gap(rng: np.ndarray, log_q: float) -> np.int64:
    """Number of empty steps before the next spike of a Bernoulli(p) process, ``log_q = log(1 - p)``."""
    if log_q == 0.0:
        return NEVER
    gap = np.floor(np.log(uniform(rng)) / log_q)
    if gap > 2.0**61:
        return NEVER
    return np.int64(gap)


@njit(cache=True, _nrt=False)
def draw_poisson(j: int, idx: np.ndarray, log_q: np.ndarray, nxt: np.ndarray, rng: np.ndarray) -> None:
    """(Re)draw the next spike step of every Poisson neuron from step ``j`` on."""
    for k in range(idx.size):
        g = geometric_gap(rng, log_q[k])
        nxt[k] = NEVER if g == NEVER else j + g


# -- neuron groups ------------------------------------------------------------
#: Synaptic currents (nA) and conductances (uS) below this are set to 0: their effect on
#: the membrane is below 1e-19 mV per step, far below double precision of v.
FLUSH = 1e-18


@njit(cache=True, inline="always", _nrt=False)
def flush(x: float) -> float:
    """``x``, or 0 when its magnitude is below ``FLUSH``."""
    return x if abs(x) >= FLUSH else 0.0


@njit(cache=True, _nrt=False)
def update_curr(lo, hi, flags, neurons):
    """Advance the current-based neurons ``lo:hi`` with the parameters of neuron ``lo``; return how many spiked.

    One loop per set of non-zero terms (Ca2+ and inhibitory currents, inhibitory only,
    neither), each free of branches so that it compiles to vector instructions.
    """
    params, v, ie, ii = neurons.params, neurons.v, neurons.ie, neurons.ii
    ica, refr, flag = neurons.ica, neurons.refr, neurons.flag
    ulo, uhi = np.uint64(lo), np.uint64(hi)  # unsigned indices: no negative-index wrap, so the loops vectorise
    rest, p22, p21e, p11e = params[lo, C_V_REST], params[lo, C_P22], params[lo, C_P21E], params[lo, C_P11E]
    p21i, p11i, p21ca, p11ca = params[lo, C_P21I], params[lo, C_P11I], params[lo, C_P21CA], params[lo, C_P11CA]
    i_off, p20, v_th = params[lo, C_I_OFFSET], params[lo, C_P20], params[lo, C_V_THRESH]
    n_spikes = 0
    if flags & F_CA:
        for q in range(ulo, uhi):
            r, vq, a, b, c = refr[q], v[q], ie[q], ii[q], ica[q]
            moved = rest + (vq - rest) * p22 + a * p21e - b * p21i - c * p21ca + i_off * p20
            vq = vq if r > 0 else moved
            r = r - 1 if r > 0 else r
            ie[q] = flush(a * p11e)
            ii[q] = flush(b * p11i)
            ica[q] = flush(c * p11ca)
            spike = (vq >= v_th) & (r == 0)
            v[q], refr[q], flag[q] = vq, r, spike
            n_spikes += spike
    elif flags & F_INH:
        for q in range(ulo, uhi):
            r, vq, a, b = refr[q], v[q], ie[q], ii[q]
            moved = rest + (vq - rest) * p22 + a * p21e - b * p21i + i_off * p20
            vq = vq if r > 0 else moved
            r = r - 1 if r > 0 else r
            ie[q] = flush(a * p11e)
            ii[q] = flush(b * p11i)
            spike = (vq >= v_th) & (r == 0)
            v[q], refr[q], flag[q] = vq, r, spike
            n_spikes += spike
    else:
        for q in range(ulo, uhi):
            r, vq, a = refr[q], v[q], ie[q]
            moved = rest + (vq - rest) * p22 + a * p21e + i_off * p20
            vq = vq if r > 0 else moved
            r = r - 1 if r > 0 else r
            ie[q] = flush(a * p11e)
            spike = (vq >= v_th) & (r == 0)
            v[q], refr[q], flag[q] = vq, r, spike
            n_spikes += spike
    return n_spikes


@njit(cache=True, inline="always", _nrt=False)
def update_cond(lo, hi, flags, dt, plastic_on, neurons):
    """Advance the conductance-based neurons ``lo:hi`` with the parameters of neuron ``lo``; return how many spiked."""
    params, v, ie, ii = neurons.params, neurons.v, neurons.ie, neurons.ii
    theta, refr, flag = neurons.theta, neurons.refr, neurons.flag
    rest, p22, i_off, p20 = params[lo, C_V_REST], params[lo, C_P22], params[lo, C_I_OFFSET], params[lo, C_P20]
    fe, fi, gl, cm = params[lo, C_FE], params[lo, C_FI], params[lo, C_GL], params[lo, C_CM]
    e_rev_e, e_rev_i, v_th = params[lo, C_E_REV_E], params[lo, C_E_REV_I], params[lo, C_V_THRESH]
    p11e, p11i, theta_decay = params[lo, C_P11E], params[lo, C_P11I], params[lo, C_THETA_DECAY]
    lock = np.int64(params[lo, C_LOCK])  # the last `lock` steps of the count: free membrane, no spike yet
    adapt = plastic_on and (flags & F_ADAPTIVE) != 0
    n_spikes = 0
    for i in range(lo, hi):
        if refr[i] > lock:
            refr[i] -= 1
        else:
            if refr[i] > 0:
                refr[i] -= 1
            if ie[i] == 0.0 and ii[i] == 0.0:  # no conductance: the leak alone (P22 = exp(-dt gL / cm))
                v[i] = rest + (v[i] - rest) * p22 + i_off * p20
            else:
                ge = ie[i] * fe
                gi = ii[i] * fi
                gt = gl + ge + gi
                v_inf = (gl * rest + ge * e_rev_e + gi * e_rev_i + i_off) / gt
                v[i] = v_inf + (v[i] - v_inf) * np.exp(-dt * gt / cm)
        ie[i] = flush(ie[i] * p11e)
        ii[i] = flush(ii[i] * p11i)
        if adapt:
            theta[i] *= theta_decay
        spike = v[i] >= v_th + theta[i] and refr[i] == 0
        flag[i] = spike
        n_spikes += spike
    return n_spikes


# -- plastic synapses ---------------------------------------------------------
@njit(cache=True, inline="always", _nrt=False)
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
    return x * np.exp(-steps * dt / tau)


@njit(cache=True, _nrt=False)
def arrive(g, nxt, j, dt, plastic_on, syn, stdp, isyn):
    """Spikes arriving at segment ``g`` at step ``j``: depress, deliver, advance the pre trace.

    Each synapse is first depressed by the postsynaptic trace (its value at time ``j``)
    and then delivers its new weight to ``isyn[0]`` (excitatory) or ``isyn[1]``
    (inhibitory). Returns the number of weight updates. ``nxt`` is the first synapse of
    the segment that arrives next: its weights and targets are prefetched meanwhile, a
    line every 8 synapses (segments lie apart, so the hardware prefetcher would start
    on each one late). ``syn`` and ``stdp`` are a :class:`PlasticTables` and :class:`Traces`.
    """
    seg_start, seg_proj, p_post, p_w, proj_inh = syn.seg_start, syn.seg_proj, syn.p_post, syn.p_w, syn.proj_inh
    seg_xpre, seg_last, rules, pre_table, tr_shift = stdp.seg_xpre, stdp.seg_last, stdp.rules, stdp.pre_table, stdp.tr_shift
    xpost1 = stdp.xpost1
    r = seg_proj[g]
    rk = rules[r, R_KIND]
    shift = tr_shift[r]  # trace of post neuron i: i + shift (>= 0)
    w_min, w_max, dep = rules[r, R_W_MIN], rules[r, R_W_MAX], rules[r, R_DEP]
    target = np.uint64(1 if proj_inh[r] else 0)
    lo, hi = np.uint64(seg_start[g]), np.uint64(seg_start[g + 1])
    ahead = np.uint64(nxt) - lo  # wraps when the next segment lies before this one: the sum below is exact
    updates = 0
    if not plastic_on:
        for q in range(lo, hi):
            if (q & np.uint64(7)) == 0:
                prefetch(p_w, ahead + q)
                prefetch(p_post, ahead + q)
            isyn[target, p_post[q]] += p_w[q]
    elif rk == RULE_ADDITIVE:
        step = dep * w_max
        for q in range(lo, hi):  # without branches: a zero trace keeps the weight
            if (q & np.uint64(7)) == 0:
                prefetch(p_w, ahead + q)
                prefetch(p_post, ahead + q)
            post = p_post[q]
            x_post = xpost1[np.uint64(post + shift)]
            w = p_w[q]
            moved = min(max(w - step * x_post, w_min), w_max)
            w = moved if x_post != 0.0 else w
            p_w[q] = w
            updates += x_post != 0.0
            isyn[target, post] += w
    else:
        for q in range(lo, hi):
            post = p_post[q]
            x_post = xpost1[np.uint64(post + shift)]
            if x_post != 0.0:
                w = p_w[q]
                if rk == RULE_MULTIPLICATIVE:
                    w -= dep * (w - w_min) * x_post
                else:
                    w -= dep * x_post
                p_w[q] = min(max(w, w_min), w_max)
                updates += 1
            isyn[target, post] += p_w[q]
    if rk == RULE_DIEHL_COOK:
        seg_xpre[g] = 1.0
    else:
        seg_xpre[g] = table_decay(seg_xpre[g], j - seg_last[g], pre_table, r, dt, rules[r, R_TAU_PRE]) + 1.0
    seg_last[g] = j
    return updates


@njit(cache=True, _nrt=False)
def potentiate(i, t, dt, syn, stdp):
    """Potentiate the plastic synapses onto neuron ``i``, which spikes at step ``t``; return the updates.

    The presynaptic traces are gathered first (into ``x_pre``, one per incoming synapse)
    while the weights are prefetched, so the scattered weight updates that follow do not
    wait on one another. When all the synapses follow one rule (``post_rule[i] >= 0``)
    whose decay table ends in 0, the gathering has no branches (a look-up clamped to
    the table's end is :func:`table_decay`); when that rule is additive, neither has
    the update loop. ``syn`` and ``stdp`` are a :class:`PlasticTables` and :class:`Traces`.
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


@njit(cache=True, inline="always", _nrt=False)
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


@njit(cache=True, inline="always", _nrt=False)
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


# -- the step loop ------------------------------------------------------------
@njit(cache=True, inline="always", _nrt=False)
def later_slot(at, delay, ring):
    """The ring slot ``delay`` steps after slot ``at``: ``(at + delay) % ring`` without a division.

    A delay is shorter than the ring, so one subtraction is enough.
    """
    due = at + delay
    return due - ring if due >= ring else due


@njit(cache=True, inline="always", _nrt=False)
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


@njit(cache=True, inline="always", _nrt=False)
def emit(i, stamp, at, width, counts, stats, record, static, arrivals, conv, syn):
    """Record the spike of neuron ``i`` at step ``stamp`` and schedule its arrivals.

    Each static segment (one delay and receptor) adds its weights into one row of the
    ring buffer ``buf`` (row ``receptor * ring + slot``, flattened, ``width`` entries
    each) and marks the neuron blocks it touches in ``dirty`` (``row_any`` says that a
    row has marks); each structured convolution the neuron feeds adds through
    :func:`convolve`. ``at`` is ``stamp``'s ring slot (``stamp % ring``), so that the
    slot of an arrival needs no division. ``record``, ``static``, ``arrivals``, ``conv`` and
    ``syn`` are a :class:`SpikeRecord`, :class:`StaticTables`, :class:`Arrivals`,
    :class:`ConvTables` and :class:`PlasticTables`.
    """
    rec_mask, rec_t, rec_i, rec_n = record
    d_seg_ptr, d_seg_start, d_seg, d_post, d_w, d_blk_ptr, d_blk = static
    buf, dirty, row_any, ev, ev_n = arrivals.buf, arrivals.dirty, arrivals.row_any, arrivals.ev, arrivals.ev_n
    cv_index = conv.index
    counts[i] += 1
    stats[ST_SPIKES] += 1
    if rec_mask[i]:
        n = rec_n[0]
        rec_t[n] = stamp
        rec_i[n] = i
        rec_n[0] = n + 1
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
    for g in range(syn.row_seg_ptr[i], syn.row_seg_ptr[i + 1]):
        due = later_slot(at, syn.seg_delay[g], ring)
        ev[due, ev_n[due]] = g
        ev_n[due] += 1


@njit(cache=True, inline="always", _nrt=False)
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


@njit(cache=True, inline="always", _nrt=False)
def deliver_static(slot, n, arrivals, isyn):
    """Add the static arrivals of ring slot ``slot`` to ``isyn`` and clear them.

    First the row's range of neurons reached by structured convolutions, then the
    marked blocks (entries the range has cleared add nothing), each with
    :func:`add_and_clear`. ``arrivals`` is an :class:`Arrivals`.
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


@njit(cache=True, _nrt=False)
def run_steps(
    j0, j1, dt, plastic_on, headroom, n_updated, neurons, record, static, arrivals, conv, syn, stdp, sources, var, stats
):
    """Advance from step ``j0`` to ``j1`` (exclusive); return the step reached.

    ``headroom`` is the most spikes one step can record; the loop stops before a step
    that could overflow the record buffers. ``n_updated`` is the number of neurons the
    groups update (sources excluded). The bundles are a :class:`Neurons`,
    :class:`SpikeRecord`, :class:`StaticTables`, :class:`Arrivals`, :class:`ConvTables`,
    :class:`PlasticTables`, :class:`Traces`, :class:`Sources` and :class:`VarRecord`;
    ``stats`` holds the activity counters (``ST_*``).
    """
    groups, params, v, isyn, ie, ii = neurons.groups, neurons.params, neurons.v, neurons.isyn, neurons.ie, neurons.ii
    theta, ica, refr, flag, flag_words = neurons.theta, neurons.ica, neurons.refr, neurons.flag, neurons.flag_words
    counts = neurons.counts
    pois_idx, pois_logq, pois_next, pois_start, pois_end, arr_step, arr_neuron, arr_ptr, rng = sources
    seg_start, ev, ev_n, rec_n = syn.seg_start, arrivals.ev, arrivals.ev_n, record.n
    ring = ev_n.size
    n = v.size
    cap = record.t.size
    width = arrivals.buf.size // arrivals.row_any.size
    for j in range(j0, j1):
        if rec_n[0] + headroom > cap:
            return j
        slot = j % ring
        after = later_slot(slot, 1, ring)  # the slot of step j + 1
        # 1. sources
        for k in range(pois_idx.size):
            if pois_next[k] == j:
                i = pois_idx[k]
                if pois_start[k] <= j < pois_end[k]:
                    emit(i, j, slot, width, counts, stats, record, static, arrivals, conv, syn)
                g = geometric_gap(rng, pois_logq[k])
                pois_next[k] = NEVER if g == NEVER else j + 1 + g
            elif pois_next[k] < j:  # window change or redraw in the past: draw forward
                g = geometric_gap(rng, pois_logq[k])
                pois_next[k] = NEVER if g == NEVER else j + g
        while arr_ptr[0] < arr_step.size and arr_step[arr_ptr[0]] <= j:
            if arr_step[arr_ptr[0]] == j:
                emit(arr_neuron[arr_ptr[0]], j, slot, width, counts, stats, record, static, arrivals, conv, syn)
            arr_ptr[0] += 1
        # 2. arrivals at plastic synapses (post traces hold their value at time j)
        for e in range(ev_n[slot]):
            g = ev[slot, e]
            nxt = seg_start[ev[slot, e + 1] if e + 1 < ev_n[slot] else g]
            stats[ST_PLASTIC_UPDATES] += arrive(g, nxt, j, dt, plastic_on, syn, stdp, isyn)
            stats[ST_SYN_EVENTS] += seg_start[g + 1] - seg_start[g]
        ev_n[slot] = 0
        # postsynaptic traces advance to the end of the step
        decay_post_traces(stdp)
        # static arrivals
        deliver_static(slot, n, arrivals, isyn)
        # 3. neurons, group by group; then each group's spikes in increasing index
        stats[ST_NEURON_UPDATES] += n_updated
        for grp in range(groups.shape[0]):
            lo, hi, flags = groups[grp, G_LO], groups[grp, G_HI], groups[grp, G_FLAGS]
            if groups[grp, G_KIND] == KIND_CURR:
                n_spikes = update_curr(lo, hi, flags, neurons)
            else:
                n_spikes = update_cond(lo, hi, flags, dt, plastic_on, neurons)
            word = lo >> 3
            while n_spikes > 0:
                if flag_words[word] != 0:
                    for i in range(word << 3, (word << 3) + 8):
                        if flag[i]:
                            flag[i] = False
                            n_spikes -= 1
                            v[i] = params[lo, C_V_RESET]
                            refr[i] = np.int64(params[lo, C_REFRAC] + params[lo, C_LOCK])
                            ica[i] += params[lo, C_I_ALPHA]
                            if plastic_on:
                                theta[i] += params[lo, C_THETA_PLUS]
                                stats[ST_PLASTIC_UPDATES] += potentiate(i, j + 1, dt, syn, stdp)
                            post_traces(i, stdp)
                            emit(i, j + 1, after, width, counts, stats, record, static, arrivals, conv, syn)
                word += 1
        # 4. state recording
        if var.idx.size:
            row = j - j0
            var_out = var.out
            for r in range(var.idx.size):
                i = var.idx[r]
                c = var.code[r]
                if c == VAR_V:
                    var_out[row, r] = v[i]
                elif c == VAR_EXC:
                    var_out[row, r] = ie[i]
                elif c == VAR_INH:
                    var_out[row, r] = ii[i]
                elif c == VAR_THETA:
                    var_out[row, r] = theta[i]
                else:
                    var_out[row, r] = ica[i]
        stats[ST_STEPS] += 1
    return j1
