"""Translation of the IR into the flat arrays the reference kernels run on.

All neurons of all populations share one global index space (populations in
insertion order). Per-neuron parameters become columns of one ``(N, K)`` array of
exact-integration propagators; static synapses become a CSR matrix by global
presynaptic index; plastic synapses a second CSR whose rows are split into
*segments* of equal delay, so a presynaptic spike schedules one event per segment.
All synapses of a segment see the same arrivals, so the presynaptic STDP trace is
held once per segment. Neurons are split into *groups*: runs of consecutive neurons
of one population with identical parameters, updated by one loop with scalar
parameters.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

from neurovpr.backendkit.propagators import propagators
from neurovpr.backendkit.timing import delay_steps
from neurovpr.ir.cells import (
    IF_cond_exp,
    IF_cond_exp_adaptive,
    IF_curr_exp_ca2_adaptive,
    SpikeSourceArray,
    SpikeSourcePoisson,
    euler_integrated,
)
from neurovpr.ir.connectivity import expand
from neurovpr.ir.connectors import ConvolutionConnector
from neurovpr.ir.network import Network
from neurovpr.ir.synapses import DiehlCookSTDP, MultiplicativeWeightDependence, STDPMechanism

from .convolution import ConvSpec, conv_spec, merge
from .delivery import split_static
from .kernel_layout import (
    C_CM,
    C_E_REV_E,
    C_E_REV_I,
    C_FE,
    C_FI,
    C_GL,
    C_I_ALPHA,
    C_I_CA_INIT,
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
    C_REFRAC,
    C_THETA_DECAY,
    C_THETA_PLUS,
    C_V_INIT,
    C_V_RESET,
    C_V_REST,
    C_V_THRESH,
    F_ADAPTIVE,
    F_CA,
    F_EULER,
    F_INH,
    G_FLAGS,
    G_HI,
    G_KIND,
    G_LO,
    INIT_COLS,
    KIND_ARRAY,
    KIND_COND,
    KIND_CURR,
    KIND_POISSON,
    N_COLS,
    N_GROUP_COLS,
    N_RULE_COLS,
    R_DEP,
    R_KIND,
    R_MU,
    R_POT,
    R_TAU_POST,
    R_TAU_POST2,
    R_TAU_PRE,
    R_W_MAX,
    R_W_MIN,
    R_X_TAR,
    RULE_ADDITIVE,
    RULE_DIEHL_COOK,
    RULE_MULTIPLICATIVE,
)

# Number of whole-step delays for which the presynaptic trace decay is tabulated with numpy;
# the table then goes on (computed as the kernels compute it) until the decay is exactly 0,
# i.e. past exp(-PRE_ZERO), for at most MAX_PRE_TABLE steps.
PRE_TABLE = 4096
PRE_ZERO = 760.0
MAX_PRE_TABLE = 1 << 17


#: Parameter table column of each exact-integration propagator (:mod:`neurovpr.backendkit.propagators`).
_COLUMNS = {
    "v_rest": C_V_REST, "v_reset": C_V_RESET, "v_thresh": C_V_THRESH, "i_offset": C_I_OFFSET, "p22": C_P22,
    "p20": C_P20, "p11e": C_P11E, "p11i": C_P11I, "p21e": C_P21E, "p21i": C_P21I, "fe": C_FE, "fi": C_FI,
    "gl": C_GL, "cm": C_CM, "e_rev_e": C_E_REV_E, "e_rev_i": C_E_REV_I, "theta_plus": C_THETA_PLUS,
    "theta_decay": C_THETA_DECAY, "p11ca": C_P11CA, "p21ca": C_P21CA, "i_alpha": C_I_ALPHA, "refrac": C_REFRAC,
    "lock": C_LOCK, "v_init": C_V_INIT, "i_ca_init": C_I_CA_INIT,
}  # fmt: skip


def neuron_table(cell: object, n: int, dt: float, v_init: object) -> tuple[int, np.ndarray]:
    """The kind and ``(n, N_COLS)`` parameter table of a population."""
    table = np.zeros((n, N_COLS))
    if isinstance(cell, (SpikeSourcePoisson, SpikeSourceArray)):
        return (KIND_POISSON if isinstance(cell, SpikeSourcePoisson) else KIND_ARRAY), table
    for name, values in propagators(cell, n, dt, v_init).items():
        table[:, _COLUMNS[name]] = values
    return (KIND_COND if isinstance(cell, (IF_cond_exp, IF_cond_exp_adaptive)) else KIND_CURR), table


def rule_row(syn: object) -> np.ndarray:
    """The plasticity rule table row of a plastic synapse type."""
    row = np.zeros(N_RULE_COLS)
    if isinstance(syn, STDPMechanism):
        td, wd = syn.timing_dependence, syn.weight_dependence
        row[R_KIND] = RULE_MULTIPLICATIVE if isinstance(wd, MultiplicativeWeightDependence) else RULE_ADDITIVE
        row[R_POT], row[R_DEP] = td.A_plus, td.A_minus
        row[R_W_MIN], row[R_W_MAX] = wd.w_min, wd.w_max
        row[R_TAU_PRE], row[R_TAU_POST] = td.tau_plus, td.tau_minus
    elif isinstance(syn, DiehlCookSTDP):
        row[R_KIND] = RULE_DIEHL_COOK
        # the kernels subtract R_DEP x_post at an arrival: a potentiating pre term is a negative depression
        row[R_POT], row[R_DEP] = syn.eta_post, (syn.eta_pre if syn.pre_term == "depress" else -syn.eta_pre)
        row[R_W_MIN], row[R_W_MAX] = 0.0, syn.w_max
        row[R_TAU_PRE], row[R_TAU_POST] = syn.tau_pre, syn.tau_post
        row[R_MU], row[R_X_TAR] = syn.mu, syn.x_tar
        row[R_TAU_POST2] = syn.tau_post2 or 0.0
    else:  # pragma: no cover - capabilities exclude other types
        raise TypeError(type(syn).__name__)
    return row


@dataclass
class Layout:
    """Everything the kernels need, as contiguous arrays (built once per compile)."""

    n: int
    offsets: dict[str, tuple[int, int]]
    kind: np.ndarray
    params: np.ndarray
    # (G, N_GROUP_COLS) neuron groups of identical parameters (sources excluded); neurons they update
    groups: np.ndarray
    n_updated: int
    # static synapses, CSR by global pre
    s_ptr: np.ndarray
    s_post: np.ndarray
    s_w: np.ndarray
    s_delay: np.ndarray
    s_inh: np.ndarray
    # static synapses in delivery order (pre, delay, receptor, then CSR order): per pre neuron, segments
    # of one delay and receptor (0 excitatory, 1 inhibitory); the neuron blocks each segment touches;
    # d_of_s: position in delivery order of each CSR position (d_w is s_w when the orders agree)
    d_seg_ptr: np.ndarray
    d_seg_start: np.ndarray
    d_seg: np.ndarray
    d_post: np.ndarray
    d_w: np.ndarray
    d_of_s: np.ndarray
    d_blk_ptr: np.ndarray
    d_blk: np.ndarray
    n_blocks: int
    # structured convolutions (see .convolution): per pre neuron its projections, their parameters, kernels
    conv_specs: list[ConvSpec]
    cv_index: np.ndarray
    cv_par: np.ndarray
    cv_w: np.ndarray
    # plastic synapses, CSR by global pre split into equal-delay segments of one projection
    row_seg_ptr: np.ndarray
    seg_start: np.ndarray
    seg_delay: np.ndarray
    seg_proj: np.ndarray
    p_post: np.ndarray
    p_w: np.ndarray
    # incoming plastic synapses by post neuron: synapse index and its segment; the rule all of them
    # follow (-1 when they follow several)
    post_ptr: np.ndarray
    post_syn: np.ndarray
    post_seg: np.ndarray
    post_rule: np.ndarray
    # per plastic projection: inhibitory?, post traces [tr_lo, tr_hi), trace index = post + tr_shift
    proj_inh: np.ndarray
    tr_lo: np.ndarray
    tr_hi: np.ndarray
    tr_shift: np.ndarray
    post_tr_ptr: np.ndarray
    post_tr_idx: np.ndarray
    trace_proj: np.ndarray
    rules: np.ndarray
    pre_table: np.ndarray
    post_decay1: np.ndarray
    post_decay2: np.ndarray
    n_traces: int
    ring: int
    # per projection: where its canonical connections live
    proj_static: dict[str, np.ndarray]
    proj_plastic: dict[str, np.ndarray]
    proj_pre: dict[str, np.ndarray]
    proj_post: dict[str, np.ndarray]


def build_layout(network: Network, dt: float, seed: int) -> Layout:
    """Expand every projection and lay the network out as kernel arrays."""
    offsets: dict[str, tuple[int, int]] = {}
    kinds, tables = [], []
    start = 0
    for pop in network.populations.values():
        kind, table = neuron_table(pop.cell_type, pop.size, dt, pop.v_init)
        offsets[pop.name] = (start, start + pop.size)
        kinds.append(np.full(pop.size, kind, dtype=np.int8))
        tables.append(table)
        start += pop.size
    n = start
    kind = np.concatenate(kinds)
    params = np.ascontiguousarray(np.concatenate(tables))
    inhibited = {proj.post for proj in network.projections.values() if proj.receptor_type == "inhibitory"}
    groups = [
        _groups(offsets[pop.name][0], table, int(k[0]), _flags(pop.cell_type, pop.name in inhibited))
        for pop, k, table in zip(network.populations.values(), kinds, tables, strict=True)
        if pop.size and int(k[0]) in (KIND_CURR, KIND_COND)
    ]
    group_table = np.concatenate(groups) if groups else np.zeros((0, N_GROUP_COLS), dtype=np.int64)

    st = {k: [] for k in ("pre", "post", "w", "d", "inh", "proj", "canon")}
    pl = {k: [] for k in ("pre", "post", "w", "d", "inh", "proj", "canon")}
    rules, proj_pre, proj_post = [], {}, {}
    trace_proj: list[np.ndarray] = []
    n_traces = 0
    proj_inh, tr_lo, tr_hi, tr_shift = [], [], [], []
    static_names, plastic_names = [], []
    specs: list[ConvSpec] = []
    for proj in network.projections.values():
        conns = expand(network, proj, dt=dt, seed=seed)
        pre0, post0 = offsets[proj.pre][0], offsets[proj.post][0]
        steps = delay_steps(conns.delay, dt)
        if not proj.plastic and isinstance(proj.connector, ConvolutionConnector):
            spec = conv_spec(proj.name, proj.connector, conns.pre, conns.post, conns.weight, steps, (pre0, post0),
                             proj.receptor_type == "inhibitory")  # fmt: skip
            if spec is not None:
                specs.append(spec)
        proj_pre[proj.name], proj_post[proj.name] = conns.pre, conns.post
        inh = np.full(len(conns), proj.receptor_type == "inhibitory")
        target = pl if proj.plastic else st
        pid = len(plastic_names) if proj.plastic else len(static_names)
        (plastic_names if proj.plastic else static_names).append(proj.name)
        target["pre"].append(conns.pre + pre0)
        target["post"].append(conns.post + post0)
        target["w"].append(conns.weight)
        target["d"].append(steps)
        target["inh"].append(inh)
        target["proj"].append(np.full(len(conns), pid, dtype=np.int64))
        target["canon"].append(np.arange(len(conns)))
        if proj.plastic:
            rules.append(rule_row(proj.synapse))
            n_post = network.populations[proj.post].size
            proj_inh.append(proj.receptor_type == "inhibitory")
            tr_lo.append(n_traces)
            tr_hi.append(n_traces + n_post)
            tr_shift.append(n_traces - post0)
            trace_proj.append(np.full(n_post, pid, dtype=np.int64))
            n_traces += n_post

    def cat(parts: list[np.ndarray], dtype: object) -> np.ndarray:
        return np.concatenate(parts).astype(dtype) if parts else np.zeros(0, dtype=dtype)

    # static CSR ordered by (pre, projection, canonical index)
    s_pre = cat(st["pre"], np.int64)
    order = np.lexsort((cat(st["canon"], np.int64), cat(st["proj"], np.int64), s_pre))
    s_ptr = np.concatenate([[0], np.cumsum(np.bincount(s_pre, minlength=n))]).astype(np.int64)
    proj_static = _positions(order, st["proj"], static_names)
    # plastic CSR ordered by (pre, projection, delay, canonical index)
    p_pre = cat(pl["pre"], np.int64)
    p_projs = cat(pl["proj"], np.int64)
    p_d = cat(pl["d"], np.int64)
    porder = np.lexsort((cat(pl["canon"], np.int64), p_d, p_projs, p_pre))
    proj_plastic = _positions(porder, pl["proj"], plastic_names)
    p_pre_s, p_proj_s, p_d_s = p_pre[porder], p_projs[porder], p_d[porder]
    if p_pre_s.size:
        new_seg = np.ones(p_pre_s.size, dtype=bool)
        new_seg[1:] = (p_pre_s[1:] != p_pre_s[:-1]) | (p_proj_s[1:] != p_proj_s[:-1]) | (p_d_s[1:] != p_d_s[:-1])
        seg_first = np.flatnonzero(new_seg)
    else:
        seg_first = np.zeros(0, dtype=np.int64)
    seg_start = np.concatenate([seg_first, [p_pre_s.size]]).astype(np.int64)
    seg_delay = p_d_s[seg_first].astype(np.int64)
    seg_pre = p_pre_s[seg_first]
    row_seg_ptr = np.concatenate([[0], np.cumsum(np.bincount(seg_pre, minlength=n))]).astype(np.int64)
    p_post = cat(pl["post"], np.int64)[porder]
    post_order = np.argsort(p_post, kind="stable")
    post_ptr = np.concatenate([[0], np.cumsum(np.bincount(p_post, minlength=n))]).astype(np.int64)
    seg_of = np.repeat(np.arange(seg_first.size, dtype=np.int64), np.diff(seg_start))
    post_rule = np.full(n, -1, dtype=np.int64)
    if p_post.size:
        rule_of = p_proj_s[post_order]
        first_rule = rule_of[np.minimum(post_ptr[:-1], p_post.size - 1)]
        differs = np.bincount(p_post[post_order], weights=rule_of != first_rule[p_post[post_order]], minlength=n)
        post_rule = np.where(differs == 0, first_rule, -1).astype(np.int64)
    index = np.uint32 if max(n, p_post.size, seg_first.size) < 2**32 else np.int64
    # which post traces belong to each neuron
    tr_neuron = np.zeros(n_traces, dtype=np.int64)
    base = 0
    for proj_name in plastic_names:
        lo, hi = offsets[network.projections[proj_name].post]
        tr_neuron[base : base + hi - lo] = np.arange(lo, hi)
        base += hi - lo
    tr_order = np.argsort(tr_neuron, kind="stable")
    post_tr_ptr = np.concatenate([[0], np.cumsum(np.bincount(tr_neuron, minlength=n))]).astype(np.int64)
    s_post = cat(st["post"], np.int64)[order]
    s_w = cat(st["w"], np.float64)[order]
    s_delay = cat(st["d"], np.int64)[order]
    s_inh = cat(st["inh"], np.bool_)[order]
    delivery = split_static(n, s_ptr, s_post, s_w, s_delay, s_inh, merge(specs), proj_static)
    all_d = np.concatenate([cat(st["d"], np.int64), p_d, [1]])
    rule_table = np.ascontiguousarray(np.array(rules).reshape(-1, N_RULE_COLS))
    tr_rule = cat(trace_proj, np.int64)
    # exp(-k dt / tau_pre) for k < PRE_TABLE steps, per rule; per-step decay factors of the post traces
    pre_table = np.exp(-np.arange(PRE_TABLE)[None, :] * dt / rule_table[:, R_TAU_PRE][:, None]) if rules else np.ones((0, 1))
    pre_table = extend_pre_table(np.ascontiguousarray(pre_table), dt, np.ascontiguousarray(rule_table[:, R_TAU_PRE]))
    post_decay1 = np.exp(-dt / rule_table[tr_rule, R_TAU_POST]) if rules else np.zeros(0)
    tau2 = rule_table[tr_rule, R_TAU_POST2] if rules else np.zeros(0)
    post_decay2 = np.where(tau2 > 0, np.exp(-dt / np.where(tau2 > 0, tau2, 1.0)), 0.0)
    return Layout(
        n=n,
        offsets=offsets,
        kind=kind,
        params=params,
        groups=group_table,
        n_updated=int(np.sum(group_table[:, G_HI] - group_table[:, G_LO])),
        s_ptr=s_ptr,
        s_post=s_post,
        s_w=s_w,
        s_delay=s_delay,
        s_inh=s_inh,
        **delivery,
        row_seg_ptr=row_seg_ptr,
        seg_start=seg_start,
        seg_delay=seg_delay,
        seg_proj=p_proj_s[seg_first].astype(np.int64),
        p_post=p_post.astype(np.uint32) if n < 2**32 else p_post,
        p_w=cat(pl["w"], np.float64)[porder],
        post_ptr=post_ptr,
        post_syn=post_order.astype(index),
        post_seg=seg_of[post_order].astype(index),
        post_rule=post_rule,
        proj_inh=np.array(proj_inh, dtype=np.bool_),
        tr_lo=np.array(tr_lo, dtype=np.int64),
        tr_hi=np.array(tr_hi, dtype=np.int64),
        tr_shift=np.array(tr_shift, dtype=np.int64),
        post_tr_ptr=post_tr_ptr,
        post_tr_idx=tr_order.astype(np.int64),
        trace_proj=tr_rule,
        rules=rule_table,
        pre_table=np.ascontiguousarray(pre_table),
        post_decay1=post_decay1,
        post_decay2=post_decay2,
        n_traces=n_traces,
        ring=int(all_d.max()) + 2,
        proj_static=proj_static,
        proj_plastic=proj_plastic,
        proj_pre=proj_pre,
        proj_post=proj_post,
    )


@njit(cache=True)
def extend_pre_table(head: np.ndarray, dt: float, taus: np.ndarray) -> np.ndarray:
    """``head`` (``exp(-k dt / tau)`` per rule) extended with the factors the kernels compute past it.

    Each factor ``exp(-k * dt / tau)`` is evaluated one at a time, as the kernels'
    ``table_decay`` does past the table, so a look-up gives the same number. The table
    goes on until every rule's argument is below ``-PRE_ZERO`` (where ``exp`` is exactly
    0), for at most ``MAX_PRE_TABLE`` columns.
    """
    n_rules, width = head.shape
    need = width
    for r in range(n_rules):
        need = max(need, int(PRE_ZERO * taus[r] / dt) + 2)
    need = min(need, MAX_PRE_TABLE)
    table = np.zeros((n_rules, need))
    for r in range(n_rules):
        table[r, :width] = head[r]
        k = width
        while k < need:  # one call at a time (a loop with an exit is never vectorised)
            factor = np.exp(-k * dt / taus[r])
            if factor == 0.0:
                break
            table[r, k] = factor
            k += 1
    return table


def _flags(cell: object, inhibited: bool) -> int:
    """The group flags of a population of ``cell`` neurons (``inhibited``: it receives inhibitory synapses)."""
    flags = F_INH if inhibited else 0
    if isinstance(cell, IF_curr_exp_ca2_adaptive):
        flags |= F_CA
    if isinstance(cell, IF_cond_exp_adaptive):
        flags |= F_ADAPTIVE
    if euler_integrated(cell):
        flags |= F_EULER
    return flags


def _groups(lo: int, table: np.ndarray, kind: int, flags: int) -> np.ndarray:
    """Runs of consecutive neurons with identical parameters, as rows of the group table."""
    dynamics = np.delete(table, INIT_COLS, axis=1)
    first = np.concatenate([[0], 1 + np.flatnonzero(np.any(dynamics[1:] != dynamics[:-1], axis=1))])
    last = np.concatenate([first[1:], [table.shape[0]]])
    out = np.empty((first.size, N_GROUP_COLS), dtype=np.int64)
    out[:, G_LO], out[:, G_HI], out[:, G_KIND], out[:, G_FLAGS] = lo + first, lo + last, kind, flags
    return out


def _positions(order: np.ndarray, proj_parts: list[np.ndarray], names: list[str]) -> dict[str, np.ndarray]:
    """For each projection, the position in the sorted synapse arrays of each canonical connection."""
    inverse = np.empty_like(order)
    inverse[order] = np.arange(order.size)
    out, start = {}, 0
    for name, part in zip(names, proj_parts, strict=True):
        out[name] = inverse[start : start + part.size]
        start += part.size
    return out
