"""The graph of one Modular SNN module (Hussaini, Milford & Fischer, IEEE T-RO 2024).

A module is the three-layer network of Diehl & Cook (2015)::

    pixels (784 Poisson sources, one per pixel of the 28x28 patch-normalised image)
      --[all-to-all, DiehlCookSTDP, excitatory]--> exc (400 IF_cond_exp_adaptive)
    exc --[one-to-one, W_EI = 10.4]--> inh (400 IF_cond_exp)
    inh --[all-to-all but the partner, W_IE = 17.0, inhibitory]--> exc

Units. The published code (QVPR/VPRSNN, ``non_modular_snn/snn_model.py``) writes the
membrane equation as ``tau dv/dt = (v_rest - v) + g_E (E_exc - v) + g_I (E_inh - v)``
with dimensionless conductances, i.e. conductances in units of the leak conductance.
In PyNN units this is ``cm = tau_m`` (nF = ms, so ``g_leak = cm / tau_m = 1 uS``) and
weights in uS; :func:`build_module` does exactly that.

Parameters (defaults = the authors' published code, QVPR/VPRSNN
``non_modular_snn/snn_model.py``, where it and the paper's text differ; see
:mod:`neurovpr.models.modular_snn` for the list): tau_e 100 ms, E_rest,e -65 mV,
tau_i 10 ms, E_rest,i -60 mV, E_exc 0 mV, E_inh,e -100 mV, E_inh,i -85 mV, tau_ge 1 ms,
tau_gi 0.5 ms; theta_plus 0.05 mV, tau_theta 1e7 ms; v_thresh,e -52 mV with theta
starting at 0 (the code's theta starts at 20 mV and its threshold subtracts a 20 mV
offset, which is the same threshold), v_reset,e -65 mV, v_reset,i -45 mV,
v_thresh,i -40 mV, refractory 2 ms (inh); initial weights ``(U(0, 1) + 0.01) * 0.3`` =
U(0.003, 0.303), input delays U(0, 10) ms (here U(dt_min, 10) with ``dt_min`` = 0.1 ms,
the simulator's minimum delay at the default step, Brian2's 0.1 ms; Brian2 rounds shorter
delays to whole steps as well).

Recurrent delays. The code's ``exc -> inh`` and ``inh -> exc`` synapses have no delay: in
Brian2 a spike's ``on_pre`` runs in the step the neuron fires, so the partner inhibitory
neuron feels it in the next step and the excitatory layer the inhibition one step after
that (0.2 ms at dt 0.1 ms). ``delay_recurrent = 0`` (default) makes them zero-delay synapses
with exactly that timing (docs/semantics.md); a delay of one step (``delay_recurrent = dt``,
the behaviour before) closes the loop two steps later, and on nordland64 lets about 1.5 times
as many excitatory spikes per image as the authors' code (0.81 against 0.54 per neuron and
query image; 0.64 at dt 0.05 ms, 0.61 with zero delays; ``benchmarks/modular_snn_vs_authors.py``).

Excitatory refractoriness. The code clamps the membrane for ``refrac_e`` = 5 ms
(``(unless refractory)``) but tests the threshold together with ``timer > refrac_e``,
where ``dtimer/dt = 0.1`` and ``timer = 0`` at a spike: a neuron cannot fire again for
50 ms. Here that is ``IF_cond_exp_adaptive(tau_refrac=refrac_e, tau_lockout=lockout_e)``
with ``refrac_e = 5``, ``lockout_e = 50`` (``lockout_e = 0`` gives the paper's 5 ms).

Integration. The code integrates every equation with Brian2's ``method='euler'`` at dt 0.1 ms:
its conductances decay by ``1 - dt / tau`` per step (0.9 for ``tau_ge`` = 1 ms, 0.8 for
``tau_gi`` = 0.5 ms, against the exact 0.905 and 0.819) and act with their values at the step's
start, and its membranes move by ``dt / cm`` times their current. ``integration="euler"``
(default) is exactly that step for both layers (docs/semantics.md). What it changes most is the
inhibitory membrane: an excitatory spike gives it 10.4 times its leak conductance, and the
Euler factor ``1 - dt g / cm`` (0.886) moves it faster than the exact ``exp(-dt g / cm)``
(0.892), so the inhibition loop closes sooner. On the oracle subset the exact step
(``integration="exact"``, the model before) fired 1.13 / 1.10 times as often as the code per
query / reference image; Euler steps bring that to 0.97 / 0.96
(``benchmarks/modular_snn_vs_authors.py --integration exact|euler``).

Learning rule. ``stdp="code"`` (default) is the code's triplet rule,
``DiehlCookSTDP(pre_term="potentiate", mu=0, x_tar=0, tau_post2=40)``: at a presynaptic
arrival ``w += eta_pre * x_post`` (a potentiation: the code writes ``w + nu_ee_pre *
post1``, where Diehl & Cook's own code subtracts), at a postsynaptic spike
``w += eta_post * x_pre * x_post2`` (``x_post2`` just before the spike), traces set to
1, weights clipped to ``[0, w_max]``. ``stdp="paper"`` is the paper's equation,
``DiehlCookSTDP(eta_pre, eta_post, w_max, mu=1)``: depression ``eta_pre * x_post`` at a
presynaptic spike, potentiation ``eta_post * x_pre * (w_max - w) ** mu`` at a
postsynaptic spike. The code applies the presynaptic update after delivering the spike
with the old weight; the IR updates first (a difference of at most ``eta_pre`` = 1e-4
in one delivered weight).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from types import MappingProxyType
from typing import Any

import numpy as np

import neurovpr as nv

__all__ = ["ModuleParameters", "build_module", "INPUT", "EXC", "INH", "INPUT_PROJECTION"]

#: Population names of a module.
INPUT, EXC, INH = "pixels", "exc", "inh"
#: Name of the learned projection.
INPUT_PROJECTION = f"{INPUT}->{EXC}"

_STDP_FORMS = ("code", "paper")
#: Parameters added after the first saved runs, with the value they had before; :meth:`ModuleParameters.as_dict`
#: leaves them out at that value.
_LATER_SWITCHES = MappingProxyType({"integration": "exact"})


@dataclass(frozen=True, slots=True, kw_only=True)
class ModuleParameters:
    """Every parameter of one module's graph (defaults: see the module docstring)."""

    n_input: int = 784
    n_neurons: int = 400
    # excitatory layer
    tau_e: float = 100.0
    v_rest_e: float = -65.0
    v_reset_e: float = -65.0
    v_thresh_e: float = -52.0
    refrac_e: float = 5.0
    lockout_e: float = 50.0
    e_exc: float = 0.0
    e_inh_e: float = -100.0
    theta_plus: float = 0.05
    tau_theta: float = 1e7
    # inhibitory layer
    tau_i: float = 10.0
    v_rest_i: float = -60.0
    v_reset_i: float = -45.0
    v_thresh_i: float = -40.0
    refrac_i: float = 2.0
    e_inh_i: float = -85.0
    # synapses
    tau_ge: float = 1.0
    tau_gi: float = 0.5
    w_ei: float = 10.4
    w_ie: float = 17.0
    delay_recurrent: float = 0.0
    integration: str = "euler"
    w_init_low: float = 0.003
    w_init_high: float = 0.303
    delay_min: float = 0.1
    delay_max: float = 10.0
    # learning
    stdp: str = "code"
    eta_pre: float = 1e-4
    eta_post: float = 1e-2
    w_max: float = 1.0
    mu: float = 1.0
    tau_pre: float = 20.0
    tau_post: float = 20.0
    tau_post2: float = 40.0

    def __post_init__(self) -> None:
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            if f.name == "stdp":
                if value not in _STDP_FORMS:
                    raise nv.ValidationError(f"ModuleParameters.stdp is {value!r}, expected one of {', '.join(_STDP_FORMS)}.")
                continue
            if f.name == "integration":
                if value not in nv.INTEGRATIONS:
                    raise nv.ValidationError(
                        f"ModuleParameters.integration is {value!r}, expected one of {', '.join(nv.INTEGRATIONS)}."
                    )
                continue
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
                raise nv.ValidationError(f"ModuleParameters.{f.name} must be a finite number, got {value!r}.")
        for name in ("n_input", "n_neurons"):
            value = getattr(self, name)
            if int(value) != value or not 1 <= value <= 100_000:
                raise nv.ValidationError(f"ModuleParameters.{name} is {value!r}, expected an integer in 1..100000.")
        positive = ("tau_e", "tau_i", "tau_ge", "tau_gi", "tau_theta", "w_max", "tau_pre", "tau_post", "tau_post2")
        for name in positive:
            if getattr(self, name) <= 0:
                raise nv.ValidationError(f"ModuleParameters.{name} must be > 0, got {getattr(self, name)!r}.")
        nonneg = (
            "refrac_e", "lockout_e", "refrac_i", "theta_plus", "w_ei", "w_ie", "delay_recurrent", "eta_pre", "eta_post", "mu",
            "w_init_low",
        )  # fmt: skip
        for name in nonneg:
            if getattr(self, name) < 0:
                raise nv.ValidationError(f"ModuleParameters.{name} must be >= 0, got {getattr(self, name)!r}.")
        if not self.w_init_low < self.w_init_high <= self.w_max:
            raise nv.ValidationError(
                f"ModuleParameters initial weights U({self.w_init_low}, {self.w_init_high}) must lie within "
                f"[0, w_max={self.w_max}] with low < high."
            )
        if self.delay_max != 0 and not 0 < self.delay_min < self.delay_max:
            raise nv.ValidationError(
                f"ModuleParameters input delays U({self.delay_min}, {self.delay_max}) ms need 0 < delay_min < delay_max "
                "(or delay_max = 0 for no delays)."
            )

    def replace(self, **changes: Any) -> ModuleParameters:
        """A copy with some parameters changed (validated again)."""
        return dataclasses.replace(self, **changes)

    def as_dict(self) -> dict[str, Any]:
        """A JSON-ready copy of every parameter.

        Parameters added after runs were first saved (:data:`_LATER_SWITCHES`) are written
        only when they differ from the value they had before: the settings of a run, and so
        the fingerprints that let it resume and be evaluated, stay what they were before the
        parameter existed (:meth:`from_dict` gives an absent one that value).
        """
        out = dataclasses.asdict(self)
        for name, before in _LATER_SWITCHES.items():
            if out[name] == before:
                del out[name]
        return out

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> ModuleParameters:
        """Parameters from :meth:`as_dict` output; unknown keys are refused.

        A parameter of :data:`_LATER_SWITCHES` that is absent takes the value it had before it
        existed (settings saved earlier describe the model they were run with).
        """
        if not isinstance(data, dict):
            raise nv.ValidationError(f"module parameters must be a JSON object, got {type(data).__name__}.")
        known = {f.name for f in dataclasses.fields(cls)}
        unknown = sorted(set(data) - known)
        if unknown:
            raise nv.ValidationError(f"module parameters contain unknown key {unknown[0]!r}.")
        return cls(**{**_LATER_SWITCHES, **data})

    def learning_rule(self, seed: int | None = None, delay_seed: int | None = None) -> nv.DiehlCookSTDP:
        """The input projection's synapse: initial weights, delays and the chosen STDP form (``mu`` is the paper's).

        With ``seed``, the initial weights and delays are drawn here, from
        ``numpy.random.default_rng([seed, 0])``, and stored in the graph as
        ``(n_input, n_neurons)`` arrays, so a saved module keeps its delays whatever
        seed it is compiled with later; ``delay_seed`` draws the delays apart, from
        ``numpy.random.default_rng([delay_seed, 1])`` (the authors' code draws its weights
        with NumPy and its delays with Brian2's generator). Without ``seed`` they are
        distributions that ``nv.compile`` resolves with its own seed.
        """
        delay: Any = None
        if seed is None:
            weight: Any = nv.Uniform(low=self.w_init_low, high=self.w_init_high)
            if self.delay_max > 0:
                delay = nv.Uniform(low=self.delay_min, high=self.delay_max)
        else:
            rng = np.random.default_rng([int(seed), 0])
            shape = (self.n_input, self.n_neurons)
            weight = rng.uniform(self.w_init_low, self.w_init_high, size=shape)
            if self.delay_max > 0:
                source = rng if delay_seed is None else np.random.default_rng([int(delay_seed), 1])
                delay = source.uniform(self.delay_min, self.delay_max, size=shape)
        common = {
            "weight": weight,
            "delay": delay,
            "eta_pre": self.eta_pre,
            "eta_post": self.eta_post,
            "w_max": self.w_max,
            "tau_pre": self.tau_pre,
            "tau_post": self.tau_post,
        }
        if self.stdp == "code":
            return nv.DiehlCookSTDP(mu=0.0, x_tar=0.0, tau_post2=self.tau_post2, pre_term="potentiate", **common)
        return nv.DiehlCookSTDP(mu=self.mu, **common)


def build_module(
    params: ModuleParameters | None = None,
    *,
    seed: int | None = None,
    delay_seed: int | None = None,
    name: str = "modular_snn_module",
    v_init_e: float | None = None,
    v_init_i: float | None = None,
) -> nv.Network:
    """The graph of one module.

    Parameters
    ----------
    params
        The parameters (paper defaults when omitted).
    seed
        Draw the initial input weights and delays now (see
        :meth:`ModuleParameters.learning_rule`); ``None`` leaves them to ``nv.compile``.
    delay_seed
        With ``seed``: draw the delays from this seed instead of with the weights.
    name
        Network name.
    v_init_e, v_init_i
        Initial membrane potentials (default: the resting potentials). The published
        code starts both layers 40 mV below rest; with ``reset()`` between images the
        resting potential is the right starting point (see :mod:`.training`).
    """
    p = params or ModuleParameters()
    tau_e, tau_i = p.tau_ge, p.tau_gi
    net = nv.Network(name)
    net.add_population(INPUT, p.n_input, nv.SpikeSourcePoisson(rate=0.0))
    exc = nv.IF_cond_exp_adaptive(
        cm=p.tau_e, tau_m=p.tau_e, v_rest=p.v_rest_e, v_reset=p.v_reset_e, v_thresh=p.v_thresh_e,
        tau_refrac=p.refrac_e, tau_lockout=p.lockout_e, tau_syn_E=tau_e, tau_syn_I=tau_i, e_rev_E=p.e_exc,
        e_rev_I=p.e_inh_e, theta_plus=p.theta_plus, tau_theta=p.tau_theta, theta_init=0.0, integration=p.integration,
    )  # fmt: skip
    inh = nv.IF_cond_exp(
        cm=p.tau_i, tau_m=p.tau_i, v_rest=p.v_rest_i, v_reset=p.v_reset_i, v_thresh=p.v_thresh_i,
        tau_refrac=p.refrac_i, tau_syn_E=tau_e, tau_syn_I=tau_i, e_rev_E=p.e_exc, e_rev_I=p.e_inh_i,
        integration=p.integration,
    )  # fmt: skip
    net.add_population(EXC, p.n_neurons, exc, v_init=v_init_e)
    net.add_population(INH, p.n_neurons, inh, v_init=v_init_i)
    net.connect(INPUT, EXC, nv.AllToAllConnector(), p.learning_rule(seed, delay_seed), receptor_type="excitatory")
    recurrent = p.delay_recurrent
    net.connect(EXC, INH, nv.OneToOneConnector(), nv.StaticSynapse(weight=p.w_ei, delay=recurrent), receptor_type="excitatory")
    net.connect(
        INH, EXC, nv.AllToAllConnector(allow_self_connections=False), nv.StaticSynapse(weight=p.w_ie, delay=recurrent),
        receptor_type="inhibitory", name="lateral",
    )  # fmt: skip
    return net
