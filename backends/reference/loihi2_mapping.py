"""Loihi 2 integers of a population and its synapse groups, as the ``lava-fixed`` backend maps them.

Lava has no quantiser of its own: a Loihi 2 network is the integers its ``fixed_pt``
processes are given. The ``loihi2`` emulation uses the integers the ``lava-fixed`` backend
gives Lava (backends/lava/translation.py and build.py), computed in float64 in the same order,
with every format limit read from the hwspec's ``[formats]``:

- ``v`` is measured from ``v_reset`` in units of ``(v_thresh - v_reset) / (64 V)``: the
  threshold is the integer ``V`` (used as ``V << 6``), as large as the headroom in ``u``
  and ``v`` and the bias format allow;
- ``u`` and ``v`` decay with ``du = round(4096 (1 - e_s)) - 1``, ``dv = round(4096 (1 - e_m))``;
- a weight ``w`` (nA) is ``W V``, ``W = +-dv kappa g w``; each synapse group (one Lava
  synapse process: a projection's connections of one delay) gets one exponent, 8-bit
  magnitudes when its weights have one sign, even 8-bit weights (Lava's ``SignMode.MIXED``)
  when they have both.

docs/number_formats.md has the rules with their derivation.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from neurovpr.backendkit.params import per_neuron
from neurovpr.errors import ValidationError
from neurovpr.ir.network import Population

__all__ = ["kappa", "gain", "lif_integers", "weight_scale", "weight_integers"]

#: Bits the mapping keeps in ``u`` and ``v`` above the threshold (backends/lava/translation.py ``V_MAX``).
_HEADROOM_BITS = 3


def kappa(tau_syn: float, tau_m: float, dt: float) -> float:
    """The constant current acting over one step like a unit current decaying with ``tau_syn`` (exact integration)."""
    e_s, e_m = math.exp(-dt / tau_syn), math.exp(-dt / tau_m)
    if math.isclose(tau_syn, tau_m, rel_tol=1e-9):
        return (dt / tau_m) * e_m / (1.0 - e_m)
    return tau_syn * (e_s - e_m) / ((tau_syn - tau_m) * (1.0 - e_m))


def _first(value: Any) -> float:
    return float(np.asarray(value).flat[0])


def gain(pop: Population) -> np.ndarray:
    """``(tau_m / cm) / (v_thresh - v_reset)`` per neuron (1/nA)."""
    c = pop.cell_type
    return (
        per_neuron(c.tau_m, pop.size)
        / per_neuron(c.cm, pop.size)
        / (per_neuron(c.v_thresh, pop.size) - per_neuron(c.v_reset, pop.size))
    )


def _bias_integers(bias: np.ndarray, fmt: Any) -> tuple[np.ndarray, np.ndarray]:
    """Bias integers as a mantissa (``bias_mantissa_bits`` and sign) and the smallest exponent ``0..bias_exponent_max``."""
    largest = 2**fmt.bias_mantissa_bits - 1
    mag = np.abs(bias)
    with np.errstate(divide="ignore"):
        exp = np.where(mag > largest, np.ceil(np.log2(mag / largest)), 0.0)
    exp = np.clip(exp, 0, fmt.bias_exponent_max).astype(np.int64)
    return np.clip(np.rint(bias / 2.0**exp), -largest - 1, largest).astype(np.int64), exp


def lif_integers(pop: Population, dt: float, fmt: Any, *, inhibitory_only: bool) -> dict[str, Any]:
    """The integers of one ``IF_curr_exp`` population as one Lava LIF.

    Returns per neuron ``du``, ``dv`` (Lava's parameters), ``ru``, ``rv`` (the decay factors
    over ``2**decay_bits``), ``vth_man`` (``V``), ``vth`` (``V << threshold_exponent``),
    ``bias_man``, ``bias_exp``, ``bias``, ``ref`` (refractory steps + 1), ``v_init``,
    ``v_unit`` (mV per voltage integer), and the population's ``v_scale`` (integers per
    threshold). ``inhibitory_only``: the synaptic decay is ``tau_syn_I``'s (else ``tau_syn_E``'s).
    """
    c, size = pop.cell_type, pop.size
    reset = per_neuron(c.v_reset, size)
    scale = per_neuron(c.v_thresh, size) - reset
    decay_v = 1.0 - math.exp(-dt / _first(c.tau_m))
    bias = decay_v * (gain(pop) * per_neuron(c.i_offset, size) + (per_neuron(c.v_rest, size) - reset) / scale)
    decay_u = 1.0 - math.exp(-dt / _first(c.tau_syn_I if inhibitory_only else c.tau_syn_E))
    vth_max = 2 ** (fmt.voltage_bits - 1 - fmt.threshold_exponent - _HEADROOM_BITS)
    bias_limit = (2**fmt.bias_mantissa_bits - 1) * 2**fmt.bias_exponent_max / 2**fmt.threshold_exponent
    max_bias = float(np.abs(bias).max()) if size else 0.0
    vth = vth_max if max_bias == 0.0 else min(vth_max, math.floor(bias_limit / max_bias))
    if vth < 1:
        raise ValidationError(
            f"Population {pop.name!r}: i_offset drives {max_bias:.3g} thresholds per step, more than Loihi's bias "
            f"({fmt.bias_mantissa_bits}-bit mantissa, exponent <= {fmt.bias_exponent_max}) holds at threshold 1."
        )
    v_scale = float(2**fmt.threshold_exponent * vth)
    bias_man, bias_exp = _bias_integers(bias * v_scale, fmt)
    unity = 2**fmt.decay_bits
    du = int(np.clip(round(unity * decay_u) - 1, 0, unity - 1))
    dv = int(np.clip(round(unity * decay_v), 0, unity - 1))
    v0 = (per_neuron(c.v_rest if pop.v_init is None else pop.v_init, size) - reset) / scale
    full = np.full(size, 1, dtype=np.int64)
    return {
        "du": du * full,
        "dv": dv * full,
        "ru": (unity - 1 - du) * full,
        "rv": (unity - dv) * full,
        "vth_man": vth * full,
        "vth": (vth << fmt.threshold_exponent) * full,
        "bias_man": bias_man,
        "bias_exp": bias_exp,
        "bias": bias_man << bias_exp,
        "ref": np.round(per_neuron(c.tau_refrac, size) / dt).astype(np.int64) + 1,
        "v_init": np.rint(v0 * v_scale).astype(np.int64),
        "v_unit": scale / v_scale,
        "v_scale": v_scale,
    }


def weight_scale(pop: Population, receptor_type: str, dt: float) -> np.ndarray:
    """Per neuron of ``pop``, the factor from a weight (nA) to ``W`` (thresholds added to ``u``, signed)."""
    c = pop.cell_type
    sign = 1.0 if receptor_type == "excitatory" else -1.0
    tau_m = _first(c.tau_m)
    tau_syn = _first(c.tau_syn_E if receptor_type == "excitatory" else c.tau_syn_I)
    return sign * (1.0 - math.exp(-dt / tau_m)) * kappa(tau_syn, tau_m, dt) * gain(pop)


def weight_integers(values: np.ndarray, fmt: Any, where: str) -> tuple[np.ndarray, int]:
    """One synapse group's weights (``W V``) as Lava's 8-bit weights and the group's exponent.

    A single-sign group uses the full ``weight_bits`` magnitude; a mixed-sign one loses the
    lowest bit to the sign (``weight_mantissa_bits``, even weights). An exponent outside
    ``weight_exponent_min..max`` is refused (``where`` names the group).
    """
    top = float(np.abs(values).max()) if values.size else 0.0
    if top == 0.0:
        return np.zeros(values.shape, dtype=np.int64), 0
    if values.min() >= 0 or values.max() <= 0:
        largest = 2**fmt.weight_bits - 1
        exp = math.ceil(math.log2(top / float(largest)))
        low, high = (0, largest) if values.min() >= 0 else (-largest, 0)
        mant = np.clip(np.rint(values / 2.0**exp), low, high)
    else:
        sign_bits = fmt.weight_bits - fmt.weight_mantissa_bits
        m = 2**fmt.weight_mantissa_bits
        exp = math.ceil(math.log2(top / float((m - 1) << sign_bits)))
        mant = np.clip(np.rint(values / 2.0 ** (exp + sign_bits)), -m, m - 1) * 2**sign_bits
    if not fmt.weight_exponent_min <= exp <= fmt.weight_exponent_max:
        raise ValidationError(
            f"{where}: the largest weight needs a weight exponent of {exp}, outside Loihi's "
            f"{fmt.weight_exponent_min}..{fmt.weight_exponent_max} ([formats].weight_exponent_min/max)."
        )
    return mant.astype(np.int64), exp
