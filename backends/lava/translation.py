"""Translation of ``IF_curr_exp`` populations and their projections into Lava's LIF terms (pure numpy).

Lava's LIF (``lava.proc.lif``) updates, per step, ``u = u (1 - du) + a_in`` and
``v = v (1 - dv) + u + bias`` and spikes when ``v > vth`` (then ``v = 0``). The
membrane equation is linear, so measuring ``v`` from ``v_reset`` turns a resting value
``v_rest != v_reset`` into a constant input. With ``dv = 1 - e_m``, ``du = 1 - e_s``
(``e_x = exp(-dt / tau_x)``), ``vth = 1`` and

- ``v = (v_mV - v_reset) / (v_thresh - v_reset)``,
- ``bias = (1 - e_m) (s i_offset + (v_rest - v_reset) / (v_thresh - v_reset))``,
  ``s = (tau_m / cm) / (v_thresh - v_reset)``,
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
from typing import Any

import numpy as np

from neurovpr.ir.cells import IF_curr_exp
from neurovpr.ir.network import Population

__all__ = [
    "LavaLIF",
    "FixedWeights",
    "lif_problems",
    "lava_lif",
    "current_factor",
    "weight_scale",
    "fixed_weights",
    "delay_steps",
    "V_MAX",
]

_RTOL = 1e-9
#: Largest threshold integer used: 2**14 leaves u and v (24-bit) three bits above 64 V.
V_MAX = 2**14
_BIAS_MANT_MAX = 4095
_BIAS_EXP_MAX = 7


def _per_neuron(value: Any, size: int) -> np.ndarray:
    return np.broadcast_to(np.asarray(value, dtype=np.float64), (size,)).copy()


def _uniform(value: Any) -> float | None:
    arr = np.asarray(value, dtype=np.float64)
    if arr.ndim == 0:
        return float(arr)
    return float(arr[0]) if np.allclose(arr, arr[0], rtol=_RTOL, atol=0.0) else None


@dataclass(frozen=True, slots=True)
class LavaLIF:
    """One population in Lava's LIF terms.

    Attributes
    ----------
    du, dv, vth
        Float decays and threshold (``vth = 1``).
    bias
        Float bias per neuron.
    v_init
        Initial normalised voltage per neuron.
    gain
        ``s`` per neuron (1/nA).
    refractory_steps
        ``round(tau_refrac / dt)``.
    tau_m, tau_syn_e, tau_syn_i
        PyNN time constants (ms).
    v_zero, v_scale
        ``v_mV = v_zero + v * v_scale`` (``v_zero = v_reset``).
    fixed_v
        Threshold integer ``V`` of the fixed-point model.
    du_int, dv_int, bias_mant, bias_exp, v_init_int
        The fixed-point parameters.
    """

    du: float
    dv: float
    vth: float
    bias: np.ndarray
    v_init: np.ndarray
    gain: np.ndarray
    refractory_steps: int
    tau_m: float
    tau_syn_e: float
    tau_syn_i: float
    v_zero: np.ndarray
    v_scale: np.ndarray
    fixed_v: int
    du_int: int
    dv_int: int
    bias_mant: np.ndarray
    bias_exp: np.ndarray
    v_init_int: np.ndarray

    def tau_syn(self, receptor_type: str) -> float:
        """Synaptic time constant (ms) of a receptor type."""
        return self.tau_syn_e if receptor_type == "excitatory" else self.tau_syn_i


def lif_problems(pop: Population) -> list[str]:
    """Why an ``IF_curr_exp`` population cannot be a Lava LIF (phrases naming parameter and value)."""
    cell = pop.cell_type
    if not isinstance(cell, IF_curr_exp):
        return []
    return [
        f"per-neuron {name} (population {pop.name!r}; Lava's LIF has one decay per process)"
        for name in ("tau_m", "tau_refrac", "tau_syn_E", "tau_syn_I")
        if _uniform(getattr(cell, name)) is None
    ]


def current_factor(tau_syn: float, tau_m: float, dt: float) -> float:
    """``kappa``: the constant current acting like a unit current decaying with ``tau_syn`` over one step."""
    e_s = math.exp(-dt / tau_syn)
    e_m = math.exp(-dt / tau_m)
    if math.isclose(tau_syn, tau_m, rel_tol=1e-9):
        return (dt / tau_m) * e_m / (1.0 - e_m)
    return tau_syn * (e_s - e_m) / ((tau_syn - tau_m) * (1.0 - e_m))


def weight_scale(lif: LavaLIF, receptor_type: str, dt: float) -> np.ndarray:
    """Per postsynaptic neuron, the factor from a weight (nA) to Lava's float weight ``W``."""
    sign = 1.0 if receptor_type == "excitatory" else -1.0
    kappa = current_factor(lif.tau_syn(receptor_type), lif.tau_m, dt)
    return sign * lif.dv * kappa * lif.gain


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
    cell = pop.cell_type
    assert isinstance(cell, IF_curr_exp)
    n = pop.size
    tau_m, tau_ref = _uniform(cell.tau_m), _uniform(cell.tau_refrac)
    tau_e, tau_i = _uniform(cell.tau_syn_E), _uniform(cell.tau_syn_I)
    assert tau_m is not None and tau_ref is not None and tau_e is not None and tau_i is not None
    rest = _per_neuron(cell.v_rest, n)
    reset = _per_neuron(cell.v_reset, n)
    scale = _per_neuron(cell.v_thresh, n) - reset
    gain = _per_neuron(cell.tau_m, n) / _per_neuron(cell.cm, n) / scale
    dv = 1.0 - math.exp(-dt / tau_m)
    bias = dv * (gain * _per_neuron(cell.i_offset, n) + (rest - reset) / scale)
    v_init = (_per_neuron(cell.v_rest if pop.v_init is None else pop.v_init, n) - reset) / scale
    du = 1.0 - math.exp(-dt / (tau_i if receptors == frozenset({"inhibitory"}) else tau_e))
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
        du=du,
        dv=dv,
        vth=1.0,
        bias=bias,
        v_init=v_init,
        gain=gain,
        refractory_steps=round(tau_ref / dt),
        tau_m=tau_m,
        tau_syn_e=tau_e,
        tau_syn_i=tau_i,
        v_zero=reset,
        v_scale=scale,
        fixed_v=int(fixed_v),
        du_int=du_int,
        dv_int=dv_int,
        bias_mant=mant,
        bias_exp=exp,
        v_init_int=np.rint(v_init * 64.0 * fixed_v).astype(np.int64),
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


def delay_steps(delays_ms: np.ndarray, dt: float) -> np.ndarray:
    """Delays rounded to whole steps (at least one)."""
    return np.maximum(np.rint(np.asarray(delays_ms, dtype=np.float64) / dt).astype(np.int64), 1)
