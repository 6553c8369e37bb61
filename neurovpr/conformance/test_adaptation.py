"""Spike-frequency adaptation: the Ca2+ current and the adaptive threshold."""

from __future__ import annotations

import numpy as np

import neurovpr as nv

from .analytic import ca2_grid_spike_times, decaying_sum, theta_grid_spike_times

DT = 0.1

CA2 = {"cm": 1.0, "tau_m": 20.0, "tau_refrac": 2.0, "v_rest": -65.0, "v_reset": -70.0, "v_thresh": -50.0,
       "i_offset": 1.5, "tau_ca2": 50.0, "i_alpha": 0.2}
CA2_INIT = (0.0, 0.05)

THETA = {"cm": 1.0, "tau_m": 20.0, "tau_refrac": 2.0, "v_rest": -65.0, "v_reset": -70.0, "v_thresh": -50.0,
         "i_offset": 1.5, "theta_plus": 0.5}
#: neuron 0 keeps theta, neuron 1 lets it decay visibly
TAU_THETA = (1e7, 50.0)


def _by_neuron(times: np.ndarray, idx: np.ndarray, n: int) -> list[np.ndarray]:
    return [times[idx == i] for i in range(n)]


def test_ca2_adaptation(backend):
    """``IF_curr_exp_ca2_adaptive`` under constant current.

    ``I_ca2(t) = i_ca2 exp(-t / tau_ca2) + sum_{spikes s <= t} i_alpha exp(-(t - s) / tau_ca2)``
    (recorded after the jump at a spike step); the spike times follow the exact
    membrane solution with that current (:func:`analytic.ca2_grid_spike_times`);
    inter-spike intervals grow.
    """
    case = "ca2_adaptation"
    t_stop = 300.0
    net = nv.Network("ca2")
    net.add_population("pn", 2, nv.IF_curr_exp_ca2_adaptive(i_ca2=np.array(CA2_INIT), **CA2))
    sim = backend.compile(net, case=case, dt=DT, recordables=("i_ca2",))
    sim.record("pn", "i_ca2")
    sim.run(t_stop)
    t, ca = sim.trace("pn", "i_ca2")
    tol = backend.tol(case)
    for i, (init, spikes) in enumerate(zip(CA2_INIT, _by_neuron(*sim.spike_trains("pn"), 2), strict=True)):
        expected_spikes = ca2_grid_spike_times(dt=DT, t_stop=t_stop, i_ca2=init, **CA2)
        assert spikes.size == expected_spikes.size, f"neuron {i}: {spikes.size} spikes, expected {expected_spikes.size}"
        np.testing.assert_allclose(spikes, expected_spikes, rtol=0, atol=tol.spike_time_ms, err_msg=f"neuron {i}")
        isi = np.diff(spikes)
        # intervals grow (up to one step of grid jitter)
        assert np.all(np.diff(isi) >= -DT - 1e-9) and isi[-1] > isi[0] + 1.0, f"neuron {i}: ISIs {isi.tolist()}"
        expected = decaying_sum(t, spikes, jump=CA2["i_alpha"], tau=CA2["tau_ca2"], initial=init)
        np.testing.assert_allclose(ca[:, i], expected, rtol=0, atol=tol.trace_rel * expected.max(), err_msg=f"neuron {i}")


def test_theta_adaptation_and_reset(backend):
    """``IF_cond_exp_adaptive`` under constant current, before and after ``reset()``.

    ``theta(t) = theta_0 exp(-t / tau_theta) + sum_{spikes s <= t} theta_plus exp(-(t - s) / tau_theta)``;
    spikes come where ``v`` first reaches ``v_thresh + theta`` (:func:`analytic.theta_grid_spike_times`),
    so intervals grow. ``reset()`` keeps ``theta``: the second run starts from it.
    """
    case = "theta_adaptation"
    net = nv.Network("theta")
    net.add_population("exc", 2, nv.IF_cond_exp_adaptive(tau_theta=np.array(TAU_THETA), **THETA))
    sim = backend.compile(net, case=case, dt=DT, recordables=("theta",))
    sim.record("exc", "theta")
    tol = backend.tol(case)
    theta0 = np.zeros(2)
    for t_stop in (200.0, 100.0):
        sim.run(t_stop)
        t, theta = sim.trace("exc", "theta")
        trains = _by_neuron(*sim.spike_trains("exc"), 2)
        for i in range(2):
            expected_spikes = theta_grid_spike_times(
                dt=DT, t_stop=t_stop, tau_theta=TAU_THETA[i], theta_init=theta0[i], **THETA
            )
            got = trains[i]
            assert got.size == expected_spikes.size, f"neuron {i}: {got.size} spikes, expected {expected_spikes.size}"
            np.testing.assert_allclose(got, expected_spikes, rtol=0, atol=tol.spike_time_ms, err_msg=f"neuron {i}")
        isi = np.diff(trains[0])
        assert np.all(np.diff(isi) >= -DT - 1e-9) and isi[-1] > isi[0], f"ISIs {isi.tolist()}"
        for i in range(2):
            expected = decaying_sum(t, trains[i], jump=THETA["theta_plus"], tau=TAU_THETA[i], initial=theta0[i])
            np.testing.assert_allclose(
                theta[:, i], expected, rtol=0, atol=tol.trace_rel * expected.max(), err_msg=f"neuron {i}"
            )
        learned = sim.learned_state("exc")["theta"]
        np.testing.assert_allclose(learned, theta[-1], rtol=0, atol=tol.trace_rel * theta[-1].max())
        sim.reset()
        assert sim.time == 0.0
        np.testing.assert_array_equal(sim.learned_state("exc")["theta"], learned)
        theta0 = learned
    assert theta0[0] > theta0[1] > 0
