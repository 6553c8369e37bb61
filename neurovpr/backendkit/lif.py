"""An ``IF_curr_exp`` population as a normalised compartment: threshold 1, reset 0.

Nengo's ``LIF``, Lava's ``LIF`` and Loihi's compartments compute on a voltage that rests
at 0 and fires above 1. neurovpr's ``IF_curr_exp`` (PyNN units: ms, mV, nA, nF)::

    cm dv/dt = cm (v_rest - v) / tau_m + I_E - I_I + i_offset,   dI_X/dt = -I_X / tau_syn_X

is linear, so measuring ``v`` from ``v_reset`` in units of ``v_thresh - v_reset`` turns it
into that form exactly:

- ``u = (v - v_reset) / (v_thresh - v_reset)``;
- the input ``J = s (i_offset + kappa I) + (v_rest - v_reset) / (v_thresh - v_reset)`` with
  the gain ``s = (tau_m / cm) / (v_thresh - v_reset)`` and ``kappa`` the constant current
  equivalent over one step of a synaptic current decaying with ``tau_syn``
  (:func:`current_factor`); the constant part of ``J`` is the bias.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from neurovpr.ir.cells import IF_curr_exp
from neurovpr.ir.network import Population

from .params import per_neuron, uniform_value

__all__ = ["NormalisedLIF", "SHARED_CONSTANTS", "normalised_lif", "shared_constant_problems", "current_factor"]

#: Time constants one normalised compartment group (an ensemble, a process, a core block) shares.
SHARED_CONSTANTS = ("tau_m", "tau_refrac", "tau_syn_E", "tau_syn_I")


@dataclass(frozen=True, slots=True)
class NormalisedLIF:
    """One ``IF_curr_exp`` population in normalised terms.

    Attributes
    ----------
    tau_m, tau_refrac, tau_syn_e, tau_syn_i
        The population's time constants (ms).
    gain
        ``s = (tau_m / cm) / (v_thresh - v_reset)`` per neuron (1/nA).
    bias
        The constant input ``s i_offset + (v_rest - v_reset) / (v_thresh - v_reset)`` per neuron.
    v_zero, v_scale
        ``v_mV = v_zero + u v_scale`` (``v_zero = v_reset``, ``v_scale = v_thresh - v_reset``).
    v_init
        The initial normalised voltage per neuron (from ``v_init``, else ``v_rest``).
    """

    tau_m: float
    tau_refrac: float
    tau_syn_e: float
    tau_syn_i: float
    gain: np.ndarray
    bias: np.ndarray
    v_zero: np.ndarray
    v_scale: np.ndarray
    v_init: np.ndarray

    def tau_syn(self, receptor_type: str) -> float:
        """The synaptic time constant (ms) of ``"excitatory"`` or ``"inhibitory"`` input."""
        return self.tau_syn_e if receptor_type == "excitatory" else self.tau_syn_i

    def to_mv(self, u: np.ndarray) -> np.ndarray:
        """Normalised voltages (``(..., size)``) in mV."""
        return self.v_zero + np.asarray(u, dtype=np.float64) * self.v_scale


def shared_constant_problems(pop: Population, holder: str) -> list[str]:
    """Per-neuron time constants of an ``IF_curr_exp`` population, which one ``holder`` shares.

    Returns one phrase per parameter, naming it, the population and ``holder`` (e.g.
    ``"one value per Nengo ensemble"``); nothing for other cell types.
    """
    cell = pop.cell_type
    if not isinstance(cell, IF_curr_exp):
        return []
    return [
        f"per-neuron {name} (population {pop.name!r}; {holder})"
        for name in SHARED_CONSTANTS
        if uniform_value(getattr(cell, name)) is None
    ]


def normalised_lif(pop: Population) -> NormalisedLIF:
    """Map an ``IF_curr_exp`` population whose time constants are shared (see :func:`shared_constant_problems`)."""
    cell = pop.cell_type
    assert isinstance(cell, IF_curr_exp)
    n = pop.size
    tau_m, tau_ref = uniform_value(cell.tau_m), uniform_value(cell.tau_refrac)
    tau_e, tau_i = uniform_value(cell.tau_syn_E), uniform_value(cell.tau_syn_I)
    assert tau_m is not None and tau_ref is not None and tau_e is not None and tau_i is not None
    reset = per_neuron(cell.v_reset, n)
    scale = per_neuron(cell.v_thresh, n) - reset
    gain = per_neuron(cell.tau_m, n) / per_neuron(cell.cm, n) / scale
    bias = gain * per_neuron(cell.i_offset, n) + (per_neuron(cell.v_rest, n) - reset) / scale
    v_init = (per_neuron(cell.v_rest if pop.v_init is None else pop.v_init, n) - reset) / scale
    return NormalisedLIF(
        tau_m=tau_m,
        tau_refrac=tau_ref,
        tau_syn_e=tau_e,
        tau_syn_i=tau_i,
        gain=gain,
        bias=bias,
        v_zero=reset,
        v_scale=scale,
        v_init=v_init,
    )


def current_factor(tau_syn: float, tau_m: float, dt: float) -> float:
    """``kappa``: the constant current acting like a unit current decaying with ``tau_syn`` over one step.

    Over a step of length ``dt`` the membrane (``tau_m``) responds to ``I exp(-t / tau_syn)``
    as to the constant ``kappa I`` (all times in the same unit); the degenerate limit
    ``tau_syn == tau_m`` is taken exactly.
    """
    e_s = math.exp(-dt / tau_syn)
    e_m = math.exp(-dt / tau_m)
    if math.isclose(tau_syn, tau_m, rel_tol=1e-9):
        return (dt / tau_m) * e_m / (1.0 - e_m)
    return tau_syn * (e_s - e_m) / ((tau_syn - tau_m) * (1.0 - e_m))
