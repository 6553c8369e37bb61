"""Forward-Euler integration of the conductance-based cells (``integration="euler"``)."""

from __future__ import annotations

import numpy as np
import pytest

import neurovpr as nv

from .analytic import euler_conductance_psp, euler_grid_spike_times, lif_grid_spike_times

DT = 0.1
T_STOP = 100.0
#: A short membrane time constant (dt / tau_m = 0.1), so that Euler and exact steps part visibly.
LIF = {"cm": 1.0, "tau_m": 1.0, "tau_refrac": 1.0, "v_rest": -65.0, "v_reset": -70.0, "v_thresh": -50.0, "i_offset": 17.0}
T_SPIKE, DELAY = 5.0, 1.0
T_ARRIVAL = T_SPIKE + DELAY


def _by_neuron(times: np.ndarray, idx: np.ndarray, n: int) -> list[np.ndarray]:
    return [times[idx == i] for i in range(n)]


@pytest.mark.parametrize("cell_type", [nv.IF_cond_exp, nv.IF_cond_exp_adaptive])
def test_euler_spike_times_under_constant_current(backend, cell_type):
    """Constant drive: every spike where the Euler closed form ``v_inf - (v_inf - v0) (1 - dt / tau_m)^k``
    first reaches threshold (:func:`analytic.euler_grid_spike_times`), which here fires more often
    than the exact solution (30 spikes in 100 ms against 29, each earlier), so an exactly integrating
    backend fails."""
    case = "euler_integration"
    net = nv.Network("euler_lif")
    extra = {"theta_plus": 0.0} if cell_type is nv.IF_cond_exp_adaptive else {}
    net.add_population("lif", 1, cell_type(integration="euler", **LIF, **extra))
    sim = backend.compile(net, case=case, dt=DT)
    sim.run(T_STOP)
    got = sim.spike_trains("lif")[0]
    expected = euler_grid_spike_times(dt=DT, t_stop=T_STOP, **LIF)
    exact = lif_grid_spike_times(dt=DT, t_stop=T_STOP, **LIF)
    # Euler: 2.1, 5.4, 8.7, ... ms (30 spikes); exact: 2.2, 5.6, 9.0, ... ms (29 spikes)
    assert expected.size > exact.size and expected[exact.size - 1] < exact[-1] - 2.0, "the case must tell Euler from exact"
    assert got.size == expected.size, f"{got.size} spikes, expected {expected.size} (exact steps give {exact.size})"
    np.testing.assert_allclose(got, expected, rtol=0, atol=backend.tol(case).spike_time_ms)


@pytest.mark.parametrize(("receptor", "e_rev"), [("excitatory", 0.0), ("inhibitory", -80.0)])
def test_euler_conductance_psp(backend, receptor, e_rev):
    """One input spike of conductance ``w`` arriving at ``t_a``: the recorded membrane and conductance
    follow the Euler difference equations from ``(v_rest, w)`` (:func:`analytic.euler_conductance_psp`),
    the conductance ``w (1 - dt / tau_syn)^k``; both differ from the exact step by far more than the bound."""
    case = "euler_integration"
    cm, tau_m, tau_syn, weight, v_rest = 1.0, 4.0, 0.5, 0.4, -65.0
    cell = nv.IF_cond_exp(
        cm=cm, tau_m=tau_m, tau_syn_E=tau_syn, tau_syn_I=tau_syn, e_rev_E=0.0, e_rev_I=-80.0,
        v_rest=v_rest, v_reset=-90.0, v_thresh=-20.0, integration="euler",
    )  # fmt: skip
    variable = "gsyn_exc" if receptor == "excitatory" else "gsyn_inh"
    net = nv.Network("euler_psp")
    net.add_population("src", 1, nv.SpikeSourceArray.from_lists([[T_SPIKE]]))
    net.add_population("post", 1, cell)
    net.connect("src", "post", nv.AllToAllConnector(), nv.StaticSynapse(weight=weight, delay=DELAY), receptor_type=receptor)
    sim = backend.compile(net, case=case, dt=DT, recordables=("v", variable))
    sim.record("post", "v")
    sim.record("post", variable)
    sim.run(40.0)
    t, v = sim.trace("post", "v")
    _, g = sim.trace("post", variable)
    after = t > T_ARRIVAL + 1e-9
    n = int(after.sum())
    v_exp, g_exp = euler_conductance_psp(n, dt=DT, weight=weight, tau_m=tau_m, tau_syn=tau_syn, cm=cm, v_rest=v_rest, e_rev=e_rev)
    peak = np.max(np.abs(v_exp - v_rest))
    tol = backend.tol(case)
    np.testing.assert_allclose(v[~after, 0], v_rest, rtol=0, atol=1e-9)
    np.testing.assert_allclose(v[after, 0], v_exp, rtol=0, atol=tol.trace_rel * peak)
    np.testing.assert_allclose(g[after, 0], g_exp, rtol=0, atol=tol.trace_rel * weight)
    exact_g = weight * np.exp(-(t[after] - T_ARRIVAL) / tau_syn)
    assert np.max(np.abs(exact_g - g_exp)) > 1e-3 * weight, "the case must tell Euler from exact decay"


def test_euler_theta_decay(backend):
    """``IF_cond_exp_adaptive(integration="euler")``: ``theta`` falls by ``1 - dt / tau_theta`` per step,
    grows by ``theta_plus`` per spike, and the spikes follow (:func:`analytic.euler_grid_spike_times`)."""
    case = "euler_theta"
    params = {**LIF, "i_offset": 30.0, "theta_plus": 2.0}
    tau_theta = 5.0
    net = nv.Network("euler_theta")
    net.add_population("exc", 1, nv.IF_cond_exp_adaptive(integration="euler", tau_theta=tau_theta, **params))
    sim = backend.compile(net, case=case, dt=DT, recordables=("theta",))
    sim.record("exc", "theta")
    sim.run(T_STOP)
    t, theta = sim.trace("exc", "theta")
    got = sim.spike_trains("exc")[0]
    tol = backend.tol(case)
    expected = euler_grid_spike_times(dt=DT, t_stop=T_STOP, tau_theta=tau_theta, **params)
    assert got.size == expected.size, f"{got.size} spikes, expected {expected.size}"
    np.testing.assert_allclose(got, expected, rtol=0, atol=tol.spike_time_ms)
    steps = np.rint(t / DT).astype(int)
    spike_steps = np.rint(got / DT).astype(int)
    want = np.zeros(steps.size)
    for s in spike_steps:  # a spike's jump, then (1 - dt / tau_theta) per later step
        later = steps >= s
        want[later] += params["theta_plus"] * (1.0 - DT / tau_theta) ** (steps[later] - s)
    np.testing.assert_allclose(theta[:, 0], want, rtol=0, atol=tol.trace_rel * want.max())
