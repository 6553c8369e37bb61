"""Quantisation: a network's float layout in a chip's integer formats.

:func:`quantise` turns the float layout of :mod:`.translation` into a :class:`FixedLayout`
with every format parameter read from the hwspec's ``[formats]`` table: for Loihi 1, each
core block discretised as NengoLoihi's ``discretize_block`` does; for Loihi 2, each
population mapped as the ``lava-fixed`` backend hands it to Lava's ``fixed_pt`` models;
for SpiNNaker, sPyNNaker's host conversion (see :mod:`.fixed_point`, which runs the
result, and docs/number_formats.md).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import scipy.sparse

from neurovpr.backendkit import loihi2
from neurovpr.backendkit.lif import current_factor
from neurovpr.backendkit.params import per_neuron
from neurovpr.errors import UnsupportedFeatureError, ValidationError
from neurovpr.hardware.cores import Partition
from neurovpr.ir.cells import IF_cond_exp, IF_curr_exp_ca2_adaptive
from neurovpr.ir.connectors import ConvolutionConnector
from neurovpr.ir.network import Network

from . import kernels_fixed as kf

__all__ = ["FixedLayout", "quantise", "decay_magnitude", "COND_SHIFT"]


#: NengoLoihi's empirical mean loss of one truncating decay step (discretize.py decay_magnitude).
_DECAY_LOSS = 0.494
#: sPyNNaker scales conductance weights by 1024 = 2**10 (input_type_conductance.py get_global_weight_scale).
COND_SHIFT = 10
#: Synaptic filter (ms) NengoLoihi gives a block no connection sets one for (builder.py Model.decode_tau).
_DEFAULT_TAU_SYN = 5.0


@dataclass
class FixedLayout:
    """A network in a chip's integer formats, as the kernels of :mod:`.kernels_fixed` run it.

    ``variant`` is ``"loihi1"``, ``"loihi2"`` or ``"spinnaker"``; ``params`` the ``(N, K)``
    per-neuron integers (columns ``L_*`` or ``S_*`` of :mod:`.kernels_fixed`). Per static
    synapse (float layout order) ``s_val`` is what it adds to the delay ring and ``s_gp`` the
    ring column; for Loihi each column has a postsynaptic neuron ``gp_post`` and a shift
    ``gp_exp`` applied to its sum. ``v_unit`` is the mV of one voltage integer per neuron.
    ``blocks`` describes each Loihi core block (``population``, ``lo``, ``hi``, ``w_exp``,
    ``v_scale`` and the integer ``vth``, ``bias``, ``du``, ``dv``, ``ref``) or each SpiNNaker
    population (its shifts); ``weights[projection]`` holds per canonical connection the integer
    ``value`` (Loihi 1: the input after its exponent; Loihi 2: the 8-bit weight; SpiNNaker: the
    16-bit weight) and its ``exponent``.
    """

    variant: str
    params: np.ndarray
    s_val: np.ndarray
    s_gp: np.ndarray
    gp_post: np.ndarray
    gp_exp: np.ndarray
    n_gp: int
    v_unit: np.ndarray
    blocks: list[dict[str, Any]] = field(default_factory=list)
    weights: dict[str, dict[str, np.ndarray]] = field(default_factory=dict)


# -- what can be emulated -----------------------------------------------------------
def decay_magnitude(decay: np.ndarray, x0: float, bits: int, offset: int = 0) -> np.ndarray:
    """Sum of the truncated integer decays of ``x0`` relative to ``x0`` (NengoLoihi's ``decay_magnitude``)."""
    r = (2**bits - offset - np.asarray(decay)) / 2**bits
    n = -(np.log1p(x0 * (1 - r) / _DECAY_LOSS)) / np.log(r)
    principal = (1 - r ** (n + 1)) / (1 - r)
    loss = _DECAY_LOSS / ((1 - r) * x0) * (n + 1 - (1 - r ** (n + 1)) / (1 - r))
    return principal - loss


def _kappa_scale(tau_syn: float, tau_m: float, dt: float) -> float:
    """``kappa dt_s / (1 - e_s)``: a weight (nA) to the compartment input of one spike of height ``1 / dt_s``."""
    return current_factor(tau_syn, tau_m, dt) * (dt / 1000.0) / (1.0 - math.exp(-dt / tau_syn))


def _float_weights(network: Network, lay: Any, dt: float, gains: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """Per projection, NengoLoihi's float32 weight of each static synapse (duplicates summed into the first)."""
    dt_s = dt / 1000.0
    out = {}
    for name, pos in lay.proj_static.items():
        proj = network.projections[name]
        cell = network.populations[proj.post].cell_type
        tau_m = float(np.asarray(cell.tau_m).flat[0])
        tau_s = float(np.asarray(cell.tau_syn_E if proj.receptor_type == "excitatory" else cell.tau_syn_I).flat[0])
        scale = (1.0 if proj.receptor_type == "excitatory" else -1.0) * _kappa_scale(tau_s, tau_m, dt)
        post = lay.proj_post[name]
        pairs = np.stack([lay.s_delay[pos], lay.proj_pre[name], post], axis=1)
        first, inverse = np.unique(pairs, axis=0, return_index=True, return_inverse=True)[1:]
        inverse = inverse.reshape(-1)
        summed = np.zeros(first.size)
        np.add.at(summed, inverse, lay.s_w[pos] * scale)
        w = np.zeros(pos.size)
        if isinstance(proj.connector, ConvolutionConnector):
            w[first] = summed / dt_s * gains[proj.post][post[first]]
        else:
            w[first] = summed * (1.0 / dt_s) * gains[proj.post][post[first]]
        out[name] = w.astype(np.float32)
    return out


def _discretize_block(fmt: Any, vth: np.ndarray, bias: np.ndarray, du: np.ndarray, dv: np.ndarray,
                      w_max: np.float32, where: str) -> dict[str, Any]:  # fmt: skip
    """NengoLoihi's ``discretize_compartment`` with the limits of ``fmt``: scales, threshold and bias integers."""
    acc = 2**fmt.accumulator_bits
    u_inf = 1.0 / decay_magnitude(du, x0=acc, bits=fmt.decay_bits, offset=1)
    v_inf = 1.0 / decay_magnitude(dv, x0=acc, bits=fmt.decay_bits)
    vth_max = (2**fmt.threshold_mantissa_bits - 1) * 2**fmt.threshold_exponent
    bias_max = (2**fmt.bias_mantissa_bits - 1) * 2**fmt.bias_exponent_max
    w_exp = 0
    if w_max > 1e-8:
        w_scale: Any = float(2**fmt.weight_bits - 1) / w_max
        s_scale = 1.0 / (u_inf * v_inf)
        for w_exp in range(0, fmt.weight_exponent_min - 1, -1):
            v_scale = s_scale * w_scale * 2 ** (fmt.weight_exponent_offset + w_exp)
            b_scale = v_scale * v_inf
            vth_i = np.round(vth * v_scale)
            bias_i = np.round(bias * b_scale)
            if (vth_i <= vth_max).all() and (np.abs(bias_i) <= bias_max).all():
                break
        else:
            raise ValidationError(f"{where}: no weight exponent fits the threshold and bias in Loihi's formats.")
    elif np.abs(bias).max() > 1e-8:
        b_scale = bias_max / np.abs(bias).max()
        while b_scale * np.abs(bias).max() > 1:
            v_scale = b_scale / v_inf
            w_scale = b_scale * u_inf / 2**fmt.weight_exponent_offset
            vth_i = np.round(vth * v_scale)
            bias_i = np.round(bias * b_scale)
            if np.all(vth_i <= vth_max):
                break
            b_scale /= 2.0
        else:
            raise ValidationError(f"{where}: no bias scaling fits the threshold in Loihi's formats.")
    else:
        vth_max = min(vth_max, 2**fmt.accumulator_bits - 1)
        v_scale = np.array([vth_max / (vth.max() + 1)])
        vth_i = np.round(vth * v_scale)
        b_scale = v_scale * v_inf
        bias_i = np.round(bias * b_scale)
        w_scale = v_scale * v_inf * u_inf / 2**fmt.weight_exponent_offset
    vth_man = np.round(vth_i / 2**fmt.threshold_exponent).astype(np.int64)
    if not ((vth_man > 0).all() and (vth_man < 2**fmt.threshold_mantissa_bits).all()):
        raise ValidationError(f"{where}: threshold mantissa {vth_man.max()} is outside 1..{2**fmt.threshold_mantissa_bits - 1}.")
    r = np.maximum(np.abs(bias_i) / (2**fmt.bias_mantissa_bits - 1), 1)
    b_exp = np.ceil(np.log2(r)).astype(np.int64)
    b_man = np.round(bias_i / 2.0**b_exp).astype(np.int64)
    v_scale = np.broadcast_to(v_scale, vth.shape)
    if not np.all(v_scale == v_scale[0]):
        raise ValidationError(f"{where}: neurons of one core block need one voltage scale.")
    return {"w_exp": w_exp, "w_scale": w_scale, "v_scale": float(v_scale[0]), "vth_man": vth_man,
            "vth": vth_man << fmt.threshold_exponent, "bias_man": b_man, "bias_exp": b_exp, "bias": b_man << b_exp}  # fmt: skip


def _discretize_weights(fmt: Any, w: np.ndarray, w_exp2: int) -> np.ndarray:
    """NengoLoihi's ``discretize_weights``: the input each weight adds after its exponent."""
    s = fmt.weight_bits - fmt.weight_mantissa_bits  # low bits lost to the sign of mixed-sign weights
    m = 2**fmt.weight_mantissa_bits - 1
    mant = np.round(w / np.float32(2.0**s)).clip(-m, m).astype(np.int64)
    s2 = s + w_exp2
    lossy = mant
    if s2 < 0:
        lossy = (np.round(mant * 2.0**s2) / 2**s2).clip(-m, m).astype(np.int64)
    return (lossy << s2 if s2 >= 0 else lossy >> -s2) << fmt.weight_exponent_offset


def _synapse_groups(lay: Any) -> np.ndarray:
    """Each static synapse's synapse group, one weight exponent each: a (projection, delay) pair."""
    s_group = np.zeros(lay.s_w.size, dtype=np.int64)
    for pos in lay.proj_static.values():
        s_group[pos] = s_group.max(initial=-1) + 1 + np.unique(lay.s_delay[pos], return_inverse=True)[1]
    return s_group


def _set_voltage_range(params: np.ndarray, rows: np.ndarray, fmt: Any) -> None:
    """Mark ``rows`` as compartments with ``v`` saturating at ``voltage_bits`` (their initial ``v`` too)."""
    params[rows, kf.L_VMIN] = -(2 ** (fmt.voltage_bits - 1)) + 1
    params[rows, kf.L_VMAX] = 2 ** (fmt.voltage_bits - 1) - 1
    params[rows, kf.L_ACTIVE] = 1
    params[rows, kf.L_V_INIT] = np.clip(params[rows, kf.L_V_INIT], params[rows, kf.L_VMIN], params[rows, kf.L_VMAX])


def _quantise_loihi1(network: Network, spec: Any, lay: Any, dt: float, partition: Partition) -> FixedLayout:
    """Loihi 1: each core block of ``partition`` discretised as NengoLoihi's ``discretize_block``."""
    fmt = spec.formats
    n = lay.n
    dt_s = dt / 1000.0
    params = np.zeros((n, kf.N_LOIHI_COLS), dtype=np.int64)
    v_unit = np.zeros(n)
    gains = {pop.name: loihi2.gain(pop) for pop in network.populations.values() if not pop.is_source}
    fw = _float_weights(network, lay, dt, gains)
    s_group = _synapse_groups(lay)
    s_fw = np.zeros(lay.s_w.size, dtype=np.float32)
    for name, pos in lay.proj_static.items():
        s_fw[pos] = fw[name]
    s_val = np.zeros(lay.s_w.size, dtype=np.int64)
    s_exp = np.zeros(lay.s_w.size, dtype=np.int64)
    blocks: list[dict[str, Any]] = []
    cores = partition.cores
    for pop in network.populations.values():
        if pop.is_source:
            continue
        c, size, off = pop.cell_type, pop.size, lay.offsets[pop.name][0]
        slices = [(s.lo, s.hi) for s in cores if s.population == pop.name and s.kind == "neurons"] or [(0, size)]
        reset, thresh = per_neuron(c.v_reset, size), per_neuron(c.v_thresh, size)
        bias64 = gains[pop.name] * per_neuron(c.i_offset, size) + (per_neuron(c.v_rest, size) - reset) / (thresh - reset)
        kinds = {p.receptor_type for p in network.projections.values() if p.post == pop.name}
        tau_s = float(np.asarray(c.tau_syn_I if kinds == {"inhibitory"} else c.tau_syn_E).flat[0])
        tau_s = tau_s if kinds else _DEFAULT_TAU_SYN
        decay_u = np.full(size, -(np.expm1(-dt_s / (tau_s / 1000.0))), dtype=np.float32)
        decay_v = np.full(size, -(np.expm1(-dt_s / (float(np.asarray(c.tau_m).flat[0]) / 1000.0))), dtype=np.float32)
        limit = 0.5 / 2**fmt.decay_bits
        if decay_u[0] <= limit or decay_v[0] <= limit:
            raise ValidationError(
                f"Population {pop.name!r}: a time constant is too long for Loihi's {fmt.decay_bits}-bit decays at "
                f"dt={dt:g} ms (decay per step below {limit:g})."
            )
        max_decay = 2**fmt.decay_bits - 1
        du = np.round(np.clip(decay_u * max_decay - 1, 0, max_decay)).astype(np.int64)
        dv = np.round(decay_v * max_decay).astype(np.int64)
        ref = np.round(per_neuron(c.tau_refrac, size) / 1000.0 / dt_s) + 1
        v0 = (per_neuron(c.v_rest if pop.v_init is None else pop.v_init, size) - reset) / (thresh - reset)
        for lo, hi in slices:
            glob = np.arange(off + lo, off + hi)
            syn = np.flatnonzero((lay.s_post >= off + lo) & (lay.s_post < off + hi))
            grp_ids = np.unique(s_group[syn])
            g_max = {g: np.abs(s_fw[syn[s_group[syn] == g]]).max() for g in grp_ids}
            w_max = max(g_max.values()) if g_max else np.float32(0.0)
            info = _discretize_block(fmt, np.ones(hi - lo, dtype=np.float32), bias64[lo:hi].astype(np.float32),
                                     du[lo:hi], dv[lo:hi], w_max, f"Population {pop.name!r} neurons {lo}..{hi - 1}")  # fmt: skip
            for g in grp_ids:
                sel = syn[s_group[syn] == g]
                if g_max[g] > 1e-16:
                    dw = int(np.floor(np.log2(w_max / g_max[g])))
                    w_exp2 = max(info["w_exp"] - dw, -fmt.weight_exponent_offset)
                else:
                    w_exp2 = -fmt.weight_exponent_offset
                    dw = info["w_exp"] - w_exp2
                ws = info["w_scale"]
                ws = ws[lay.s_post[sel] - off - lo] if np.ndim(ws) else ws
                s_val[sel], s_exp[sel] = _discretize_weights(fmt, s_fw[sel] * ws * 2**dw, w_exp2), w_exp2
            params[glob, kf.L_RU] = 2**fmt.decay_bits - 1 - du[lo:hi]
            params[glob, kf.L_RV] = 2**fmt.decay_bits - dv[lo:hi]
            params[glob, kf.L_BIAS] = info["bias"]
            params[glob, kf.L_VTH] = info["vth"]
            params[glob, kf.L_REF] = ref[lo:hi].astype(np.int64)
            params[glob, kf.L_V_INIT] = np.round(v0[lo:hi] * info["v_scale"]).astype(np.int64)
            v_unit[glob] = (thresh[lo:hi] - reset[lo:hi]) / info["v_scale"]
            blocks.append({"population": pop.name, "lo": lo, "hi": hi, "du": du[lo:hi], "dv": dv[lo:hi],
                           "ref": ref[lo:hi].astype(np.int64), **{k: v for k, v in info.items() if k != "w_scale"}})  # fmt: skip
        _set_voltage_range(params, np.arange(off, off + size), fmt)
    weights = {name: {"value": s_val[pos], "exponent": s_exp[pos]} for name, pos in lay.proj_static.items()}
    s_gp, gp_post, _, n_gp = _ring_columns(s_group, s_exp, lay.s_post, lay.n)
    return FixedLayout(variant="loihi1", params=params, s_val=s_val, s_gp=s_gp, gp_post=gp_post,
                       gp_exp=np.zeros(n_gp, dtype=np.int64), n_gp=n_gp, v_unit=v_unit, blocks=blocks,
                       weights=weights)  # fmt: skip


def _ring_columns(
    s_group: np.ndarray, s_exp: np.ndarray, s_post: np.ndarray, n: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
    """Delay-ring columns, one per (synapse group, postsynaptic neuron): each synapse's column, and per column
    its neuron and its group's exponent, and the number of columns."""
    uniq, s_gp = np.unique(s_group * n + s_post, return_inverse=True)
    first = np.zeros(uniq.size, dtype=np.int64)
    first[s_gp] = np.arange(s_gp.size)
    gp_post = uniq % n if n else uniq
    return s_gp.reshape(-1).astype(np.int64), gp_post.astype(np.int64), s_exp[first].astype(np.int64), int(uniq.size)


# -- Loihi 2 ------------------------------------------------------------------------
def _quantise_loihi2(network: Network, spec: Any, lay: Any, dt: float) -> FixedLayout:
    """Loihi 2: each population as the ``lava-fixed`` backend maps it (:mod:`neurovpr.backendkit.loihi2`), one weight
    exponent per synapse group (one Lava synapse process per projection and delay)."""
    fmt = spec.formats
    params = np.zeros((lay.n, kf.N_LOIHI_COLS), dtype=np.int64)
    v_unit = np.zeros(lay.n)
    s_group = _synapse_groups(lay)
    s_val = np.zeros(lay.s_w.size, dtype=np.int64)
    s_exp = np.zeros(lay.s_w.size, dtype=np.int64)
    blocks: list[dict[str, Any]] = []
    for pop in network.populations.values():
        if pop.is_source:
            continue
        projs = [p for p in network.projections.values() if p.post == pop.name]
        lif = loihi2.lif_integers(pop, dt, fmt, inhibitory_only={p.receptor_type for p in projs} == {"inhibitory"})
        rows = np.arange(lay.offsets[pop.name][0], lay.offsets[pop.name][1])
        for col, value in ((kf.L_RU, lif.ru), (kf.L_RV, lif.rv), (kf.L_BIAS, lif.bias_int), (kf.L_VTH, lif.vth),
                           (kf.L_REF, lif.ref), (kf.L_V_INIT, lif.v_init)):  # fmt: skip
            params[rows, col] = value
        _set_voltage_range(params, rows, fmt)
        v_unit[rows] = lif.v_unit
        full = np.ones(pop.size, dtype=np.int64)
        blocks.append({"population": pop.name, "lo": 0, "hi": pop.size, "du": lif.du * full, "dv": lif.dv * full,
                       "ref": lif.ref, "v_scale": lif.v_scale, "vth_man": lif.vth_man * full, "vth": lif.vth * full,
                       "bias_man": lif.bias_man, "bias_exp": lif.bias_exp, "bias": lif.bias_int})  # fmt: skip
        for proj in projs:
            pos = lay.proj_static[proj.name]
            pre, post = lay.proj_pre[proj.name], lay.proj_post[proj.name]
            n_pre = network.populations[proj.pre].size
            values = lay.s_w[pos] * loihi2.weight_scale(pop, proj.receptor_type, dt)[post]
            for g in np.unique(s_group[pos]):
                sel = np.flatnonzero(s_group[pos] == g)
                # duplicates of a (pre, post) pair summed as the lava-fixed backend sums them (a scipy CSR matrix)
                matrix = scipy.sparse.coo_matrix((values[sel], (post[sel], pre[sel])), shape=(pop.size, n_pre)).tocsr()
                matrix.sum_duplicates()
                first = sel[np.unique(post[sel] * n_pre + pre[sel], return_index=True)[1]]
                summed = np.asarray(matrix[post[first], pre[first]], dtype=np.float64).reshape(-1)
                where = f"Projection {proj.name!r} (delay {int(lay.s_delay[pos[sel[0]]]) * dt:g} ms)"
                quant = loihi2.weight_integers(summed * lif.vth_man, fmt, where=where)
                s_val[pos[first]], s_exp[pos[sel]] = quant.mantissa, quant.exp
    weights = {name: {"value": s_val[pos], "exponent": s_exp[pos]} for name, pos in lay.proj_static.items()}
    s_gp, gp_post, gp_exp, n_gp = _ring_columns(s_group, s_exp, lay.s_post, lay.n)
    return FixedLayout(variant="loihi2", params=params, s_val=s_val, s_gp=s_gp, gp_post=gp_post, gp_exp=gp_exp,
                       n_gp=n_gp, v_unit=v_unit, blocks=blocks, weights=weights)  # fmt: skip


# -- SpiNNaker ------------------------------------------------------------------------
def _ring_shift(total: float, fmt: Any, where: str) -> int:
    """sPyNNaker's ``get_ring_buffer_shifts`` for one synapse type: bits above the largest summed weight."""
    power = 0 if total <= 0 else math.ceil(max(0.0, math.log2(total)))
    if total > 0 and 2**power <= total:
        power += 1
    if not fmt.weight_exponent_min <= power <= fmt.weight_exponent_max:
        raise ValidationError(
            f"{where}: largest summed weight {total:g} needs a ring-buffer shift of {power}, outside "
            f"{fmt.weight_exponent_min}..{fmt.weight_exponent_max}."
        )
    return power


def _quantise_spinnaker(network: Network, spec: Any, lay: Any, dt: float) -> FixedLayout:
    fmt = spec.formats
    fr = fmt.fraction_bits
    n = lay.n
    params = np.zeros((n, kf.N_SPINN_COLS), dtype=np.int64)
    s_val = np.zeros(lay.s_w.size, dtype=np.int64)
    blocks: list[dict[str, Any]] = []
    weights: dict[str, dict[str, np.ndarray]] = {}
    ts = kf.to_fixed(dt, fr)
    for pop in network.populations.values():
        if pop.is_source:
            continue
        c, size, off = pop.cell_type, pop.size, lay.offsets[pop.name][0]
        rows = np.arange(off, off + size)
        p = {name: kf.to_fixed(per_neuron(getattr(c, name), size), fr)
             for name in ("v_rest", "v_reset", "v_thresh", "i_offset", "cm", "tau_m", "tau_refrac", "tau_syn_E",
                          "tau_syn_I")}  # fmt: skip
        params[rows, kf.S_V_REST], params[rows, kf.S_V_RESET] = p["v_rest"], p["v_reset"]
        params[rows, kf.S_V_THRESH], params[rows, kf.S_I_OFFSET] = p["v_thresh"], p["i_offset"]
        params[rows, kf.S_V_INIT] = kf.to_fixed(per_neuron(c.v_rest if pop.v_init is None else pop.v_init, size), fr)
        params[rows, kf.S_R] = kf.div_fixed(p["tau_m"], p["cm"], fr)
        params[rows, kf.S_EXP_TC] = kf.exp_fixed(-kf.div_fixed(ts, p["tau_m"], fr), fr, fr)
        params[rows, kf.S_T_REFRACT] = kf.ceil_fixed(kf.div_fixed(p["tau_refrac"], ts, fr), fr)
        for tau, dcol, icol in (("tau_syn_E", kf.S_DEC_E, kf.S_INIT_E), ("tau_syn_I", kf.S_DEC_I, kf.S_INIT_I)):
            decay = kf.exp_fixed(-kf.div_fixed(ts, p[tau], fr), fr, fmt.decay_bits)
            inv = (2**fmt.decay_bits - 1) - decay  # 1.0ulr saturates to the largest u0.32
            params[rows, dcol] = decay
            params[rows, icol] = (kf.div_fixed(p[tau], ts, fr) * inv) >> fr
        params[rows, kf.S_EXP_CA] = 2**fr  # no Ca2+ current: a decay of 1
        if isinstance(c, IF_curr_exp_ca2_adaptive):
            params[rows, kf.S_EXP_CA] = kf.exp_fixed(-kf.div_fixed(ts, kf.to_fixed(per_neuron(c.tau_ca2, size), fr), fr), fr, fr)
            params[rows, kf.S_I_ALPHA] = kf.to_fixed(per_neuron(c.i_alpha, size), fr)
            params[rows, kf.S_I_CA_INIT] = kf.to_fixed(per_neuron(c.i_ca2, size), fr)
        cond = isinstance(c, IF_cond_exp)
        if cond:
            params[rows, kf.S_COND] = 1
            params[rows, kf.S_E_REV_E] = kf.to_fixed(per_neuron(c.e_rev_E, size), fr)
            params[rows, kf.S_E_REV_I] = kf.to_fixed(per_neuron(c.e_rev_I, size), fr)
        params[rows, kf.S_ACTIVE] = 1
        global_scale = 2.0**COND_SHIFT if cond else 1.0
        shifts = {}
        for kind, col in (("excitatory", kf.S_SHIFT_E), ("inhibitory", kf.S_SHIFT_I)):
            names = [q.name for q in network.projections.values() if q.post == pop.name and q.receptor_type == kind]
            total = 0.0
            for name in names:
                pos = lay.proj_static[name]
                if pos.size and lay.s_w[pos].min() < 0:
                    raise UnsupportedFeatureError(
                        f"Hardware emulation of {spec.name!r} cannot run projection {name!r} with negative weights "
                        f"(min {lay.s_w[pos].min():g}): sPyNNaker keeps weight magnitudes, the receptor type gives the sign."
                    )
                if pos.size:
                    fan_in = np.bincount(lay.proj_post[name], minlength=size).max()
                    total += float(np.abs(lay.s_w[pos]).max()) * global_scale * fan_in
            shift = _ring_shift(total, fmt, f"Population {pop.name!r} {kind} input")
            params[rows, col] = shift
            shifts[kind] = shift
            for name in names:
                pos = lay.proj_static[name]
                scale = 2.0 ** (-(shift + fmt.weight_exponent_offset)) * global_scale
                s_val[pos] = np.rint(np.abs(lay.s_w[pos] * scale)).astype(np.int64) & (2**fmt.weight_bits - 1)
                weights[name] = {"value": s_val[pos], "exponent": np.full(pos.size, shift)}
        blocks.append({"population": pop.name, "shift_excitatory": shifts["excitatory"],
                       "shift_inhibitory": shifts["inhibitory"], "conductance": cond})  # fmt: skip
    s_gp = 2 * lay.s_post + lay.s_inh.astype(np.int64)
    v_unit = np.full(n, 2.0**-fr)
    return FixedLayout(variant="spinnaker", params=params, s_val=s_val, s_gp=s_gp, gp_post=np.zeros(0, np.int64),
                       gp_exp=np.zeros(0, np.int64), n_gp=2 * n, v_unit=v_unit, blocks=blocks, weights=weights)  # fmt: skip


def quantise(network: Network, spec: Any, lay: Any, *, dt: float, partition: Partition) -> FixedLayout:
    """Quantise the float layout ``lay`` of ``network`` into ``spec``'s formats.

    Parameters
    ----------
    network, lay
        The network and its float layout (:func:`.translation.build_layout`).
    spec
        A loaded hwspec whose ``[formats].arithmetic`` the backend emulates.
    dt
        Time step (ms).
    partition
        The compile's partition of ``network`` on ``spec`` (its core blocks are discretised one by one).

    Returns
    -------
    FixedLayout
        The integer network.
    """
    variant = spec.formats.arithmetic
    if variant == "spinnaker":
        return _quantise_spinnaker(network, spec, lay, dt)
    if variant == "loihi2":
        return _quantise_loihi2(network, spec, lay, dt)
    return _quantise_loihi1(network, spec, lay, dt, partition)


# -- simulation -----------------------------------------------------------------------
