"""Translation of the IR into Brian2 model descriptions: fixed equation templates and values.

Every equation, threshold, reset and synaptic statement Brian2 compiles comes from the
template strings in this module. They are assembled from fixed fragments chosen by the
*type* of an IR node (cell class, receptor, plasticity rule); no value and no name read
from a network reaches them. Parameters travel as numbers: per-neuron ``(constant)``
variables of the ``NeuronGroup`` and ``(shared, constant)`` variables of the
``Synapses``, set from validated floats after the objects exist. So the generated code
is the same for every network of the same structure, and Brian2's Cython cache is
reused across parameter values.

Values are returned in SI base units (V, s, A, F, S), the unit-free form Brian2 stores
(``group.v_ = ...``); synaptic weights stay in PyNN units (uS or nA) and are multiplied
by the unit constant ``w_unit`` in the synaptic templates.

Numerical notes (see also the package docstring):

- Current-based neurons use Brian2's ``exact`` integrator, which solves the linear
  system symbolically with the time constants as symbols. Its solution divides by
  ``tau_m - tau_syn``; a population in which a synaptic (or calcium) time constant
  equals ``tau_m`` for every neuron gets the template in which that current decays
  with ``tau_m`` itself, for which the symbolic solution is the exact degenerate form
  ``(w / cm) s exp(-s / tau_m)``. Where only some neurons have (nearly) equal time
  constants, those neurons' synaptic time constant is moved to a relative distance of
  ``TAU_SEPARATION`` from ``tau_m`` (an error of about that size in that current's effect).
- Conductance-based neurons use Brian2's ``exponential_euler``. The templates multiply
  each conductance by ``f_X = tau_syn_X / dt (1 - exp(-dt / tau_syn_X))``, the mean of an
  exponentially decaying conductance over one step relative to its start value, so that
  Brian2's exponential-Euler step is exactly the semantics' update (the membrane is
  integrated exactly with the step's mean conductances). A cell with
  ``integration="euler"`` uses Brian2's ``euler`` on the same equations with ``f_X = 1``:
  every variable takes the forward-Euler step from its value at the step's start.
- Refractoriness uses Brian2's own mechanism (``lastspike``, ``not_refractory`` and the
  threshold's ``and not_refractory``): ``refractory`` is ``(R + 1) dt`` with
  ``R = round(tau_refrac / dt)``, because Brian2 counts the step of the spike itself,
  while the semantics hold ``v`` for the ``R`` steps that follow it. The spike lockout of
  ``IF_cond_exp_adaptive`` (``tau_lockout``) is a second condition of its threshold,
  ``t - lastspike > t_lock`` (VPRSNN expresses the same with a timer variable), which
  leaves the membrane free. ``v`` is held by a
  ``run_regularly`` operation after the integration rather than by the ``(unless
  refractory)`` flag, which would put ``not_refractory`` into the system matrix of the
  exact solver and hide the degenerate ``tau_syn == tau_m`` case from it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from neurovpr.backendkit.params import per_neuron
from neurovpr.backendkit.propagators import euler_time_constants
from neurovpr.errors import UnsupportedFeatureError
from neurovpr.ir.cells import (
    IF_cond_exp,
    IF_cond_exp_adaptive,
    IF_curr_exp,
    IF_curr_exp_ca2_adaptive,
    NeuronType,
    euler_integrated,
)
from neurovpr.ir.synapses import (
    DiehlCookSTDP,
    MultiplicativeWeightDependence,
    StaticSynapse,
    STDPMechanism,
    Synapse,
)

__all__ = [
    "TAU_SEPARATION",
    "NeuronModel",
    "SynapseModel",
    "neuron_model",
    "synapse_model",
    "RECORD_MAP",
]

#: Relative distance kept between ``tau_m`` and a synaptic time constant where they differ
#: for some neurons of a population only (Brian2's symbolic exact solution is singular there).
TAU_SEPARATION = 1e-6
#: Populations whose time constants are all within this relative distance count as equal.
_EQUAL_RTOL = 1e-12

# SI scale of each PyNN unit.
_MV, _MS, _NA, _NF, _US = 1e-3, 1e-3, 1e-9, 1e-9, 1e-6

# -- neuron templates ---------------------------------------------------------------------------

_CURR_V = "dv/dt = (v_rest - v)/tau_m + (I_E - I_I + i_offset{ca_term})/c_m : volt\n"
_CURR_SYN = "dI_E/dt = -I_E/{tau_E} : amp\ndI_I/dt = -I_I/{tau_I} : amp\n"
_CA_EQ = "dI_ca2/dt = -I_ca2/{tau_ca} : amp\ni_alpha : amp (constant)\n"
_COND_V = (
    "dv/dt = (v_rest - v)/tau_m + (f_E*g_E*(e_rev_E - v) + f_I*g_I*(e_rev_I - v) + i_offset)/c_m : volt\n"
    "dg_E/dt = -g_E/tau_syn_E : siemens\n"
    "dg_I/dt = -g_I/tau_syn_I : siemens\n"
    "e_rev_E : volt (constant)\n"
    "e_rev_I : volt (constant)\n"
    "f_E : 1 (constant)\n"
    "f_I : 1 (constant)\n"
)
_THETA_EQ = (
    "dtheta/dt = -learn*theta/tau_theta : volt\ntau_theta : second (constant)\ntheta_plus : volt (constant)\nlearn : 1 (shared)\n"
    "t_lock : second (constant)\n"
)
_COMMON = (
    "v_rest : volt (constant)\n"
    "v_reset : volt (constant)\n"
    "v_thresh : volt (constant)\n"
    "tau_m : second (constant)\n"
    "tau_syn_E : second (constant)\n"
    "tau_syn_I : second (constant)\n"
    "t_ref : second (constant)\n"
    "i_offset : amp (constant)\n"
    "c_m : farad (constant)\n"
)
_TAU_CA_PARAM = "tau_ca2 : second (constant)\n"

_THRESHOLD = "v >= v_thresh"
#: The spike lockout (``tau_lockout``): no spike until ``t_lock`` after the last one, whatever ``v`` does.
_THRESHOLD_THETA = "v >= v_thresh + theta and t - lastspike > t_lock"
_RESET = "v = v_reset"
_RESET_THETA = "v = v_reset\ntheta += learn*theta_plus"
_RESET_CA = "v = v_reset\nI_ca2 += i_alpha"
#: Run after the integration in every step: hold v at v_reset while refractory.
_CLAMP = "v = v_reset*(1 - int(not_refractory)) + v*int(not_refractory)"

#: Recordable variable -> (Brian2 variable, factor from SI to PyNN units).
RECORD_MAP: dict[str, tuple[str, float]] = {
    "v": ("v", 1 / _MV),
    "isyn_exc": ("I_E", 1 / _NA),
    "isyn_inh": ("I_I", 1 / _NA),
    "gsyn_exc": ("g_E", 1 / _US),
    "gsyn_inh": ("g_I", 1 / _US),
    "theta": ("theta", 1 / _MV),
    "i_ca2": ("I_ca2", 1 / _NA),
}


@dataclass(frozen=True, slots=True)
class NeuronModel:
    """Everything needed to build the ``NeuronGroup`` of one neuron population.

    Attributes
    ----------
    equations, threshold, reset, method
        Template text and Brian2 integration method.
    clamp
        Code run after the integration in every step (holds ``v`` while refractory).
    refractory
        Name of the per-neuron variable holding Brian2's refractory period.
    params
        ``{variable: SI values}`` of the constant per-neuron parameters.
    initial
        ``{variable: SI values}`` of the state at time 0 (also after ``reset()``).
    learned
        Names of learned variables kept by ``reset()`` (``theta``).
    adjusted
        Time constants moved by ``TAU_SEPARATION`` away from ``tau_m`` for some neurons.
    """

    equations: str
    threshold: str
    reset: str
    method: str
    clamp: str
    refractory: str
    params: dict[str, np.ndarray]
    initial: dict[str, np.ndarray]
    learned: tuple[str, ...] = ()
    adjusted: tuple[str, ...] = ()


def _tau_symbol(name: str, tau: np.ndarray, tau_m: np.ndarray) -> tuple[str, np.ndarray, bool]:
    """Template symbol for a current's decay constant and the (possibly separated) values.

    Returns ``("tau_m", tau, False)`` when the constant equals ``tau_m`` for every neuron,
    otherwise ``(name, values, adjusted)`` with values moved away from ``tau_m`` where needed.
    """
    rel = np.abs(tau - tau_m) / tau_m
    if np.all(rel <= _EQUAL_RTOL):
        return "tau_m", tau, False
    close = rel < TAU_SEPARATION
    if not np.any(close):
        return name, tau, False
    moved = tau.copy()
    sign = np.where(tau >= tau_m, 1.0, -1.0)
    moved[close] = tau_m[close] * (1.0 + sign[close] * TAU_SEPARATION)
    return name, moved, True


def neuron_model(cell: NeuronType, n: int, dt: float, v_init: Any) -> NeuronModel:
    """Translate a neuron cell type into a Brian2 template and SI values.

    Parameters
    ----------
    cell
        The population's cell type (a current- or conductance-based LIF).
    n
        Number of neurons.
    dt
        Time step (ms).
    v_init
        The population's ``v_init`` (``None`` for ``v_rest``).
    """
    if not isinstance(cell, (IF_curr_exp, IF_cond_exp, IF_cond_exp_adaptive, IF_curr_exp_ca2_adaptive)):
        raise UnsupportedFeatureError(f"Backend 'brian2' cannot run cell type {type(cell).__name__}.")
    get = {name: per_neuron(getattr(cell, name), n) for name in ("cm", "tau_m", "tau_refrac", "tau_syn_E", "tau_syn_I")}
    v_rest = per_neuron(cell.v_rest, n)
    refrac_steps = np.rint(get["tau_refrac"] / dt)
    params = {
        "v_rest": v_rest * _MV,
        "v_reset": per_neuron(cell.v_reset, n) * _MV,
        "v_thresh": per_neuron(cell.v_thresh, n) * _MV,
        "tau_m": get["tau_m"] * _MS,
        "tau_syn_E": get["tau_syn_E"] * _MS,
        "tau_syn_I": get["tau_syn_I"] * _MS,
        "t_ref": (refrac_steps + 1.0) * dt * _MS,
        "i_offset": per_neuron(cell.i_offset, n) * _NA,
        "c_m": get["cm"] * _NF,
    }
    v0 = v_rest if v_init is None else per_neuron(v_init, n)
    initial = {"v": v0 * _MV}
    learned: tuple[str, ...] = ()
    adjusted: list[str] = []
    if isinstance(cell, (IF_cond_exp, IF_cond_exp_adaptive)):
        equations = _COND_V + _COMMON
        params["e_rev_E"] = per_neuron(cell.e_rev_E, n) * _MV
        params["e_rev_I"] = per_neuron(cell.e_rev_I, n) * _MV
        initial.update(g_E=np.zeros(n), g_I=np.zeros(n))
        threshold, reset, method = _THRESHOLD, _RESET, "exponential_euler"
        if euler_integrated(cell):  # Brian2's forward Euler on the same equations, conductances at the step's start
            euler_time_constants(cell, n, dt)
            params["f_E"], params["f_I"], method = np.ones(n), np.ones(n), "euler"
        else:
            params["f_E"] = get["tau_syn_E"] / dt * -np.expm1(-dt / get["tau_syn_E"])
            params["f_I"] = get["tau_syn_I"] / dt * -np.expm1(-dt / get["tau_syn_I"])
        if isinstance(cell, IF_cond_exp_adaptive):
            equations += _THETA_EQ
            params["tau_theta"] = per_neuron(cell.tau_theta, n) * _MS
            params["theta_plus"] = per_neuron(cell.theta_plus, n) * _MV
            # the first step allowed to spike again is L = max(R, round(tau_lockout / dt)) steps after a spike, where
            # t - lastspike = L dt; half a step below that keeps the comparison clear of round-off
            lock_steps = np.maximum(refrac_steps, np.rint(per_neuron(cell.tau_lockout, n) / dt))
            params["t_lock"] = (lock_steps - 0.5) * dt * _MS
            initial["theta"] = per_neuron(cell.theta_init, n) * _MV
            threshold, reset, learned = _THRESHOLD_THETA, _RESET_THETA, ("theta",)
    else:
        tau_m = get["tau_m"]
        sym_e, tau_e, adj_e = _tau_symbol("tau_syn_E", get["tau_syn_E"], tau_m)
        sym_i, tau_i, adj_i = _tau_symbol("tau_syn_I", get["tau_syn_I"], tau_m)
        params["tau_syn_E"], params["tau_syn_I"] = tau_e * _MS, tau_i * _MS
        adjusted += ["tau_syn_E"] * adj_e + ["tau_syn_I"] * adj_i
        ca = isinstance(cell, IF_curr_exp_ca2_adaptive)
        equations = _CURR_V.format(ca_term=" - I_ca2" if ca else "") + _CURR_SYN.format(tau_E=sym_e, tau_I=sym_i)
        equations += _COMMON
        initial.update(I_E=np.zeros(n), I_I=np.zeros(n))
        threshold, reset, method = _THRESHOLD, _RESET, "exact"
        if ca:
            sym_c, tau_c, adj_c = _tau_symbol("tau_ca2", per_neuron(cell.tau_ca2, n), tau_m)
            equations += _CA_EQ.format(tau_ca=sym_c) + _TAU_CA_PARAM
            params["tau_ca2"] = tau_c * _MS
            params["i_alpha"] = per_neuron(cell.i_alpha, n) * _NA
            initial["I_ca2"] = per_neuron(cell.i_ca2, n) * _NA
            adjusted += ["tau_ca2"] * adj_c
            reset = _RESET_CA
    return NeuronModel(
        equations=equations,
        threshold=threshold,
        reset=reset,
        method=method,
        clamp=_CLAMP,
        refractory="t_ref",
        params=params,
        initial=initial,
        learned=learned,
        adjusted=tuple(adjusted),
    )


# -- synapse templates --------------------------------------------------------------------------

#: (conductance-based target, receptor) -> the neuron variable a spike increments.
_TARGETS = {
    (True, "excitatory"): "g_E",
    (True, "inhibitory"): "g_I",
    (False, "excitatory"): "I_E",
    (False, "inhibitory"): "I_I",
}

_STATIC_MODEL = "w : 1\n"
_STATIC_PRE = "{target}_post += w*w_unit"

# Plastic synapses keep their traces as plain variables with the time of their last
# update (``tpre``, ``tpost``) and decay them when they are read, in the semantics' time:
# presynaptic arrivals run at the start of the step in which they act (Brian2's ``t`` is
# then the arrival time), postsynaptic spikes in the step they are found (Brian2's ``t``
# is that step's start, the spike's time is ``t + dt``).
_PLASTIC_COMMON = (
    "w : 1\n"
    "w_min : 1 (shared, constant)\n"
    "w_max : 1 (shared, constant)\n"
    "plastic : 1 (shared)\n"
    "n_events : 1\n"
    "n_plastic : 1\n"
    "xpre : 1\n"
    "xpost : 1\n"
    "tpre : second\n"
    "tpost : second\n"
)
_PAIR_MODEL = (
    "tau_plus : second (shared, constant)\n"
    "tau_minus : second (shared, constant)\n"
    "A_plus : 1 (shared, constant)\n"
    "A_minus : 1 (shared, constant)\n"
)
#: Weight dependence -> (F-(w), F+(w)).
_PAIR_FACTORS = {
    "additive": ("w_max", "w_max"),
    "multiplicative": ("(w - w_min)", "(w_max - w)"),
}
# Arrival of a presynaptic spike: depression, then its current with the depressed weight
# (as NEST's stdp_synapse and sPyNNaker), then the presynaptic trace.
_PAIR_PRE = (
    "n_events += 1\n"
    "xpost_now = xpost*exp((tpost - t)/tau_minus)\n"
    "n_plastic += plastic*int(xpost_now != 0)\n"
    "w = clip(w - plastic*A_minus*{f_minus}*xpost_now, w_min, w_max)\n"
    "{target}_post += w*w_unit\n"
    "xpre = xpre*exp((tpre - t)/tau_plus) + 1\n"
    "tpre = t"
)
_PAIR_POST = (
    "t_spike = t + dt\n"
    "xpre_now = xpre*exp((tpre - t_spike)/tau_plus)\n"
    "n_plastic += plastic*int(xpre_now != 0)\n"
    "w = clip(w + plastic*A_plus*{f_plus}*xpre_now, w_min, w_max)\n"
    "xpost = xpost*exp((tpost - t_spike)/tau_minus) + 1\n"
    "tpost = t_spike"
)
_DC_MODEL = (
    "tau_xpre : second (shared, constant)\n"
    "tau_xpost : second (shared, constant)\n"
    "eta_dep : 1 (shared, constant)\n"
    "eta_pot : 1 (shared, constant)\n"
    "x_tar : 1 (shared, constant)\n"
    "mu : 1 (shared, constant)\n"
)
_DC_TRIPLET_MODEL = "xpost2 : 1\ntau_xpost2 : second (shared, constant)\n"
_DC_PRE = (
    "n_events += 1\n"
    "xpost_now = xpost*exp((tpost - t)/tau_xpost)\n"
    "n_plastic += plastic*int(xpost_now != 0)\n"
    "w = clip(w - plastic*eta_dep*xpost_now, w_min, w_max)\n"
    "{target}_post += w*w_unit\n"
    "xpre = 1\n"
    "tpre = t"
)
#: Pair form or triplet form (the second postsynaptic trace just before this spike).
_DC_TRIPLET = {False: ("", ""), True: ("*xpost2*exp((tpost - t_spike)/tau_xpost2)", "\nxpost2 = 1")}
_DC_POST = (
    "t_spike = t + dt\n"
    "factor = (xpre*exp((tpre - t_spike)/tau_xpre) - x_tar)*(w_max - w)**mu{y}\n"
    "n_plastic += plastic*int(factor != 0)\n"
    "w = clip(w + plastic*eta_pot*factor, w_min, w_max)\n"
    "xpost = 1{set_y}\n"
    "tpost = t_spike"
)


@dataclass(frozen=True, slots=True)
class SynapseModel:
    """Everything needed to build the ``Synapses`` of one projection.

    Attributes
    ----------
    model, on_pre, on_post
        Template text (``on_post`` is empty for static synapses).
    shared
        ``{variable: SI value}`` of the projection-wide constants.
    unit_si
        SI value of one unit of weight (1 uS or 1 nA).
    plastic
        Whether the template learns (has ``plastic``, ``n_events`` and ``n_plastic``).
    """

    model: str
    on_pre: str
    on_post: str
    shared: dict[str, float]
    unit_si: float
    plastic: bool


def synapse_model(synapse: Synapse, *, conductance: bool, receptor: str) -> SynapseModel:
    """Translate a synapse type into a Brian2 template and SI constants."""
    target = _TARGETS[(bool(conductance), receptor)]
    unit_si = _US if conductance else _NA
    if isinstance(synapse, StaticSynapse):
        return SynapseModel(_STATIC_MODEL, _STATIC_PRE.format(target=target), "", {}, unit_si, False)
    if isinstance(synapse, STDPMechanism):
        td, wd = synapse.timing_dependence, synapse.weight_dependence
        kind = "multiplicative" if isinstance(wd, MultiplicativeWeightDependence) else "additive"
        shared = {
            "w_min": wd.w_min,
            "w_max": wd.w_max,
            "tau_plus": td.tau_plus * _MS,
            "tau_minus": td.tau_minus * _MS,
            "A_plus": td.A_plus,
            "A_minus": td.A_minus,
        }
        f_minus, f_plus = _PAIR_FACTORS[kind]
        return SynapseModel(
            _PLASTIC_COMMON + _PAIR_MODEL,
            _PAIR_PRE.format(target=target, f_minus=f_minus),
            _PAIR_POST.format(f_plus=f_plus),
            shared,
            unit_si,
            True,
        )
    if isinstance(synapse, DiehlCookSTDP):
        shared = {
            "w_min": 0.0,
            "w_max": synapse.w_max,
            "tau_xpre": synapse.tau_pre * _MS,
            "tau_xpost": synapse.tau_post * _MS,
            # the template subtracts eta_dep x_post at an arrival: a potentiating pre term is a negative depression
            "eta_dep": synapse.eta_pre if synapse.pre_term == "depress" else -synapse.eta_pre,
            "eta_pot": synapse.eta_post,
            "x_tar": synapse.x_tar,
            "mu": synapse.mu,
        }
        triplet = synapse.tau_post2 is not None
        model = _PLASTIC_COMMON + _DC_MODEL + (_DC_TRIPLET_MODEL if triplet else "")
        if triplet:
            shared["tau_xpost2"] = synapse.tau_post2 * _MS  # type: ignore[operator]
        y, set_y = _DC_TRIPLET[triplet]
        on_post = _DC_POST.format(y=y, set_y=set_y)
        return SynapseModel(model, _DC_PRE.format(target=target), on_post, shared, unit_si, True)
    raise UnsupportedFeatureError(f"Backend 'brian2' cannot run synapse type {type(synapse).__name__}.")
