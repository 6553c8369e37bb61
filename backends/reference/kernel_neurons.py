"""The neuron updates of the float step loop: one group of neurons with identical parameters per call."""

from __future__ import annotations

import numpy as np
from numba import njit

from .kernel_layout import (
    C_CM,
    C_E_REV_E,
    C_E_REV_I,
    C_FE,
    C_FI,
    C_GL,
    C_I_OFFSET,
    C_LOCK,
    C_P11CA,
    C_P11E,
    C_P11I,
    C_P20,
    C_P21CA,
    C_P21E,
    C_P21I,
    C_P22,
    C_THETA_DECAY,
    C_V_REST,
    C_V_THRESH,
    F_ADAPTIVE,
    F_CA,
    F_EULER,
    F_INH,
)
from .libm import exp

#: Synaptic currents (nA) and conductances (uS) below this are set to 0: their effect on
#: the membrane is below 1e-19 mV per step, far below double precision of v.
FLUSH = 1e-18


@njit(inline="always", _nrt=False)
def flush(x: float) -> float:
    """``x``, or 0 when its magnitude is below ``FLUSH``."""
    return x if abs(x) >= FLUSH else 0.0


@njit(_nrt=False)
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


@njit(inline="always", _nrt=False)
def update_cond(lo, hi, flags, dt, plastic_on, neurons):
    """Advance the conductance-based neurons ``lo:hi`` with the parameters of neuron ``lo``; return how many spiked.

    Three passes over the group, each neuron's arithmetic the same as in one pass: the
    refractory counters and the membranes without conductance (the leak alone), noting
    for the others the equilibrium and exponent of their step (``neurons.todo`` and
    ``neurons.scratch``); then those membranes, whose ``exp`` calls follow one another
    with nothing else to keep in registers; then the synaptic decays, thresholds and spikes
    without branches.
    """
    params, v, ie, ii = neurons.params, neurons.v, neurons.ie, neurons.ii
    theta, refr, flag, todo = neurons.theta, neurons.refr, neurons.flag, neurons.todo
    v_eq, rate = neurons.scratch[0], neurons.scratch[1]
    rest, p22, i_off, p20 = params[lo, C_V_REST], params[lo, C_P22], params[lo, C_I_OFFSET], params[lo, C_P20]
    fe, fi, gl, cm = params[lo, C_FE], params[lo, C_FI], params[lo, C_GL], params[lo, C_CM]
    e_rev_e, e_rev_i, v_th = params[lo, C_E_REV_E], params[lo, C_E_REV_I], params[lo, C_V_THRESH]
    p11e, p11i, theta_decay = params[lo, C_P11E], params[lo, C_P11I], params[lo, C_THETA_DECAY]
    lock = np.int64(params[lo, C_LOCK])  # the last `lock` steps of the count: free membrane, no spike yet
    adapt = plastic_on and (flags & F_ADAPTIVE) != 0
    ulo, uhi = np.uint64(lo), np.uint64(hi)  # unsigned indices: no negative-index wrap
    m = np.uint64(0)
    for i in range(ulo, uhi):
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
                todo[m] = i
                v_eq[m] = (gl * rest + ge * e_rev_e + gi * e_rev_i + i_off) / gt
                rate[m] = -dt * gt / cm
                m += np.uint64(1)
    if (flags & F_EULER) != 0:  # forward Euler: 1 - dt gt / cm instead of exp(-dt gt / cm)
        for k in range(m):
            i = todo[k]
            v_inf = v_eq[k]
            v[i] = v_inf + (v[i] - v_inf) * (1.0 + rate[k])
    else:
        for k in range(m):
            i = todo[k]
            v_inf = v_eq[k]
            v[i] = v_inf + (v[i] - v_inf) * exp(rate[k])
    n_spikes = 0
    for q in range(ulo, uhi):
        ie[q] = flush(ie[q] * p11e)
        ii[q] = flush(ii[q] * p11i)
        th = theta[q] * theta_decay if adapt else theta[q]
        theta[q] = th
        spike = (v[q] >= v_th + th) & (refr[q] == 0)
        flag[q] = spike
        n_spikes += spike
    return n_spikes
