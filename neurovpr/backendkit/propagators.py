"""Exact-integration propagators of the spiking cell types, per neuron (docs/semantics.md, "Neurons").

Over one step ``dt`` the subthreshold system of a current-based neuron is linear and is
advanced exactly (NEST's and sPyNNaker's exact integration); a conductance-based neuron's
conductances decay exponentially within the step and its membrane is advanced exactly
with their step means. :func:`propagators` gives every factor both need, one value per
neuron, so that every backend integrating this way computes with the same numbers.

A conductance-based neuron with ``integration="euler"`` takes forward-Euler steps instead
(Brian2's ``method='euler'``): its decays are ``1 - dt / tau``, its conductances act with
their values at the step's start (``fe = fi = 1``), ``i_offset`` moves the membrane by
``dt / cm`` per nA, and a backend multiplies the distance to the step's equilibrium by
``1 - dt g / cm`` instead of ``exp(-dt g / cm)`` (:func:`neurovpr.ir.cells.euler_integrated`).
"""

from __future__ import annotations

import numpy as np

from neurovpr.errors import ValidationError
from neurovpr.ir.cells import IF_cond_exp, IF_cond_exp_adaptive, IF_curr_exp, IF_curr_exp_ca2_adaptive, euler_integrated

from .params import per_neuron

__all__ = ["PROPAGATORS", "euler_time_constants", "propagators", "psc_propagator"]

#: The names :func:`propagators` returns.
PROPAGATORS = (
    "v_rest", "v_reset", "v_thresh", "i_offset",
    "p22",  # exp(-dt/tau_m)
    "p20",  # (tau_m/cm)(1 - p22): i_offset -> v
    "p11e", "p11i",  # exp(-dt/tau_syn_X)
    "p21e", "p21i",  # I_X(t) -> v over one step (current-based)
    "fe", "fi",  # mean of a decaying conductance over one step, relative to its start value
    "gl", "cm",  # leak conductance cm/tau_m, capacitance
    "e_rev_e", "e_rev_i",
    "theta_plus", "theta_decay",  # exp(-dt/tau_theta)
    "p11ca", "p21ca", "i_alpha",  # exp(-dt/tau_ca2), I_ca2 -> v, its jump per spike
    "refrac",  # refractory steps (membrane held at v_reset)
    "lock",  # steps after the refractory ones in which the membrane integrates but may not fire
    "v_init", "i_ca_init",
)  # fmt: skip


def psc_propagator(dt: float, tau_s: np.ndarray, tau_m: np.ndarray, cm: np.ndarray) -> np.ndarray:
    """Exact effect on v after one step of an exponentially decaying current of 1 nA."""
    a = 1.0 / tau_m - 1.0 / tau_s
    out = np.empty_like(tau_s)
    small = np.abs(a * dt) < 1e-8
    out[small] = dt * np.exp(-dt / tau_m[small]) / cm[small]
    big = ~small
    out[big] = np.exp(-dt / tau_m[big]) * np.expm1(dt * a[big]) / (a[big] * cm[big])
    return out


def euler_time_constants(cell: IF_cond_exp | IF_cond_exp_adaptive, n: int, dt: float) -> dict[str, np.ndarray]:
    """The time constants a forward-Euler step decays with, per neuron; each must exceed ``dt``.

    Raises
    ------
    ValidationError
        Naming the cell, the shortest offending time constant and ``dt``.
    """
    names = ("tau_m", "tau_syn_E", "tau_syn_I") + (("tau_theta",) if isinstance(cell, IF_cond_exp_adaptive) else ())
    taus = {name: per_neuron(getattr(cell, name), n) for name in names}
    for name, tau in taus.items():
        if np.any(tau <= dt):
            raise ValidationError(
                f"{type(cell).__name__}(integration='euler').{name} = {float(tau.min())!r} ms needs a time step "
                f"below it, got dt = {dt!r} ms."
            )
    return taus


def _euler(cell: IF_cond_exp | IF_cond_exp_adaptive, n: int, dt: float, out: dict[str, np.ndarray]) -> None:
    """Replace the exact factors in ``out`` by the forward-Euler ones."""
    taus = euler_time_constants(cell, n, dt)
    out["p22"] = 1.0 - dt / taus["tau_m"]
    out["p20"] = dt / per_neuron(cell.cm, n)
    out["p11e"] = 1.0 - dt / taus["tau_syn_E"]
    out["p11i"] = 1.0 - dt / taus["tau_syn_I"]
    out["fe"] = np.ones(n)
    out["fi"] = np.ones(n)
    if "tau_theta" in taus:
        out["theta_decay"] = 1.0 - dt / taus["tau_theta"]


def propagators(cell: object, n: int, dt: float, v_init: object = None) -> dict[str, np.ndarray]:
    """Every factor of :data:`PROPAGATORS` for ``n`` neurons of a spiking ``cell`` type (0 where it has none)."""
    assert isinstance(cell, (IF_curr_exp, IF_cond_exp, IF_cond_exp_adaptive, IF_curr_exp_ca2_adaptive))
    out = {name: np.zeros(n) for name in PROPAGATORS}
    g = {name: per_neuron(getattr(cell, name), n) for name in ("cm", "tau_m", "tau_refrac", "tau_syn_E", "tau_syn_I")}
    out["v_rest"] = per_neuron(cell.v_rest, n)
    out["v_reset"] = per_neuron(cell.v_reset, n)
    out["v_thresh"] = per_neuron(cell.v_thresh, n)
    out["i_offset"] = per_neuron(cell.i_offset, n)
    out["p22"] = np.exp(-dt / g["tau_m"])
    out["p20"] = g["tau_m"] / g["cm"] * -np.expm1(-dt / g["tau_m"])
    out["p11e"] = np.exp(-dt / g["tau_syn_E"])
    out["p11i"] = np.exp(-dt / g["tau_syn_I"])
    out["p21e"] = psc_propagator(dt, g["tau_syn_E"], g["tau_m"], g["cm"])
    out["p21i"] = psc_propagator(dt, g["tau_syn_I"], g["tau_m"], g["cm"])
    out["fe"] = g["tau_syn_E"] / dt * -np.expm1(-dt / g["tau_syn_E"])
    out["fi"] = g["tau_syn_I"] / dt * -np.expm1(-dt / g["tau_syn_I"])
    out["gl"] = g["cm"] / g["tau_m"]
    out["cm"] = g["cm"]
    out["refrac"] = np.rint(g["tau_refrac"] / dt)
    out["theta_decay"] = np.ones(n)
    out["p11ca"] = np.ones(n)
    out["v_init"] = out["v_rest"].copy() if v_init is None else per_neuron(v_init, n)
    if isinstance(cell, (IF_cond_exp, IF_cond_exp_adaptive)):
        out["e_rev_e"] = per_neuron(cell.e_rev_E, n)
        out["e_rev_i"] = per_neuron(cell.e_rev_I, n)
    if isinstance(cell, IF_cond_exp_adaptive):
        out["theta_plus"] = per_neuron(cell.theta_plus, n)
        out["theta_decay"] = np.exp(-dt / per_neuron(cell.tau_theta, n))
        out["lock"] = np.maximum(np.rint(per_neuron(cell.tau_lockout, n) / dt) - out["refrac"], 0.0)
    if euler_integrated(cell):
        _euler(cell, n, dt, out)  # type: ignore[arg-type]
    if isinstance(cell, IF_curr_exp_ca2_adaptive):
        tau_ca = per_neuron(cell.tau_ca2, n)
        out["p11ca"] = np.exp(-dt / tau_ca)
        out["p21ca"] = psc_propagator(dt, tau_ca, g["tau_m"], g["cm"])
        out["i_alpha"] = per_neuron(cell.i_alpha, n)
        out["i_ca_init"] = per_neuron(cell.i_ca2, n)
    return out
