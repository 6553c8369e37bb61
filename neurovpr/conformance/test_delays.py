"""Delays shift postsynaptic spikes by exactly the delay."""

from __future__ import annotations

import numpy as np
import pytest

import neurovpr as nv

from .analytic import GRID_MARGIN, current_psp

DT = 0.1
T_STOP = 60.0
T_SRC = (5.0, 30.0)
DELAYS = (0.1, 0.5, 1.0, 2.5, 7.3)
WEIGHT = 100.0
POST = {"cm": 1.0, "tau_m": 10.0, "tau_syn_E": 1.0, "tau_refrac": 5.0, "v_rest": -65.0, "v_reset": -65.0,
        "v_thresh": -50.0}


def latency_steps() -> int:
    """Steps from an input's arrival to the post spike it forces.

    The first ``k >= 1`` with ``current_psp(k dt) >= v_thresh - v_rest`` (exact PSP,
    see :func:`analytic.current_psp`), refusing a crossing within round-off of a step.
    """
    s = np.arange(1, 200) * DT
    u = current_psp(s, weight=WEIGHT, tau_m=POST["tau_m"], tau_syn=POST["tau_syn_E"], cm=POST["cm"])
    gap = u - (POST["v_thresh"] - POST["v_rest"])
    k = int(np.flatnonzero(gap >= 0)[0])
    if np.any(np.abs(gap[max(k - 1, 0) : k + 1]) < GRID_MARGIN):
        raise ValueError("the forced spike's threshold crossing lies on the grid; choose another weight")
    return k + 1


def _network(n_post: int, delay) -> nv.Network:
    net = nv.Network("delays")
    net.add_population("src", 1, nv.SpikeSourceArray.from_lists([list(T_SRC)]))
    net.add_population("post", n_post, nv.IF_curr_exp(**POST))
    net.connect("src", "post", nv.AllToAllConnector(), nv.StaticSynapse(weight=WEIGHT, delay=delay))
    return net


def _post_trains(sim: nv.Simulation, n_post: int) -> list[np.ndarray]:
    times, idx = sim.spike_trains("post")
    return [times[idx == i] for i in range(n_post)]


def _expected(delay_ms: float) -> np.ndarray:
    return np.array(T_SRC) + delay_ms + latency_steps() * DT


def test_delay_shift(backend):
    """The same network with delays ``d1`` and ``d2`` (multiples of dt): post spikes at
    ``t_src + d + k dt`` (``k`` from :func:`latency_steps`), so the trains differ by exactly ``d2 - d1``."""
    case = "delay_shift"
    tol = backend.tol(case).spike_time_ms
    trains = {}
    for d in DELAYS:
        sim = backend.compile(_network(1, d), case=case, dt=DT)
        sim.run(T_STOP)
        trains[d] = _post_trains(sim, 1)[0]
        assert trains[d].size == len(T_SRC), f"delay {d} ms: post spikes {trains[d].tolist()}"
        np.testing.assert_allclose(trains[d], _expected(d), rtol=0, atol=tol, err_msg=f"delay {d} ms")
    for d in DELAYS[1:]:
        np.testing.assert_allclose(trains[d] - trains[DELAYS[0]], d - DELAYS[0], rtol=0, atol=2 * tol)


def test_heterogeneous_delays(backend):
    """One projection whose connections have different delays: post neuron ``j`` fires at
    ``t_src + d_j + k dt``."""
    case = "delay_heterogeneous"
    net = _network(len(DELAYS), np.array(DELAYS))
    sim = backend.compile(net, case=case, dt=DT, heterogeneous_delays=True)
    sim.run(T_STOP)
    tol = backend.tol(case).spike_time_ms
    for j, (d, got) in enumerate(zip(DELAYS, _post_trains(sim, len(DELAYS)), strict=True)):
        assert got.size == len(T_SRC), f"post {j} (delay {d} ms): {got.tolist()}"
        np.testing.assert_allclose(got, _expected(d), rtol=0, atol=tol, err_msg=f"post {j}, delay {d} ms")


@pytest.mark.parametrize(("delay", "on_grid"), [(1.04, 1.0), (1.06, 1.1), (2.449, 2.4)])
def test_delay_rounding(backend, delay, on_grid):
    """A delay that is not a multiple of dt acts as ``round(d / dt) dt``."""
    case = "delay_rounding"
    sim = backend.compile(_network(1, delay), case=case, dt=DT)
    sim.run(T_STOP)
    got = _post_trains(sim, 1)[0]
    assert got.size == len(T_SRC), f"delay {delay} ms: post spikes {got.tolist()}"
    np.testing.assert_allclose(got, _expected(on_grid), rtol=0, atol=backend.tol(case).spike_time_ms)


def test_spike_array_times_rounded(backend):
    """A ``SpikeSourceArray`` spike at ``t`` is emitted at ``round(t / dt) dt`` and shifts the
    post spike accordingly."""
    case = "spike_array_rounding"
    given, on_grid = [5.04, 29.96], [5.0, 30.0]
    net = nv.Network("array_rounding")
    net.add_population("src", 1, nv.SpikeSourceArray.from_lists([given]))
    net.add_population("post", 1, nv.IF_curr_exp(**POST))
    net.connect("src", "post", nv.AllToAllConnector(), nv.StaticSynapse(weight=WEIGHT, delay=1.0))
    sim = backend.compile(net, case=case, dt=DT)
    sim.run(T_STOP)
    tol = backend.tol(case).spike_time_ms
    np.testing.assert_allclose(sim.spike_trains("src")[0], on_grid, rtol=0, atol=tol)
    expected = np.array(on_grid) + 1.0 + latency_steps() * DT
    np.testing.assert_allclose(_post_trains(sim, 1)[0], expected, rtol=0, atol=tol)


def _relay(delay) -> nv.Network:
    """A source drives neuron ``a`` (delay dt), which drives ``b`` through ``delay``."""
    net = nv.Network("relay")
    net.add_population("src", 1, nv.SpikeSourceArray.from_lists([list(T_SRC)]))
    net.add_population("a", 1, nv.IF_curr_exp(**POST))
    net.add_population("b", 1, nv.IF_curr_exp(**POST))
    net.connect("src", "a", nv.AllToAllConnector(), nv.StaticSynapse(weight=WEIGHT, delay=DT))
    net.connect("a", "b", nv.AllToAllConnector(), nv.StaticSynapse(weight=WEIGHT, delay=delay))
    return net


def test_zero_delay(backend):
    """``a`` fires at ``t_src + dt + k dt``; ``b`` at ``t_a + d + k dt``, with ``d = 0`` as well as ``d = dt``."""
    case = "zero_delay"
    tol = backend.tol(case).spike_time_ms
    t_a = _expected(DT)
    for delay in (0.0, DT):
        sim = backend.compile(_relay(delay), case=case, dt=DT)
        sim.run(T_STOP)
        np.testing.assert_allclose(sim.spike_trains("a")[0], t_a, rtol=0, atol=tol, err_msg="a")
        expected = t_a + delay + latency_steps() * DT
        np.testing.assert_allclose(sim.spike_trains("b")[0], expected, rtol=0, atol=tol, err_msg=f"b, delay {delay} ms")
