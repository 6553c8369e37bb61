"""Compiled step loops of the reference backend in a chip's integer formats.

Two loops share the source handling, spike recording and delay rings of the float
loop (:mod:`.kernels`); their neurons compute only with integers:

* :func:`run_loihi`: the Loihi compartment (``u`` current, ``v`` voltage, 12-bit
  decays that truncate toward zero, 24-bit state, threshold and refractoriness as
  NengoLoihi's emulator and Lava's bit-accurate models compute them). ``variant``
  selects the Loihi 1 conventions of NengoLoihi (``LOIHI1``: weight exponent applied to
  each weight, synaptic accumulator and ``u + bias`` wrap) or the Loihi 2 ones of Lava
  (``LOIHI2``: exponent applied to the summed input of each synapse group, no wrap of
  ``u + bias``).
* :func:`run_spinnaker`: sPyNNaker's LIF neuron in s16.15 (``accum``) with u0.32 decays,
  16-bit saturating ring buffers shifted left per synapse type, exponential synapses
  scaled by their ``init`` factor, the Ca2+ adaptation current and conductance input.

Step ``j`` follows docs/semantics.md for timing (sources emit at ``j``, a neuron
crossing threshold in step ``j`` emits at ``j + 1``, an input arrives ``delay`` steps
after its stamp and acts from the step starting then); inside a step the order is the
chip's. The scalar helpers below are the chips' arithmetic, also used by the quantiser
and tested on their own.
"""

from __future__ import annotations

from collections import namedtuple
from collections.abc import Callable

import numpy as np
from numba import njit

from .kernel_cache import source_stamp
from .kernel_delivery import record_spike
from .kernel_layout import NEVER, ST_NEURON_UPDATES, ST_STEPS, ST_SYN_EVENTS
from .kernel_sources import geometric_gap

#: The modules whose code the step loops below are made of (numba caches them under a hash of
#: all these files, see :mod:`.kernel_cache`).
CACHE_UNIT = ("kernels_fixed", "kernel_layout", "kernel_sources", "kernel_delivery")

# The arrays the loops work on, bundled by role (with :mod:`.kernel_layout`'s ``Sources``,
# ``SpikeRecord`` and ``VarRecord``).
#: Static synapses: per neuron its synapses (CSR pointer), each one's ring column
#: (synapse group), integer value and delay in steps.
FixedSynapses = namedtuple("FixedSynapses", "ptr gp val delay")
#: The Loihi arithmetic: ``LOIHI1`` or ``LOIHI2``, bits of the decay factors, the accumulator
#: and the current, and the shift of the synaptic input (Loihi 2's weight exponent offset).
LoihiFormats = namedtuple("LoihiFormats", "variant decay_bits acc_bits u_bits act_shift")
#: Loihi compartment state: current, voltage, refractory steps, input of this step.
LoihiState = namedtuple("LoihiState", "u v ref q")
#: Loihi synapse groups: the neuron each feeds and its weight exponent.
SynapseGroups = namedtuple("SynapseGroups", "post exp")
#: The SpiNNaker arithmetic: fraction bits of ``accum``, the ring buffer's saturation and the
#: right shift of conductance input.
SpinnakerFormats = namedtuple("SpinnakerFormats", "frac acc_max cond_shift")
#: sPyNNaker LIF state: membrane, excitatory and inhibitory input, Ca2+ current, refractory timer.
SpinnakerState = namedtuple("SpinnakerState", "v isyn_e isyn_i ica refr")

#: Loihi arithmetic variants.
LOIHI1, LOIHI2 = 0, 1

# Columns of the Loihi per-neuron table.
(L_RU, L_RV, L_BIAS, L_VTH, L_REF, L_V_INIT, L_VMIN, L_VMAX, L_ACTIVE, N_LOIHI_COLS) = range(10)

# Columns of the SpiNNaker per-neuron table (raw s16.15 unless noted).
(
    S_V_REST,
    S_V_RESET,
    S_V_THRESH,
    S_I_OFFSET,
    S_R,
    S_EXP_TC,
    S_T_REFRACT,  # steps
    S_DEC_E,  # u0.32
    S_INIT_E,  # u0.32
    S_DEC_I,
    S_INIT_I,
    S_EXP_CA,
    S_I_ALPHA,
    S_E_REV_E,
    S_E_REV_I,
    S_COND,  # 1 for conductance input
    S_V_INIT,
    S_I_CA_INIT,
    S_SHIFT_E,  # ring-buffer left shift (bits)
    S_SHIFT_I,
    S_ACTIVE,  # 1 for a neuron, 0 for a source
    N_SPINN_COLS,
) = range(22)

_INT32_MIN = -(2**31)
_INT32_MAX = 2**31 - 1


# -- Loihi arithmetic -------------------------------------------------------------
@njit(cache=True, inline="always")
def decay_toward_zero(x: int, r: int, bits: int) -> int:
    """``sign(x) floor(|x| r / 2**bits)``: Loihi's decay of ``u`` and ``v`` by the factor ``r / 2**bits``."""
    if x >= 0:
        return (x * r) >> bits
    return -(((-x) * r) >> bits)


@njit(cache=True, inline="always")
def wrap_signed(x: int, bits: int) -> int:
    """Two's-complement overflow of ``x`` into ``bits`` magnitude bits and a sign (NengoLoihi's ``overflow_signed``)."""
    sign = np.int64(1) << bits
    return (x & (sign - 1)) - (x & sign)


@njit(cache=True, inline="always")
def wrap_lava(x: int, bits: int) -> int:
    """Lava's wrap of the 24-bit current: values above ``2**bits`` or at/below ``-2**bits`` move by ``2**(bits+1)``."""
    top = np.int64(1) << bits
    if x > top:
        return x - 2 * top
    if x <= -top:
        return x + 2 * top
    return x


@njit(cache=True, inline="always")
def shift_floor(x: int, s: int) -> int:
    """``x * 2**s`` for ``s >= 0``, ``floor(x / 2**-s)`` for ``s < 0`` (an arithmetic shift)."""
    if s >= 0:
        return x << s
    return x >> (-s)


# -- s16.15 arithmetic (sPyNNaker, spinn_common stdfix) -------------------------------
@njit(cache=True, inline="always")
def sat32(x: int) -> int:
    """Saturate to the 32-bit ``accum`` range."""
    if x > _INT32_MAX:
        return _INT32_MAX
    if x < _INT32_MIN:
        return _INT32_MIN
    return x


@njit(cache=True, inline="always")
def wrap32(x: int) -> int:
    """Two's-complement wrap to 32 bits (``accum`` addition does not saturate)."""
    return ((x + 2**31) & 0xFFFFFFFF) - 2**31


@njit(cache=True, inline="always")
def mul_round(a: int, b: int, frac: int) -> int:
    """``MULT_ROUND_NEAREST_ACCUM``: product of two fixed-point raws, round half up, saturated."""
    if a == _INT32_MIN and b == _INT32_MIN:
        return _INT32_MAX
    return sat32((a * b + (np.int64(1) << (frac - 1))) >> frac)


@njit(cache=True, inline="always")
def mul_trunc(a: int, b: int, frac: int) -> int:
    """Plain ``accum * accum``: product shifted right (rounded toward minus infinity)."""
    return sat32((a * b) >> frac)


@njit(cache=True, inline="always")
def decay_u032(x: int, d: int) -> int:
    """``decay_s1615``: an s16.15 raw times a u0.32 raw, ``(x d) >> 32``."""
    return (x * d) >> 32


def to_fixed(value: float | np.ndarray, frac: int) -> np.ndarray:
    """Host-side conversion to a fixed-point raw, rounded to nearest (sPyNNaker's ``DataType`` encoding)."""
    return np.rint(np.asarray(value, dtype=np.float64) * 2.0**frac).astype(np.int64)


def div_fixed(a: np.ndarray, b: np.ndarray, frac: int) -> np.ndarray:
    """``kdivk``: fixed-point quotient of raws, truncated toward zero."""
    num = np.asarray(a, dtype=np.int64) << frac
    den = np.asarray(b, dtype=np.int64)
    q = np.abs(num) // np.abs(den)
    return np.where((num < 0) != (den < 0), -q, q)


def exp_fixed(x_raw: np.ndarray, frac: int, out_frac: int) -> np.ndarray:
    """``exp`` of a fixed-point raw (``frac`` bits) as a raw with ``out_frac`` bits, rounded to nearest.

    Stands for the core's ``expk`` (``out_frac = frac``) and ``expulr`` (``out_frac = 32``,
    capped below 1); both are taken as correctly rounded.
    """
    y = np.rint(np.exp(np.asarray(x_raw, dtype=np.float64) / 2.0**frac) * 2.0**out_frac).astype(np.int64)
    return np.minimum(y, (1 << out_frac) - 1) if out_frac == 32 else y


def ceil_fixed(x_raw: np.ndarray, frac: int) -> np.ndarray:
    """``lif_ceil_accum``: the ceiling of a fixed-point raw, as an integer."""
    x = np.asarray(x_raw, dtype=np.int64)
    return (x >> frac) + ((x & ((1 << frac) - 1)) > 0)


# -- shared mechanics (compiled into the loops, not cached on their own) -----------------
@njit
def _emit(i, stamp, counts, stats, record, syn, acc, acc_max):
    """Record the spike of ``i`` stamped ``stamp`` and add its synapses' values to the delay ring.

    ``record`` and ``syn`` are a ``SpikeRecord`` and a :class:`FixedSynapses`; a sum above
    ``acc_max`` saturates there (no saturation when ``acc_max`` is 0).
    """
    record_spike(i, stamp, counts, stats, record)
    s_ptr, s_gp, s_val, s_delay = syn
    ring = acc.shape[0]
    for k in range(s_ptr[i], s_ptr[i + 1]):
        slot = (stamp + s_delay[k]) % ring
        x = acc[slot, s_gp[k]] + s_val[k]
        if acc_max > 0 and x > acc_max:
            x = acc_max
        acc[slot, s_gp[k]] = x
    stats[ST_SYN_EVENTS] += s_ptr[i + 1] - s_ptr[i]


@njit
def _sources(j, sources, counts, stats, record, syn, acc, acc_max):
    """Emit the Poisson and array spikes of step ``j`` (the draws of :func:`.kernels.run_steps`) through :func:`_emit`."""
    nxt, rng = sources.pois_next, sources.rng
    for k in range(nxt.size):
        if nxt[k] == j:
            if sources.pois_start[k] <= j < sources.pois_end[k]:
                _emit(sources.pois_idx[k], j, counts, stats, record, syn, acc, acc_max)
            g = geometric_gap(rng, sources.pois_logq[k])
            nxt[k] = NEVER if g == NEVER else j + 1 + g
        elif nxt[k] < j:
            g = geometric_gap(rng, sources.pois_logq[k])
            nxt[k] = NEVER if g == NEVER else j + g
    arr_step, arr_neuron, arr_ptr = sources.arr_step, sources.arr_neuron, sources.arr_ptr
    while arr_ptr[0] < arr_step.size and arr_step[arr_ptr[0]] <= j:
        if arr_step[arr_ptr[0]] == j:
            _emit(arr_neuron[arr_ptr[0]], j, counts, stats, record, syn, acc, acc_max)
        arr_ptr[0] += 1


# -- Loihi ---------------------------------------------------------------------------
_STAMP = source_stamp(__file__, CACHE_UNIT)


def _loihi_loop(stamp: int) -> Callable[..., int]:
    """The Loihi step loop, cached under ``stamp`` (:func:`.kernel_cache.source_stamp` of ``CACHE_UNIT``)."""

    @njit(cache=True)
    def run_loihi(j0, j1, formats, params, state, groups, counts, syn, acc, sources, record, headroom, var, stats):
        """Advance Loihi compartments from step ``j0`` to ``j1``; return the step reached.

        Per step: the synaptic input of every synapse group arriving now is shifted by
        its weight exponent (per group for ``LOIHI2``; already applied per weight for
        ``LOIHI1``) and by ``act_shift``; then ``u = decay(u) + input``, ``v = decay(v) + u +
        bias`` (with the variant's overflow rules), ``v`` held at 0 while refractory, a
        spike when ``v > vth`` (then ``v = 0`` and ``ref - 1`` refractory steps). ``formats``,
        ``state`` and ``groups`` are a :class:`LoihiFormats`, :class:`LoihiState` and
        :class:`SynapseGroups`; ``params`` has the ``L_*`` columns; the recorded variable is ``v``.
        """
        stamp  # noqa: B018 - in numba's cache key (see .kernel_cache)
        variant, decay_bits, acc_bits, u_bits, act_shift = formats
        u, v, ref, q = state
        gp_post, gp_exp = groups
        rec_n, var_idx, var_out = record.n, var.idx, var.out
        n = u.size
        ring = acc.shape[0]
        cap = record.t.size
        for j in range(j0, j1):
            if rec_n[0] + headroom > cap:
                return j
            slot = j % ring
            _sources(j, sources, counts, stats, record, syn, acc, 0)
            for g in range(gp_post.size):
                x = acc[slot, g]
                if x != 0:
                    q[gp_post[g]] += shift_floor(x, gp_exp[g]) << act_shift
                    acc[slot, g] = 0
            for i in range(n):
                p = params[i]
                if p[L_ACTIVE] == 0:
                    continue
                stats[ST_NEURON_UPDATES] += 1
                qi = q[i]
                q[i] = 0
                if variant == LOIHI1:
                    qi = wrap_signed(qi, acc_bits)
                    ui = wrap_signed(decay_toward_zero(u[i], p[L_RU], decay_bits) + qi, u_bits)
                    u2 = wrap_signed(ui + p[L_BIAS], u_bits)
                else:
                    ui = wrap_lava(decay_toward_zero(u[i], p[L_RU], decay_bits) + qi, u_bits)
                    u2 = ui + p[L_BIAS]
                u[i] = ui
                vi = decay_toward_zero(v[i], p[L_RV], decay_bits) + u2
                vi = min(max(vi, p[L_VMIN]), p[L_VMAX])
                if ref[i] > 0:
                    vi = 0
                if vi > p[L_VTH]:
                    vi = 0
                    ref[i] = p[L_REF]
                    _emit(i, j + 1, counts, stats, record, syn, acc, 0)
                if ref[i] > 0:
                    ref[i] -= 1
                v[i] = vi
            for r in range(var_idx.size):
                var_out[j - j0, r] = v[var_idx[r]]
            stats[ST_STEPS] += 1
        return j1

    return run_loihi


run_loihi = _loihi_loop(_STAMP)


# -- SpiNNaker -----------------------------------------------------------------------
def _spinnaker_loop(stamp: int) -> Callable[..., int]:
    """The SpiNNaker step loop, cached under ``stamp``."""

    @njit(cache=True)
    def run_spinnaker(j0, j1, formats, params, state, counts, syn, acc, sources, record, headroom, var, stats):
        """Advance sPyNNaker LIF neurons from step ``j0`` to ``j1``; return the step reached.

        Ring-buffer slot ``2 i`` holds neuron ``i``'s excitatory input, ``2 i + 1`` its
        inhibitory input (16-bit saturating sums of weights). Per neuron and step, in
        sPyNNaker's order: the arriving sums, shifted left by the synapse type's shift,
        are added to the synaptic inputs scaled by ``init``; the Ca2+ current decays; unless
        refractory the membrane takes the closed-form step ``v = a - exp_TC (a - v)``,
        ``a = I R + v_rest``; ``v >= v_thresh`` spikes (``v = v_reset``, refractory timer,
        ``I_ca2 += i_alpha``); the synaptic inputs decay. ``formats`` and ``state`` are a
        :class:`SpinnakerFormats` and :class:`SpinnakerState`; ``params`` has the ``S_*`` columns.
        """
        stamp  # noqa: B018 - in numba's cache key (see .kernel_cache)
        frac, acc_max, cond_shift = formats
        v, isyn_e, isyn_i, ica, refr = state
        rec_n, var_idx, var_code, var_out = record.n, var.idx, var.code, var.out
        n = v.size
        ring = acc.shape[0]
        cap = record.t.size
        for j in range(j0, j1):
            if rec_n[0] + headroom > cap:
                return j
            slot = j % ring
            _sources(j, sources, counts, stats, record, syn, acc, acc_max)
            for i in range(n):
                p = params[i]
                if p[S_ACTIVE] == 0:
                    continue
                stats[ST_NEURON_UPDATES] += 1
                we = acc[slot, 2 * i]
                wi = acc[slot, 2 * i + 1]
                if we != 0:
                    isyn_e[i] = wrap32(isyn_e[i] + decay_u032(we << p[S_SHIFT_E], p[S_INIT_E]))
                    acc[slot, 2 * i] = 0
                if wi != 0:
                    isyn_i[i] = wrap32(isyn_i[i] + decay_u032(wi << p[S_SHIFT_I], p[S_INIT_I]))
                    acc[slot, 2 * i + 1] = 0
                vi = v[i]
                if p[S_COND] == 1:
                    ge = isyn_e[i] >> cond_shift
                    gi = isyn_i[i] >> cond_shift
                    total = wrap32(mul_trunc(ge, p[S_E_REV_E] - vi, frac) + mul_trunc(gi, p[S_E_REV_I] - vi, frac))
                else:
                    total = wrap32(isyn_e[i] - isyn_i[i])
                ica[i] = mul_trunc(ica[i], p[S_EXP_CA], frac)
                if refr[i] <= 0:
                    inp = wrap32(total - ica[i] + p[S_I_OFFSET])
                    alpha = wrap32(mul_round(inp, p[S_R], frac) + p[S_V_REST])
                    vi = wrap32(alpha - mul_round(p[S_EXP_TC], wrap32(alpha - vi), frac))
                else:
                    refr[i] -= 1
                if vi >= p[S_V_THRESH]:
                    vi = p[S_V_RESET]
                    refr[i] = p[S_T_REFRACT]
                    ica[i] = wrap32(ica[i] + p[S_I_ALPHA])
                    _emit(i, j + 1, counts, stats, record, syn, acc, acc_max)
                v[i] = vi
                isyn_e[i] = decay_u032(isyn_e[i], p[S_DEC_E])
                isyn_i[i] = decay_u032(isyn_i[i], p[S_DEC_I])
            for r in range(var_idx.size):
                i = var_idx[r]
                c = var_code[r]
                if c == 0:
                    var_out[j - j0, r] = v[i]
                elif c == 1:
                    var_out[j - j0, r] = isyn_e[i]
                elif c == 2:
                    var_out[j - j0, r] = isyn_i[i]
                else:
                    var_out[j - j0, r] = ica[i]
            stats[ST_STEPS] += 1
        return j1

    return run_spinnaker


run_spinnaker = _spinnaker_loop(_STAMP)
