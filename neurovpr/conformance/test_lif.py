"""Firing and membrane of IF_curr_exp and IF_cond_exp under a constant current, against the closed form."""

from __future__ import annotations

import numpy as np
import pytest

import neurovpr as nv

from .analytic import lif_grid_spike_times, lif_grid_trace, lif_isi_closed_form

DT = 0.1
T_STOP = 200.0
PARAMS = {"cm": 0.25, "tau_m": 10.0, "tau_refrac": 2.0, "v_rest": -65.0, "v_reset": -70.0, "v_thresh": -55.0}
#: nA; with R = tau_m / cm = 40 MOhm the rheobase is (v_thresh - v_rest) / R = 0.25 nA.
CURRENTS = (0.1, 0.24, 0.3, 0.5, 1.0, 2.0)
#: initial membrane potentials (mV)
V_INIT = (-65.0, -56.0, -60.0, -65.0, -70.0, -58.0)


@pytest.mark.parametrize(("cell", "case"), [(nv.IF_curr_exp, "lif_rate_curr"), (nv.IF_cond_exp, "lif_rate_cond")])
def test_constant_current_spike_times(backend, cell, case):
    """Spike times and membrane under ``i_offset`` equal the closed form on the time grid.

    Continuous time: ``T = tau_refrac + tau_m ln((R I - (v_reset - v_rest)) / (R I - (v_thresh - v_rest)))``
    with ``R = tau_m / cm``, no spikes at or below the rheobase. On the grid the
    threshold is tested at step ends and the refractory period lasts
    ``n_ref = round(tau_refrac / dt)`` steps, so the first spike is at ``k0 dt`` and the
    interval is ``(n_ref + k) dt`` with ``k = ceil(tau_m / dt ln((v_inf - v_reset) / (v_inf - v_thresh)))``
    (``k0`` likewise from ``v_init``), ``v_inf = v_rest + R I``. Between spikes
    ``v = v_inf - (v_inf - v0) exp(-(t - t0) / tau_m)``; recorded ``v`` is ``v_reset`` at
    a spike and through the refractory steps. An ``IF_cond_exp`` without synaptic
    input is the same LIF.
    """
    net = nv.Network("lif_rate")
    net.add_population("lif", len(CURRENTS), cell(i_offset=np.array(CURRENTS), **PARAMS), v_init=np.array(V_INIT))
    sim = backend.compile(net, case=case, dt=DT, recordables=("v",))
    sim.record("lif", "v")
    sim.run(T_STOP)
    assert sim.time == pytest.approx(T_STOP)
    times, idx = sim.spike_trains("lif")
    t, v = sim.trace("lif", "v")
    tol = backend.tol(case)
    np.testing.assert_array_equal(sim.spike_counts("lif"), np.bincount(idx, minlength=len(CURRENTS)))
    trace_params = {k: PARAMS[k] for k in ("tau_m", "cm", "v_rest", "v_reset", "tau_refrac")}
    for i, (current, v_init) in enumerate(zip(CURRENTS, V_INIT, strict=True)):
        expected = lif_grid_spike_times(dt=DT, t_stop=T_STOP, i_offset=current, v_init=v_init, **PARAMS)
        got = times[idx == i]
        assert got.size == expected.size, (
            f"{cell.__name__} with i_offset={current} nA: {got.size} spikes in {T_STOP} ms, expected {expected.size}"
        )
        np.testing.assert_allclose(got, expected, rtol=0, atol=tol.spike_time_ms, err_msg=f"i_offset={current} nA")
        closed = lif_isi_closed_form(i_offset=current, **PARAMS)
        if np.isinf(closed):
            assert expected.size == 0
        else:
            # the grid interval rounds the continuous one up by less than one step
            assert expected.size >= 2
            isi = expected[1] - expected[0]
            assert closed <= isi + 1e-9 < closed + DT
        v_expected = lif_grid_trace(t, got, dt=DT, i_offset=current, v_init=v_init, **trace_params)
        scale = PARAMS["v_thresh"] - PARAMS["v_reset"]
        np.testing.assert_allclose(
            v[:, i], v_expected, rtol=0, atol=tol.trace_rel * scale, err_msg=f"membrane, i_offset={current} nA"
        )
