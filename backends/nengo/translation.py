"""Translation of neurovpr's IR into Nengo's normalised LIF terms (pure numpy, no Nengo import).

neurovpr's ``IF_curr_exp`` (PyNN units: ms, mV, nA, nF)::

    cm dv/dt = cm (v_rest - v) / tau_m + I_E - I_I + i_offset,   dI_X/dt = -I_X / tau_syn_X

Nengo's ``LIF`` works on a normalised voltage ``u`` that rests at 0, fires above 1
and resets to 0, driven by an input ``J`` held constant over each step (its
zero-order-hold update ``u += (J - u) (1 - exp(-dt / tau_rc))``). The membrane
equation is linear, so measuring ``v`` from ``v_reset`` turns a resting value
``v_rest != v_reset`` into a constant input. The two agree exactly below threshold with

- ``u = (v - v_reset) / (v_thresh - v_reset)``, ``tau_rc = tau_m``, ``tau_ref = tau_refrac``,
- ``J = s (i_offset + kappa I) + (v_rest - v_reset) / (v_thresh - v_reset)`` with
  ``s = R / (v_thresh - v_reset)``, ``R = tau_m / cm``, and ``kappa`` the factor that
  makes a current decaying with ``tau_syn`` during the step act like a constant one
  (``I`` is the synaptic current at the start of the step),
  ``kappa = tau_syn (e_s - e_m) / ((tau_syn - tau_m) (1 - e_m))``, ``e_x = exp(-dt / tau_x)``.

On the Nengo side ``s`` is the ensemble's ``gain`` (Nengo multiplies connections
into ``.neurons`` by it), the constant part of ``J`` its ``bias``, and a connection's transform
is ``kappa w dt / (1 - e_s)``: with spikes of height ``1 / dt`` and a first-order
filter of unit DC gain (``nengo.Lowpass(tau_syn)`` or the delayed discrete filter
below), the filtered current then starts at ``kappa w`` and decays by ``e_s`` per
step, exactly the exact-integration current.

Where Nengo differs from docs/semantics.md (and so the tolerances):

- spike timing inside a step: Nengo's LIF interpolates the threshold crossing and
  starts the refractory period there, so a neuron under constant input fires at the
  continuous-time LIF rate ``1 / (tau_ref + tau_rc log(1 + 1 / (J - 1)))`` instead of
  the step-grid rate (threshold tested at the end of a step, ``round(tau_refrac / dt)``
  refractory steps). The rates agree within ``dt`` per inter-spike interval;
- threshold: ``u > 1`` instead of ``v >= v_thresh`` (differs only on exact equality);
- delays: Nengo has no synaptic delay; the ``nengo`` backend builds one with a
  discrete filter ``(1 - e_s) z^-D / (1 - e_s z^-1)`` per projection and delay, so
  spike arrival is on the same step as the semantics. NengoLoihi accepts only
  ``nengo.Lowpass`` (``D = 1``): projections from spike sources keep the exact timing,
  projections between neuron populations act one step (``dt``) early.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from neurovpr.ir.cells import IF_curr_exp
from neurovpr.ir.connectors import ConvolutionConnector
from neurovpr.ir.network import Population

__all__ = [
    "LIFMapping",
    "lif_mapping",
    "lif_problems",
    "current_factor",
    "transform_scale",
    "delay_steps",
    "filter_delay",
    "conv_padding_mode",
]

#: Relative tolerance for "equal" parameters (v_reset vs v_rest, uniform arrays).
_RTOL = 1e-9


@dataclass(frozen=True, slots=True)
class LIFMapping:
    """One ``IF_curr_exp`` population in Nengo's normalised terms.

    Attributes
    ----------
    tau_rc_s, tau_ref_s
        Membrane time constant and refractory period in seconds.
    tau_syn_e_ms, tau_syn_i_ms, tau_m_ms
        The PyNN time constants (ms), kept for the synapse factors.
    gain
        ``s = R / (v_thresh - v_reset)`` per neuron (1/nA).
    bias
        ``s i_offset + (v_rest - v_reset) / (v_thresh - v_reset)`` per neuron.
    v_zero, v_scale
        ``v = v_zero + u * v_scale`` (mV) per neuron: ``v_zero = v_reset``,
        ``v_scale = v_thresh - v_reset``.
    u_init
        Initial normalised voltage per neuron.
    """

    tau_rc_s: float
    tau_ref_s: float
    tau_m_ms: float
    tau_syn_e_ms: float
    tau_syn_i_ms: float
    gain: np.ndarray
    bias: np.ndarray
    v_zero: np.ndarray
    v_scale: np.ndarray
    u_init: np.ndarray

    def tau_syn_ms(self, receptor_type: str) -> float:
        """The synaptic time constant (ms) of ``"excitatory"`` or ``"inhibitory"`` input."""
        return self.tau_syn_e_ms if receptor_type == "excitatory" else self.tau_syn_i_ms


def _per_neuron(value: Any, size: int) -> np.ndarray:
    return np.broadcast_to(np.asarray(value, dtype=np.float64), (size,)).copy()


def _uniform(value: Any) -> float | None:
    arr = np.asarray(value, dtype=np.float64)
    if arr.ndim == 0:
        return float(arr)
    return float(arr[0]) if np.allclose(arr, arr[0], rtol=_RTOL, atol=0.0) else None


def lif_problems(pop: Population, *, loihi: bool) -> list[str]:
    """Why an ``IF_curr_exp`` population cannot be expressed as a Nengo (or NengoLoihi) LIF.

    Parameters
    ----------
    pop
        The population (other cell types are refused by the capability table).
    loihi
        Also apply NengoLoihi's restriction: every voltage starts at 0 (``v_reset``).

    Returns
    -------
    list of str
        One phrase per problem, naming the parameter and its value.
    """
    cell = pop.cell_type
    if not isinstance(cell, IF_curr_exp):
        return []
    problems: list[str] = []
    for name in ("tau_m", "tau_refrac", "tau_syn_E", "tau_syn_I"):
        if _uniform(getattr(cell, name)) is None:
            problems.append(f"per-neuron {name} (population {pop.name!r}; one value per Nengo ensemble)")
    if loihi:
        reset = _per_neuron(cell.v_reset, pop.size)
        init = _per_neuron(cell.v_rest if pop.v_init is None else pop.v_init, pop.size)
        close = np.isclose(init, reset, rtol=_RTOL, atol=1e-12)
        if not np.all(close):
            bad = int(np.flatnonzero(~close)[0])
            problems.append(
                f"initial voltage {init[bad]:g} mV != v_reset {reset[bad]:g} mV (population {pop.name!r}; "
                "NengoLoihi starts every voltage at 0, which stands for v_reset)"
            )
    return problems


def lif_mapping(pop: Population) -> LIFMapping:
    """Map an ``IF_curr_exp`` population (already checked by :func:`lif_problems`)."""
    cell = pop.cell_type
    assert isinstance(cell, IF_curr_exp)
    n = pop.size
    tau_m = _uniform(cell.tau_m)
    tau_ref = _uniform(cell.tau_refrac)
    tau_e = _uniform(cell.tau_syn_E)
    tau_i = _uniform(cell.tau_syn_I)
    assert tau_m is not None and tau_ref is not None and tau_e is not None and tau_i is not None
    reset = _per_neuron(cell.v_reset, n)
    rest = _per_neuron(cell.v_rest, n)
    scale = _per_neuron(cell.v_thresh, n) - reset
    resistance = _per_neuron(cell.tau_m, n) / _per_neuron(cell.cm, n)
    gain = resistance / scale
    bias = gain * _per_neuron(cell.i_offset, n) + (rest - reset) / scale
    init = (_per_neuron(cell.v_rest if pop.v_init is None else pop.v_init, n) - reset) / scale
    return LIFMapping(
        tau_rc_s=tau_m / 1000.0,
        tau_ref_s=tau_ref / 1000.0,
        tau_m_ms=tau_m,
        tau_syn_e_ms=tau_e,
        tau_syn_i_ms=tau_i,
        gain=gain,
        bias=bias,
        v_zero=reset,
        v_scale=scale,
        u_init=init,
    )


def current_factor(tau_syn: float, tau_m: float, dt: float) -> float:
    """``kappa``: the constant current equivalent to a unit current decaying with ``tau_syn`` over one step.

    Over a step of length ``dt`` the membrane responds to ``I exp(-t / tau_syn)`` as
    to the constant ``kappa I`` (all times in the same unit).
    """
    e_s = math.exp(-dt / tau_syn)
    e_m = math.exp(-dt / tau_m)
    if math.isclose(tau_syn, tau_m, rel_tol=1e-9):
        return (dt / tau_m) * e_m / (1.0 - e_m)
    return tau_syn * (e_s - e_m) / ((tau_syn - tau_m) * (1.0 - e_m))


def transform_scale(tau_syn: float, tau_m: float, dt: float) -> float:
    """Factor from a weight (nA) to a Nengo transform, given spikes of height ``1 / dt_s``.

    ``kappa dt_s / (1 - e_s)``; the ensemble's gain supplies ``R / (v_thresh - v_rest)``.
    """
    e_s = math.exp(-dt / tau_syn)
    return current_factor(tau_syn, tau_m, dt) * (dt / 1000.0) / (1.0 - e_s)


def delay_steps(delays_ms: np.ndarray, dt: float) -> np.ndarray:
    """Delays rounded to whole steps (at least one)."""
    return np.maximum(np.rint(np.asarray(delays_ms, dtype=np.float64) / dt).astype(np.int64), 1)


def filter_delay(steps: int, *, from_source: bool) -> int:
    """Steps from a spike in Nengo to its first effect on the target's input ``J``.

    A neuron spiking in step ``j`` (at ``(j + 1) dt``) with a delay of ``K`` steps acts
    from step ``j + 1 + K``; a source spike stamped at ``m dt`` is emitted by Nengo in
    step ``m`` (its gate neurons run one step later than the stamp) and acts from
    ``m + K``. Nengo's filter adds the rest.
    """
    return int(steps) if from_source else int(steps) + 1


def conv_padding_mode(conn: ConvolutionConnector) -> str | None:
    """``"valid"`` or ``"same"`` when Nengo's ``Convolution`` pads exactly like ``conn``, else ``None``.

    Nengo pads ``"same"`` like TensorFlow (output ``ceil(size / stride)``, total padding
    split with the smaller half first); neurovpr pads ``padding`` on every side.
    """
    if conn.padding == (0, 0):
        return "valid"
    out = conn.output_hw
    for axis in range(2):
        size, k, s, p = conn.input_shape[axis + 1], conn.kernel_shape[axis], conn.stride[axis], conn.padding[axis]
        same_out = -(-size // s)
        total = max((same_out - 1) * s + k - size, 0)
        if out[axis] != same_out or p != total // 2:
            return None
    return "same"
