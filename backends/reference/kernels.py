"""The compiled step loop of the reference backend.

One ``numba.njit`` function advances the whole network over a range of steps with
no Python in the loop. The order within step ``j`` follows docs/semantics.md:

1. sources emit their spikes stamped ``j`` (scheduled into the delay ring);
2. arrivals for step ``j``: plastic synapses' events (depression, pre traces) and
   the static ring slot, added to synaptic currents/conductances;
3. each neuron: exact propagation of the membrane over the step with the
   synaptic state at its start, decay of the synaptic state, threshold, reset,
   refractoriness, adaptation, and on a spike the potentiation of its incoming
   plastic synapses and the scheduling of its outgoing spikes (stamped ``j + 1``);
4. recording of state variables at the end of the step.

The loop returns early (before starting a step) when the spike record buffer may
overflow; the caller grows the buffer and calls again from that step.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .translation import (
    C_CM,
    C_E_REV_E,
    C_E_REV_I,
    C_FE,
    C_FI,
    C_GL,
    C_I_ALPHA,
    C_I_OFFSET,
    C_P11CA,
    C_P11E,
    C_P11I,
    C_P20,
    C_P21CA,
    C_P21E,
    C_P21I,
    C_P22,
    C_REFRAC,
    C_THETA_DECAY,
    C_THETA_PLUS,
    C_V_RESET,
    C_V_REST,
    C_V_THRESH,
    KIND_COND,
    KIND_CURR,
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
)

NEVER = np.int64(2**62)

#: Synaptic currents (nA) and conductances (uS) below this are set to 0: their effect on
#: the membrane is below 1e-19 mV per step, far below double precision of v.
FLUSH = 1e-18

# Indices of the activity counters.
ST_STEPS, ST_NEURON_UPDATES, ST_SPIKES, ST_SYN_EVENTS, ST_PLASTIC_UPDATES = range(5)


@njit(cache=True, inline="always")
def uniform(rng: np.ndarray) -> float:
    """A uniform draw in (0, 1] from a xorshift64* generator held in ``rng[0]``."""
    x = rng[0]
    x ^= x >> np.uint64(12)
    x ^= x << np.uint64(25)
    x ^= x >> np.uint64(27)
    rng[0] = x
    r = x * np.uint64(2685821657736338717)
    return float((r >> np.uint64(11)) + np.uint64(1)) * (1.0 / 9007199254740992.0)


@njit(cache=True, inline="always")
def _flush(x: float) -> float:
    """``x``, or 0 when its magnitude is below ``FLUSH``."""
    return x if abs(x) >= FLUSH else 0.0


@njit(cache=True)
def geometric_gap(rng: np.ndarray, log_q: float) -> np.int64:
    """Number of empty steps before the next spike of a Bernoulli(p) process, ``log_q = log(1 - p)``."""
    if log_q == 0.0:
        return NEVER
    gap = np.floor(np.log(uniform(rng)) / log_q)
    if gap > 2.0**61:
        return NEVER
    return np.int64(gap)


@njit(cache=True)
def draw_poisson(j: int, idx: np.ndarray, log_q: np.ndarray, nxt: np.ndarray, rng: np.ndarray) -> None:
    """(Re)draw the next spike step of every Poisson neuron from step ``j`` on."""
    for k in range(idx.size):
        g = geometric_gap(rng, log_q[k])
        nxt[k] = NEVER if g == NEVER else j + g


@njit(cache=True)
def emit(
    i, stamp, counts, rec_mask, rec_t, rec_i, rec_n, s_ptr, s_post, s_w, s_delay, s_inh,
    buf_e, buf_i, row_seg_ptr, seg_delay, ev, ev_n, stats,
):  # fmt: skip
    """Record the spike of neuron ``i`` at step ``stamp`` and schedule its arrivals."""
    counts[i] += 1
    stats[ST_SPIKES] += 1
    if rec_mask[i]:
        n = rec_n[0]
        rec_t[n] = stamp
        rec_i[n] = i
        rec_n[0] = n + 1
    ring = buf_e.shape[0]
    for k in range(s_ptr[i], s_ptr[i + 1]):
        slot = (stamp + s_delay[k]) % ring
        if s_inh[k]:
            buf_i[slot, s_post[k]] += s_w[k]
        else:
            buf_e[slot, s_post[k]] += s_w[k]
    stats[ST_SYN_EVENTS] += s_ptr[i + 1] - s_ptr[i]
    for g in range(row_seg_ptr[i], row_seg_ptr[i + 1]):
        slot = (stamp + seg_delay[g]) % ring
        ev[slot, ev_n[slot]] = g
        ev_n[slot] += 1


@njit(cache=True)
def run_steps(
    j0, j1, dt, plastic_on, kind, params, v, ie, ii, theta, ica, refr, counts, buf_e, buf_i,
    s_ptr, s_post, s_w, s_delay, s_inh,
    row_seg_ptr, seg_start, seg_delay, p_post, p_w, p_proj, p_inh, p_trace, p_xpre, p_last,
    post_ptr, post_syn, post_tr_ptr, post_tr_idx, trace_proj, rules, pre_table, post_decay1, post_decay2,
    xpost1, xpost2, ev, ev_n, pois_idx, pois_logq, pois_next, pois_start, pois_end, arr_step, arr_neuron, arr_ptr, rng,
    rec_mask, rec_t, rec_i, rec_n, headroom, var_idx, var_code, var_out, stats,
):  # fmt: skip
    """Advance from step ``j0`` to ``j1`` (exclusive); return the step reached.

    ``headroom`` is the most spikes one step can record; the loop stops before a
    step that could overflow the record buffers.
    """
    n = kind.size
    ring = buf_e.shape[0]
    cap = rec_t.size
    for j in range(j0, j1):
        if rec_n[0] + headroom > cap:
            return j
        slot = j % ring
        # 1. sources
        for k in range(pois_idx.size):
            if pois_next[k] == j:
                i = pois_idx[k]
                if pois_start[k] <= j < pois_end[k]:
                    emit(i, j, counts, rec_mask, rec_t, rec_i, rec_n, s_ptr, s_post, s_w, s_delay, s_inh,
                         buf_e, buf_i, row_seg_ptr, seg_delay, ev, ev_n, stats)  # fmt: skip
                g = geometric_gap(rng, pois_logq[k])
                pois_next[k] = NEVER if g == NEVER else j + 1 + g
            elif pois_next[k] < j:  # window change or redraw in the past: draw forward
                g = geometric_gap(rng, pois_logq[k])
                pois_next[k] = NEVER if g == NEVER else j + g
        while arr_ptr[0] < arr_step.size and arr_step[arr_ptr[0]] <= j:
            if arr_step[arr_ptr[0]] == j:
                emit(arr_neuron[arr_ptr[0]], j, counts, rec_mask, rec_t, rec_i, rec_n, s_ptr, s_post, s_w,
                     s_delay, s_inh, buf_e, buf_i, row_seg_ptr, seg_delay, ev, ev_n, stats)  # fmt: skip
            arr_ptr[0] += 1
        # 2. arrivals at plastic synapses (post traces hold their value at time j)
        for e in range(ev_n[slot]):
            g = ev[slot, e]
            for k in range(seg_start[g], seg_start[g + 1]):
                r = p_proj[k]
                post = p_post[k]
                x_post = xpost1[p_trace[k]]
                rk = rules[r, R_KIND]
                if plastic_on and x_post != 0.0:
                    w = p_w[k]
                    if rk == RULE_ADDITIVE:
                        w -= rules[r, R_DEP] * rules[r, R_W_MAX] * x_post
                    elif rk == RULE_MULTIPLICATIVE:
                        w -= rules[r, R_DEP] * (w - rules[r, R_W_MIN]) * x_post
                    else:
                        w -= rules[r, R_DEP] * x_post
                    p_w[k] = min(max(w, rules[r, R_W_MIN]), rules[r, R_W_MAX])
                    stats[ST_PLASTIC_UPDATES] += 1
                if p_inh[k]:  # the arriving spike carries the weight after its own depression
                    ii[post] += p_w[k]
                else:
                    ie[post] += p_w[k]
                if rk == RULE_DIEHL_COOK:
                    p_xpre[k] = 1.0
                else:
                    p_xpre[k] = _table_decay(p_xpre[k], j - p_last[k], pre_table, r, dt, rules[r, R_TAU_PRE]) + 1.0
                p_last[k] = j
            stats[ST_SYN_EVENTS] += seg_start[g + 1] - seg_start[g]
        ev_n[slot] = 0
        # postsynaptic traces advance to the end of the step
        for tr in range(xpost1.size):
            xpost1[tr] *= post_decay1[tr]
            xpost2[tr] *= post_decay2[tr]
        # static arrivals
        for i in range(n):
            if buf_e[slot, i] != 0.0:
                ie[i] += buf_e[slot, i]
                buf_e[slot, i] = 0.0
            if buf_i[slot, i] != 0.0:
                ii[i] += buf_i[slot, i]
                buf_i[slot, i] = 0.0
        # 3. neurons
        for i in range(n):
            kd = kind[i]
            if kd != KIND_CURR and kd != KIND_COND:
                continue
            stats[ST_NEURON_UPDATES] += 1
            if refr[i] > 0:
                refr[i] -= 1
            elif kd == KIND_CURR:
                v[i] = (
                    params[i, C_V_REST]
                    + (v[i] - params[i, C_V_REST]) * params[i, C_P22]
                    + ie[i] * params[i, C_P21E]
                    - ii[i] * params[i, C_P21I]
                    - ica[i] * params[i, C_P21CA]
                    + params[i, C_I_OFFSET] * params[i, C_P20]
                )
            elif ie[i] == 0.0 and ii[i] == 0.0:  # no conductance: the leak alone (P22 = exp(-dt gL / cm))
                v[i] = (
                    params[i, C_V_REST]
                    + (v[i] - params[i, C_V_REST]) * params[i, C_P22]
                    + params[i, C_I_OFFSET] * params[i, C_P20]
                )
            else:
                ge = ie[i] * params[i, C_FE]
                gi = ii[i] * params[i, C_FI]
                gt = params[i, C_GL] + ge + gi
                v_inf = (
                    params[i, C_GL] * params[i, C_V_REST]
                    + ge * params[i, C_E_REV_E]
                    + gi * params[i, C_E_REV_I]
                    + params[i, C_I_OFFSET]
                ) / gt
                v[i] = v_inf + (v[i] - v_inf) * np.exp(-dt * gt / params[i, C_CM])
            # decay; values below FLUSH (1e-18 nA or uS, ~1e-20 mV per step) are exactly 0 from then on
            ie[i] = _flush(ie[i] * params[i, C_P11E])
            ii[i] = _flush(ii[i] * params[i, C_P11I])
            ica[i] = _flush(ica[i] * params[i, C_P11CA])
            if plastic_on:
                theta[i] *= params[i, C_THETA_DECAY]
            if v[i] >= params[i, C_V_THRESH] + theta[i] and refr[i] == 0:
                v[i] = params[i, C_V_RESET]
                refr[i] = np.int64(params[i, C_REFRAC])
                ica[i] += params[i, C_I_ALPHA]
                if plastic_on:
                    theta[i] += params[i, C_THETA_PLUS]
                    _potentiate(i, j + 1, dt, post_ptr, post_syn, p_proj, p_w, p_xpre, p_last, p_trace,
                                rules, pre_table, xpost2, stats)  # fmt: skip
                _post_traces(i, post_tr_ptr, post_tr_idx, trace_proj, rules, xpost1, xpost2)
                emit(i, j + 1, counts, rec_mask, rec_t, rec_i, rec_n, s_ptr, s_post, s_w, s_delay, s_inh,
                     buf_e, buf_i, row_seg_ptr, seg_delay, ev, ev_n, stats)  # fmt: skip
        # 4. state recording
        if var_idx.size:
            row = j - j0
            for r in range(var_idx.size):
                i = var_idx[r]
                c = var_code[r]
                if c == 0:
                    var_out[row, r] = v[i]
                elif c == 1:
                    var_out[row, r] = ie[i]
                elif c == 2:
                    var_out[row, r] = ii[i]
                elif c == 3:
                    var_out[row, r] = theta[i]
                else:
                    var_out[row, r] = ica[i]
        stats[ST_STEPS] += 1
    return j1


@njit(cache=True, inline="always")
def _table_decay(x, steps, table, r, dt, tau):  # fmt: skip
    """``x * exp(-steps * dt / tau)`` with the factor from rule ``r``'s table when it holds it."""
    if x == 0.0:
        return 0.0
    if steps < table.shape[1]:
        return x * table[r, steps]
    return x * np.exp(-steps * dt / tau)


@njit(cache=True)
def _potentiate(i, t, dt, post_ptr, post_syn, p_proj, p_w, p_xpre, p_last, p_trace, rules, pre_table, xpost2, stats):  # fmt: skip
    """Potentiate the plastic synapses onto neuron ``i``, which spikes at step ``t``."""
    for q in range(post_ptr[i], post_ptr[i + 1]):
        k = post_syn[q]
        r = p_proj[k]
        x_pre = _table_decay(p_xpre[k], t - p_last[k], pre_table, r, dt, rules[r, R_TAU_PRE])
        rk = rules[r, R_KIND]
        w = p_w[k]
        w_max = rules[r, R_W_MAX]
        if rk == RULE_ADDITIVE:
            if x_pre == 0.0:
                continue
            w += rules[r, R_POT] * w_max * x_pre
        elif rk == RULE_MULTIPLICATIVE:
            if x_pre == 0.0:
                continue
            w += rules[r, R_POT] * (w_max - w) * x_pre
        else:
            factor = (x_pre - rules[r, R_X_TAR]) * (w_max - w) ** rules[r, R_MU]
            if rules[r, R_TAU_POST2] > 0.0:
                factor *= xpost2[p_trace[k]]
            if factor == 0.0:
                continue
            w += rules[r, R_POT] * factor
        p_w[k] = min(max(w, rules[r, R_W_MIN]), w_max)
        stats[ST_PLASTIC_UPDATES] += 1


@njit(cache=True)
def _post_traces(i, post_tr_ptr, post_tr_idx, trace_proj, rules, xpost1, xpost2):  # fmt: skip
    """Update the postsynaptic traces of neuron ``i`` for its spike (traces are at its time already)."""
    for q in range(post_tr_ptr[i], post_tr_ptr[i + 1]):
        tr = post_tr_idx[q]
        if rules[trace_proj[tr], R_KIND] == RULE_DIEHL_COOK:
            xpost1[tr] = 1.0
            xpost2[tr] = 1.0
        else:
            xpost1[tr] += 1.0
