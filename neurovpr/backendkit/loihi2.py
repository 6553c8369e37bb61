"""Loihi 2 integers of an ``IF_curr_exp`` population and its synapse groups (pure numpy).

Lava has no quantiser of its own: a Loihi 2 network is the integers its ``fixed_pt``
processes are given. This module computes them once, for the ``lava-fixed`` backend (which
gives them to Lava's bit-accurate models) and for the reference backend's ``loihi2``
emulation (which runs them itself), with every format limit read from the hwspec's
``[formats]`` (hwspecs/loihi2.toml; the formats of lava/proc/lif/models.py,
lava/proc/dense/models.py and lava/utils/weightutils.py):

- ``v`` is measured from ``v_reset`` in units of ``(v_thresh - v_reset) / (2**threshold_exponent V)``:
  the threshold is the integer ``V`` (used as ``V << threshold_exponent``), as large as
  ``voltage_headroom_bits`` of headroom in ``u`` and ``v`` (``voltage_bits`` wide) and the
  bias format (``bias_mantissa_bits`` and sign, exponent ``0..bias_exponent_max``) allow;
- ``u`` and ``v`` decay with ``du = round(2**decay_bits (1 - e_s)) - 1`` (Loihi adds 1) and
  ``dv = round(2**decay_bits (1 - e_m))``;
- a weight ``w`` (nA) is ``W V``, ``W = +-dv kappa g w`` (:func:`weight_scale`); each synapse
  group (one Lava synapse process: a projection's connections of one delay) gets one
  exponent, ``weight_bits`` magnitudes when its weights have one sign, even weights
  (``weight_mantissa_bits`` and sign, Lava's ``SignMode.MIXED``) when they have both.

docs/number_formats.md has the rules with their derivation.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from neurovpr.errors import ValidationError
from neurovpr.ir.network import Population

from .lif import current_factor
from .params import per_neuron

__all__ = ["LIFIntegers", "SynapseWeights", "gain", "lif_integers", "weight_scale", "weight_integers"]


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


@dataclass(frozen=True, slots=True)
class LIFIntegers:
    """One ``IF_curr_exp`` population as one Lava LIF in Loihi 2's formats.

    Attributes
    ----------
    decay_u, decay_v
        The float decays per step ``1 - e_s`` and ``1 - e_m``.
    bias
        The float bias per neuron (thresholds per step: ``decay_v`` times the constant input).
    du, dv
        Lava's integer decays (``2**decay_bits`` is 1).
    vth_man
        The threshold integer ``V``; Lava's ``vth`` parameter.
    v_scale
        Voltage integers per threshold (``V << threshold_exponent``).
    bias_man, bias_exp
        The bias mantissa and exponent per neuron.
    ref
        Refractory steps + 1 per neuron.
    v_init
        The initial voltage integer per neuron.
    v_unit
        mV of one voltage integer per neuron.
    decay_unity
        ``2**decay_bits``.
    threshold_exponent
        The hwspec's ``threshold_exponent``.
    """

    decay_u: float
    decay_v: float
    bias: np.ndarray
    du: int
    dv: int
    vth_man: int
    v_scale: float
    bias_man: np.ndarray
    bias_exp: np.ndarray
    ref: np.ndarray
    v_init: np.ndarray
    v_unit: np.ndarray
    decay_unity: int
    threshold_exponent: int

    @property
    def ru(self) -> int:
        """The factor ``u`` keeps per step, over ``2**decay_bits``."""
        return self.decay_unity - 1 - self.du

    @property
    def rv(self) -> int:
        """The factor ``v`` keeps per step, over ``2**decay_bits``."""
        return self.decay_unity - self.dv

    @property
    def vth(self) -> int:
        """The threshold as ``v`` is compared with it (``V << threshold_exponent``)."""
        return self.vth_man << self.threshold_exponent

    @property
    def bias_int(self) -> np.ndarray:
        """The bias added to ``v`` per step (``bias_man << bias_exp``)."""
        return self.bias_man << self.bias_exp


def _bias_integers(bias: np.ndarray, fmt: Any) -> tuple[np.ndarray, np.ndarray]:
    """Bias integers as a mantissa (``bias_mantissa_bits`` and sign) and the smallest exponent ``0..bias_exponent_max``."""
    largest = 2**fmt.bias_mantissa_bits - 1
    mag = np.abs(bias)
    with np.errstate(divide="ignore"):
        exp = np.where(mag > largest, np.ceil(np.log2(mag / largest)), 0.0)
    exp = np.clip(exp, 0, fmt.bias_exponent_max).astype(np.int64)
    return np.clip(np.rint(bias / 2.0**exp), -largest - 1, largest).astype(np.int64), exp


def lif_integers(pop: Population, dt: float, fmt: Any, *, inhibitory_only: bool) -> LIFIntegers:
    """The integers of one ``IF_curr_exp`` population as one Lava LIF.

    Parameters
    ----------
    pop
        The population (its time constants are taken from its first neuron).
    dt
        Time step (ms).
    fmt
        The hwspec's ``[formats]`` (``voltage_headroom_bits`` is required).
    inhibitory_only
        The synaptic decay is ``tau_syn_I``'s (only inhibitory input arrives), else ``tau_syn_E``'s.

    Raises
    ------
    ValidationError
        When ``i_offset`` is too large for the bias format at threshold 1 (the message names it),
        or the hwspec has no ``voltage_headroom_bits``.
    """
    if fmt.voltage_headroom_bits is None:
        raise ValidationError("hwspec [formats] has no voltage_headroom_bits, which the Loihi 2 mapping needs.")
    c, size = pop.cell_type, pop.size
    reset = per_neuron(c.v_reset, size)
    scale = per_neuron(c.v_thresh, size) - reset
    decay_v = 1.0 - math.exp(-dt / _first(c.tau_m))
    bias = decay_v * (gain(pop) * per_neuron(c.i_offset, size) + (per_neuron(c.v_rest, size) - reset) / scale)
    decay_u = 1.0 - math.exp(-dt / _first(c.tau_syn_I if inhibitory_only else c.tau_syn_E))
    vth_max = 2 ** (fmt.voltage_bits - 1 - fmt.threshold_exponent - fmt.voltage_headroom_bits)
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
    v0 = (per_neuron(c.v_rest if pop.v_init is None else pop.v_init, size) - reset) / scale
    return LIFIntegers(
        decay_u=decay_u,
        decay_v=decay_v,
        bias=bias,
        du=int(np.clip(round(unity * decay_u) - 1, 0, unity - 1)),
        dv=int(np.clip(round(unity * decay_v), 0, unity - 1)),
        vth_man=int(vth),
        v_scale=v_scale,
        bias_man=bias_man,
        bias_exp=bias_exp,
        ref=np.round(per_neuron(c.tau_refrac, size) / dt).astype(np.int64) + 1,
        v_init=np.rint(v0 * v_scale).astype(np.int64),
        v_unit=scale / v_scale,
        decay_unity=unity,
        threshold_exponent=fmt.threshold_exponent,
    )


def weight_scale(pop: Population, receptor_type: str, dt: float) -> np.ndarray:
    """Per neuron of ``pop``, the factor from a weight (nA) to ``W`` (thresholds added to ``u``, signed)."""
    c = pop.cell_type
    sign = 1.0 if receptor_type == "excitatory" else -1.0
    tau_m = _first(c.tau_m)
    tau_syn = _first(c.tau_syn_E if receptor_type == "excitatory" else c.tau_syn_I)
    return sign * (1.0 - math.exp(-dt / tau_m)) * current_factor(tau_syn, tau_m, dt) * gain(pop)


@dataclass(frozen=True, slots=True)
class SynapseWeights:
    """One synapse group's weights in Loihi 2's synapse format.

    Attributes
    ----------
    mantissa
        Integer weights as Lava's fixed-point synapse processes take them (even for mixed sign).
    exp
        The group's ``weight_exp``.
    sign_mode
        ``"excitatory"``, ``"inhibitory"`` or ``"mixed"`` (Lava's ``SignMode``).
    """

    mantissa: np.ndarray
    exp: int
    sign_mode: str


def weight_integers(
    values: np.ndarray, fmt: Any, *, like: np.ndarray | None = None, where: str | None = None
) -> SynapseWeights:
    """One synapse group's weights (``W V``) as Lava's weights and the group's exponent.

    A single-sign group uses the full ``weight_bits`` magnitude; a mixed-sign one loses the
    lowest bits to the sign (``weight_mantissa_bits`` and sign, even weights). The exponent
    and sign mode are chosen for ``like`` when given (the values a projection's connections
    carry, for a convolution kernel holding entries that reach no connection), else for
    ``values``. With ``where`` (naming the group), an exponent outside
    ``weight_exponent_min..max`` is refused.
    """
    values = np.asarray(values, dtype=np.float64)
    ref = values if like is None else np.asarray(like, dtype=np.float64)
    top = float(np.abs(ref).max()) if ref.size else 0.0
    if top == 0.0:
        return SynapseWeights(np.zeros(values.shape, dtype=np.int64), 0, "excitatory")
    if ref.min() >= 0 or ref.max() <= 0:
        mode = "excitatory" if ref.min() >= 0 else "inhibitory"
        largest = 2**fmt.weight_bits - 1
        exp = math.ceil(math.log2(top / float(largest)))
        low, high = (0, largest) if mode == "excitatory" else (-largest, 0)
        mant = np.clip(np.rint(values / 2.0**exp), low, high)
    else:
        mode = "mixed"
        sign_bits = fmt.weight_bits - fmt.weight_mantissa_bits
        m = 2**fmt.weight_mantissa_bits
        exp = math.ceil(math.log2(top / float((m - 1) << sign_bits)))
        mant = np.clip(np.rint(values / 2.0 ** (exp + sign_bits)), -m, m - 1) * 2**sign_bits
    if where is not None and not fmt.weight_exponent_min <= exp <= fmt.weight_exponent_max:
        raise ValidationError(
            f"{where}: the largest weight needs a weight exponent of {exp}, outside Loihi's "
            f"{fmt.weight_exponent_min}..{fmt.weight_exponent_max} ([formats].weight_exponent_min/max)."
        )
    return SynapseWeights(mant.astype(np.int64), int(exp), mode)
