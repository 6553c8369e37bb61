"""Translation of ``IF_curr_exp`` populations and their projections into Lava's LIF terms (pure numpy).

Lava's LIF (``lava.proc.lif``) updates, per step, ``u = u (1 - du) + a_in`` and
``v = v (1 - dv) + u + bias`` and spikes when ``v > vth`` (then ``v = 0``). On the
normalised compartment of :mod:`neurovpr.backendkit.lif` (``v`` measured from ``v_reset``
in units of ``v_thresh - v_reset``, gain ``s``, constant input ``b``), with ``dv = 1 - e_m``,
``du = 1 - e_s`` (``e_x = exp(-dt / tau_x)``), ``vth = 1``,

- ``bias = (1 - e_m) b``,
- a synaptic weight ``W = (1 - e_m) s kappa w`` (negative for inhibitory projections),
  ``kappa`` the constant-current equivalent of a current decaying with ``tau_syn``
  over one step,

this is exactly the exact integration of docs/semantics.md, step by step; the
refractory period is Lava's ``LIFRefractory`` (``round(tau_refrac / dt)`` steps held at
rest while ``u`` keeps integrating). A spike reaches its target through
``DelayDense``/``DelaySparse`` (or a ``DelayConv``) one step plus ``delays`` later
(``Dense``/``Sparse``: one step), so a neuron projection uses ``delays = K`` and a
source projection (replayed one step after its stamp) ``K - 1``,
``K = round(delay / dt)``: arrival times match the semantics.

``fixed_pt`` (``lava-fixed``, bit-accurate Loihi 2) scales everything into Loihi's
integer formats (lava/proc/lif/models.py, dense/models.py, utils/weightutils.py):

- threshold ``vth`` (17-bit unsigned), used as ``vth << 6``; ``v`` and ``u`` are 24-bit.
  One integer ``V`` per population is the threshold, so one voltage unit is ``64 V``;
  ``V = min(2**14, 8190 / max|bias|)`` keeps three bits of headroom above threshold in
  ``u`` and ``v`` and fits the bias;
- ``du``, ``dv``: 12-bit, ``du = round(4096 (1 - e_s)) - 1`` (Loihi adds 1),
  ``dv = round(4096 (1 - e_m))``; decays truncate toward zero;
- bias: 13-bit signed mantissa and 3-bit exponent, ``bias_mant << bias_exp = 64 V bias``;
- weights: 8-bit mantissas with one exponent per projection (``w << weight_exp``,
  applied to the summed input, so negative exponents floor the sum), mixed-sign
  projections keep even mantissas (Loihi's sign bit); ``w_int 2**weight_exp = W V``.

The float model (``lava``) is exact to rounding; the fixed model's error is the
quantisation above: about ``2**-8`` of the largest weight of each projection, the
12-bit decays, and the per-step truncation of ``u`` and ``v``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from neurovpr.backendkit.lif import NormalisedLIF, current_factor, normalised_lif, shared_constant_problems
from neurovpr.ir.network import Population

__all__ = [
    "LavaLIF",
    "FixedWeights",
    "lif_problems",
    "lava_lif",
    "current_factor",
    "weight_scale",
    "fixed_weights",
    "V_MAX",
]

#: Largest threshold integer used: 2**14 leaves u and v (24-bit) three bits above 64 V.
V_MAX = 2**14
_BIAS_MANT_MAX = 4095
_BIAS_EXP_MAX = 7


@dataclass(frozen=True, slots=True)
class LavaLIF:
    """One population in Lava's LIF terms.

    Attributes
    ----------
    compartment
        The population as a normalised compartment (gain, time constants, initial voltage, mV scale).
    du, dv, vth
        Float decays and threshold (``vth = 1``).
    bias
        Float bias per neuron (``dv`` times the compartment's constant input).
    refractory_steps
        ``round(tau_refrac / dt)``.
    fixed_v
        Threshold integer ``V`` of the fixed-point model.
    du_int, dv_int, bias_mant, bias_exp, v_init_int
        The fixed-point parameters.
    """

    compartment: NormalisedLIF
    du: float
    dv: float
    vth: float
    bias: np.ndarray
    refractory_steps: int
    fixed_v: int
    du_int: int
    dv_int: int
    bias_mant: np.ndarray
    bias_exp: np.ndarray
    v_init_int: np.ndarray


def lif_problems(pop: Population) -> list[str]:
    """Why an ``IF_curr_exp`` population cannot be a Lava LIF (phrases naming parameter and value)."""
    return shared_constant_problems(pop, "Lava's LIF has one decay per process")


def weight_scale(lif: LavaLIF, receptor_type: str, dt: float) -> np.ndarray:
    """Per postsynaptic neuron, the factor from a weight (nA) to Lava's float weight ``W``."""
    c = lif.compartment
    sign = 1.0 if receptor_type == "excitatory" else -1.0
    kappa = current_factor(c.tau_syn(receptor_type), c.tau_m, dt)
    return sign * lif.dv * kappa * c.gain


def _quantise_bias(bias_internal: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    mag = np.abs(bias_internal)
    with np.errstate(divide="ignore"):
        exp = np.where(mag > _BIAS_MANT_MAX, np.ceil(np.log2(mag / _BIAS_MANT_MAX)), 0.0)
    exp = np.clip(exp, 0, _BIAS_EXP_MAX).astype(np.int64)
    mant = np.clip(np.rint(bias_internal / 2.0**exp), -_BIAS_MANT_MAX - 1, _BIAS_MANT_MAX).astype(np.int64)
    return mant, exp


def lava_lif(pop: Population, dt: float, receptors: frozenset[str] = frozenset()) -> LavaLIF:
    """Map an ``IF_curr_exp`` population (checked by :func:`lif_problems`) for both Lava models.

    ``receptors`` are the receptor types of its incoming projections: Lava's LIF has
    one synaptic current, whose decay is ``tau_syn_I``'s when only inhibitory input
    arrives and ``tau_syn_E``'s otherwise (both must then be equal; checked elsewhere).

    Raises
    ------
    ValueError
        When ``i_offset`` is too large for Loihi 2's bias format (the message names it).
    """
    c = normalised_lif(pop)
    n = pop.size
    dv = 1.0 - math.exp(-dt / c.tau_m)
    bias = dv * c.bias
    du = 1.0 - math.exp(-dt / (c.tau_syn_i if receptors == frozenset({"inhibitory"}) else c.tau_syn_e))
    max_bias = float(np.abs(bias).max()) if n else 0.0
    limit = (_BIAS_MANT_MAX * 2**_BIAS_EXP_MAX) / 64.0
    fixed_v = V_MAX if max_bias == 0.0 else min(V_MAX, math.floor(limit / max_bias))
    if fixed_v < 1:
        raise ValueError(
            f"population {pop.name!r}: i_offset drives {max_bias:.3g} thresholds per step, more than Loihi 2's "
            f"13-bit bias with exponent <= 7 can hold at threshold 1"
        )
    mant, exp = _quantise_bias(bias * 64.0 * fixed_v)
    du_int = int(np.clip(round(4096.0 * du) - 1, 0, 4095))
    dv_int = int(np.clip(round(4096.0 * dv), 0, 4095))
    return LavaLIF(
        compartment=c,
        du=du,
        dv=dv,
        vth=1.0,
        bias=bias,
        refractory_steps=round(c.tau_refrac / dt),
        fixed_v=int(fixed_v),
        du_int=du_int,
        dv_int=dv_int,
        bias_mant=mant,
        bias_exp=exp,
        v_init_int=np.rint(c.v_init * 64.0 * fixed_v).astype(np.int64),
    )


@dataclass(frozen=True, slots=True)
class FixedWeights:
    """A projection's weights in Loihi 2's synapse format.

    Attributes
    ----------
    mantissa
        Integer weights as Lava's fixed-point Dense/Sparse expect them (8-bit range,
        even for mixed sign).
    exp
        The shared ``weight_exp``.
    sign_mode
        ``"excitatory"``, ``"inhibitory"`` or ``"mixed"``.
    """

    mantissa: np.ndarray
    exp: int
    sign_mode: str


def fixed_weights(values: np.ndarray, *, like: np.ndarray | None = None) -> FixedWeights:
    """Quantise ``values`` (already multiplied by ``V``) to 8-bit mantissas with one exponent.

    The exponent and sign mode are chosen for ``like`` when given (the values a
    projection's connections actually carry, for a kernel holding entries that
    reach no connection), else for ``values``.
    """
    values = np.asarray(values, dtype=np.float64)
    ref = values if like is None else np.asarray(like, dtype=np.float64)
    top = float(np.abs(ref).max()) if ref.size else 0.0
    if ref.size == 0 or top == 0.0:
        return FixedWeights(np.zeros(values.shape, dtype=np.int64), 0, "excitatory")
    if ref.min() >= 0 or ref.max() <= 0:
        mode = "excitatory" if ref.min() >= 0 else "inhibitory"
        exp = math.ceil(math.log2(top / 255.0))
        low, high = (0, 255) if mode == "excitatory" else (-255, 0)
        mant = np.clip(np.rint(values / 2.0**exp), low, high)
    else:
        mode = "mixed"
        exp = math.ceil(math.log2(top / 254.0))
        mant = 2 * np.clip(np.rint(values / 2.0 ** (exp + 1)), -128, 127)
    return FixedWeights(mant.astype(np.int64), int(exp), mode)
