"""The spike lockout of ``IF_cond_exp_adaptive`` (``tau_lockout``), separate from the membrane clamp."""

from __future__ import annotations

import numpy as np

import neurovpr as nv

from .analytic import lif_grid_spike_times, lif_grid_trace

DT = 0.1

#: Without a lockout this neuron fires every R + k = 20 + 170 steps (19.0 ms).
CELL = {
    "cm": 1.0,
    "tau_m": 20.0,
    "tau_refrac": 2.0,
    "v_rest": -65.0,
    "v_reset": -70.0,
    "v_thresh": -50.0,
    "i_offset": 1.5,
    "theta_plus": 0.0,
}
#: No lockout; a lockout shorter than the free interval (no effect); one longer (it sets the interval).
LOCKOUTS = (0.0, 10.0, 30.0)


def test_spike_lockout(backend):
    """Constant drive: each interval is ``max(L, R + k)`` steps (:func:`analytic.lif_grid_spike_times`).

    The membrane is held at ``v_reset`` for ``tau_refrac`` only: during a longer lockout it
    follows the free solution ``v_inf - (v_inf - v_reset) exp(-s / tau_m)`` and rises
    above the threshold without firing, and a lockout at or below the free interval
    changes nothing.
    """
    case = "spike_lockout"
    t_stop = 150.0
    net = nv.Network("lockout")
    net.add_population("exc", len(LOCKOUTS), nv.IF_cond_exp_adaptive(tau_lockout=np.array(LOCKOUTS), **CELL))
    sim = backend.compile(net, case=case, dt=DT)
    sim.record("exc", "v")
    sim.run(t_stop)
    t, v = sim.trace("exc", "v")
    times, idx = sim.spike_trains("exc")
    tol = backend.tol(case)
    free = {k: CELL[k] for k in ("tau_m", "cm", "v_rest", "v_reset", "tau_refrac", "i_offset")}
    for i, lockout in enumerate(LOCKOUTS):
        expected = lif_grid_spike_times(dt=DT, t_stop=t_stop, tau_lockout=lockout, v_thresh=CELL["v_thresh"], **free)
        got = times[idx == i]
        assert got.size == expected.size, f"neuron {i}: {got.size} spikes, expected {expected.size}"
        np.testing.assert_allclose(got, expected, rtol=0, atol=tol.spike_time_ms, err_msg=f"neuron {i}")
        trace = lif_grid_trace(t, got, dt=DT, **free)
        span = abs(CELL["v_thresh"] - CELL["v_reset"])
        np.testing.assert_allclose(v[:, i], trace, rtol=0, atol=tol.trace_rel * span, err_msg=f"neuron {i}")
    np.testing.assert_allclose(np.diff(times[idx == 0]), 19.0, rtol=0, atol=1e-9)
    np.testing.assert_allclose(np.diff(times[idx == 1]), 19.0, rtol=0, atol=1e-9)
    np.testing.assert_allclose(np.diff(times[idx == 2]), 30.0, rtol=0, atol=1e-9)
    assert v[:, 2].max() > CELL["v_thresh"] + 1.0, "the membrane must integrate freely (past threshold) in the lockout"
