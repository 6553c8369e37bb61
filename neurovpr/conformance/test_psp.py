"""Membrane traces after a single input spike, against the exact (or high-precision) solution."""

from __future__ import annotations

import numpy as np
import pytest

import neurovpr as nv

from .analytic import conductance_psp, current_psp

DT = 0.1
T_STOP = 60.0
T_SPIKE = 5.0
DELAY = 1.0
T_ARRIVAL = T_SPIKE + DELAY


def _single_spike_network(cell: nv.IF_curr_exp | nv.IF_cond_exp, weight: float, receptor: str) -> nv.Network:
    net = nv.Network("psp")
    net.add_population("src", 1, nv.SpikeSourceArray.from_lists([[T_SPIKE]]))
    net.add_population("post", 1, cell)
    net.connect("src", "post", nv.AllToAllConnector(), nv.StaticSynapse(weight=weight, delay=DELAY), receptor_type=receptor)
    return net


def _recorded_v(backend, net: nv.Network, case: str) -> tuple[np.ndarray, np.ndarray]:
    sim = backend.compile(net, case=case, dt=DT, recordables=("v",))
    sim.record("post", "v")
    sim.run(T_STOP)
    t, v = sim.trace("post", "v")
    n = round(T_STOP / DT)
    assert v.shape == (n, 1)
    np.testing.assert_allclose(t, np.arange(1, n + 1) * DT, rtol=0, atol=1e-9)
    assert sim.spike_counts("post").sum() == 0
    return t, v[:, 0]


@pytest.mark.parametrize(
    ("tau_m", "tau_syn", "receptor", "case"),
    [
        (10.0, 2.0, "excitatory", "psp_curr"),
        (5.0, 8.0, "inhibitory", "psp_curr"),
        (10.0, 10.0, "excitatory", "psp_curr_equal_tau"),
        (7.0, 7.0, "inhibitory", "psp_curr_equal_tau"),
    ],
)
def test_current_psp_is_exact(backend, tau_m, tau_syn, receptor, case):
    """``IF_curr_exp`` after one spike of weight ``w`` arriving at ``t_a = t_spike + delay``:

    ``v(t) = v_rest + sign w R tau_s / (tau_m - tau_s) (exp(-s / tau_m) - exp(-s / tau_s))``,
    ``s = t - t_a``, ``R = tau_m / cm``; for ``tau_s == tau_m``: ``v_rest + sign (w / cm) s exp(-s / tau_m)``;
    ``sign = -1`` on the inhibitory receptor. Exact integration reproduces it at every
    recorded step end.
    """
    cm, weight, v_rest = 0.5, 1.0, -65.0
    cell = nv.IF_curr_exp(cm=cm, tau_m=tau_m, tau_syn_E=tau_syn, tau_syn_I=tau_syn, v_rest=v_rest)
    t, v = _recorded_v(backend, _single_spike_network(cell, weight, receptor), case)
    sign = 1.0 if receptor == "excitatory" else -1.0
    expected = v_rest + sign * current_psp(t - T_ARRIVAL, weight=weight, tau_m=tau_m, tau_syn=tau_syn, cm=cm)
    peak = np.max(np.abs(expected - v_rest))
    assert peak > 1.0
    np.testing.assert_allclose(v[t <= T_ARRIVAL + 1e-9], v_rest, rtol=0, atol=1e-9)
    np.testing.assert_allclose(v, expected, rtol=0, atol=backend.tol(case).trace_rel * peak)


@pytest.mark.parametrize(("receptor", "e_rev"), [("excitatory", 0.0), ("inhibitory", -80.0)])
def test_conductance_psp(backend, receptor, e_rev):
    """``IF_cond_exp`` after one spike of weight ``w`` (uS) arriving at ``t_a``.

    ``cm dv/dt = cm (v_rest - v) / tau_m + g (e_rev - v)``, ``g = w exp(-(t - t_a) / tau_syn)``
    for ``t >= t_a``, solved with DOP853 at ``rtol = 1e-12``. The semantics' step
    (exponential Euler on the step's mean conductance) errs by about
    ``(dt / tau_syn)**2 / 48`` of the peak.
    """
    case = "psp_cond"
    cm, tau_m, tau_syn, weight, v_rest = 1.0, 20.0, 5.0, 0.05, -65.0
    cell = nv.IF_cond_exp(
        cm=cm, tau_m=tau_m, tau_syn_E=tau_syn, tau_syn_I=tau_syn, e_rev_E=0.0, e_rev_I=-80.0,
        v_rest=v_rest, v_reset=-70.0, v_thresh=-20.0,
    )
    t, v = _recorded_v(backend, _single_spike_network(cell, weight, receptor), case)
    expected = conductance_psp(t - T_ARRIVAL, weight=weight, tau_m=tau_m, tau_syn=tau_syn, cm=cm, v_rest=v_rest, e_rev=e_rev)
    peak = np.max(np.abs(expected - v_rest))
    assert peak > 0.5
    np.testing.assert_allclose(v[t <= T_ARRIVAL + 1e-9], v_rest, rtol=0, atol=1e-9)
    np.testing.assert_allclose(v, expected, rtol=0, atol=backend.tol(case).cond_trace_rel * peak)


@pytest.mark.parametrize(
    ("cell", "variable", "receptor"),
    [
        (nv.IF_curr_exp(tau_syn_E=3.0, tau_syn_I=6.0), "isyn_exc", "excitatory"),
        (nv.IF_curr_exp(tau_syn_E=3.0, tau_syn_I=6.0), "isyn_inh", "inhibitory"),
        (nv.IF_cond_exp(tau_syn_E=3.0, tau_syn_I=6.0, v_thresh=-20.0), "gsyn_exc", "excitatory"),
        (nv.IF_cond_exp(tau_syn_E=3.0, tau_syn_I=6.0, v_thresh=-20.0), "gsyn_inh", "inhibitory"),
    ],
    ids=["isyn_exc", "isyn_inh", "gsyn_exc", "gsyn_inh"],
)
def test_synaptic_variable_trace(backend, cell, variable, receptor):
    """The recorded synaptic current (nA) or conductance (uS) is ``w exp(-(t - t_a) / tau_syn)``
    after the arrival ``t_a`` and 0 before it (the jump instant itself is not compared)."""
    case = "synaptic_trace"
    weight = 0.04
    sim = backend.compile(_single_spike_network(cell, weight, receptor), case=case, dt=DT, recordables=(variable,))
    sim.record("post", variable)
    sim.run(T_STOP)
    t, x = sim.trace("post", variable)
    tau = cell.tau_syn_E if receptor == "excitatory" else cell.tau_syn_I
    expected = np.where(t > T_ARRIVAL, weight * np.exp(-(t - T_ARRIVAL) / tau), 0.0)
    compare = np.abs(t - T_ARRIVAL) > 1e-6
    np.testing.assert_allclose(
        x[compare, 0], expected[compare], rtol=0, atol=backend.tol(case).trace_rel * weight
    )
