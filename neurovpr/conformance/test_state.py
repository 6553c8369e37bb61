"""Determinism, reset() and plasticity(False)."""

from __future__ import annotations

import math

import numpy as np

import neurovpr as nv

from .networks import DELAY, DT, PAIR, pair_network


def _random_network() -> nv.Network:
    net = nv.Network("random")
    net.add_population("inp", 50, nv.SpikeSourcePoisson(rate=40.0))
    net.add_population("out", 20, nv.IF_curr_exp(tau_syn_E=2.0))
    net.connect(
        "inp", "out", nv.FixedProbabilityConnector(p_connect=0.3),
        nv.StaticSynapse(weight=nv.Normal(mu=1.2, sigma=0.3, low=0.0)),
    )
    return net


def test_same_seed_same_spikes(backend):
    """The same seed gives identical spike trains (sources and neurons); another seed
    gives other Poisson trains."""
    case = "determinism"
    runs = {}
    for key, seed in (("a", 7), ("b", 7), ("c", 8)):
        sim = backend.compile(_random_network(), case=case, dt=DT, seed=seed)
        sim.run(200.0)
        runs[key] = {pop: sim.spike_trains(pop) for pop in ("inp", "out")}
    assert runs["a"]["out"][0].size > 0
    for pop in ("inp", "out"):
        for x, y in zip(runs["a"][pop], runs["b"][pop], strict=True):
            np.testing.assert_array_equal(x, y, err_msg=f"{pop}: same seed, different spikes")
    a, c = runs["a"]["inp"], runs["c"]["inp"]
    assert a[0].size != c[0].size or not (np.array_equal(a[0], c[0]) and np.array_equal(a[1], c[1]))


def _stdp_additive() -> nv.STDPMechanism:
    return nv.STDPMechanism(
        timing_dependence=PAIR,
        weight_dependence=nv.AdditiveWeightDependence(w_min=0.0, w_max=1.0),
        weight=0.5,
        delay=DELAY,
    )


def test_reset_restores_state_and_keeps_weights(backend):
    """``reset()``: time 0, spikes and recordings cleared, weights kept; membrane, synaptic
    currents, refractoriness, STDP traces and spikes in flight back to their initial
    values, so the next run equals a fresh simulation that starts from the learned weights.

    The pre spike at 45 ms (delay 8 ms) is still in flight when the first 50 ms run ends.
    """
    case = "reset"
    syn = _stdp_additive().replace(delay=8.0)
    net = pair_network(syn, [10.0, 45.0], [25.0])
    sim = backend.compile(net, case=case, dt=DT, recordables=("v",))
    sim.record("post", "v")
    sim.run(50.0)
    learned = sim.weights("plastic", format="list")
    assert abs(learned[0] - 0.5) > 1e-3 and sim.spike_counts("post").sum() == 1
    sim.reset()
    assert sim.time == 0.0
    assert sim.spike_counts("post").sum() == 0 and sim.spike_counts("pre").sum() == 0
    assert sim.spike_trains("post")[0].size == 0
    t, v = sim.trace("post", "v")
    assert t.size == 0 and v.shape[0] == 0
    np.testing.assert_array_equal(sim.weights("plastic", format="list"), learned)

    sim.run(50.0)
    after_reset = _outcome(sim)
    # read everything first: some simulators hold one simulation per process
    fresh = backend.compile(net, case=case, dt=DT, recordables=("v",))
    fresh.set_weights("plastic", learned)
    fresh.record("post", "v")
    fresh.run(50.0)
    for key, expected in _outcome(fresh).items():
        atol = 1e-12 if key == "weights" else 1e-9
        np.testing.assert_allclose(after_reset[key], expected, rtol=0, atol=atol, err_msg=f"{key}: after reset vs fresh")


def _outcome(sim: nv.Simulation) -> dict[str, np.ndarray]:
    return {
        "pre spike times": sim.spike_trains("pre")[0],
        "post spike times": sim.spike_trains("post")[0],
        "v": sim.trace("post", "v")[1],
        "weights": sim.weights("plastic", format="list"),
    }


def test_plasticity_off_freezes_weights_not_traces(backend):
    """With ``plasticity(False)`` pairs that would change the weight (pre arrival at 3.5 ms,
    forced post spike, pre arrival at 11.5 ms) leave it unchanged. Traces keep evolving,
    so after ``plasticity(True)`` the post spike at ``t`` potentiates by
    ``A_plus w_max sum_a exp(-(t - a) / tau_plus)`` over both earlier arrivals ``a``.
    """
    case = "plasticity_off"
    syn = _stdp_additive()
    sim = backend.compile(pair_network(syn, [2.0, 10.0], [5.0, 20.0]), case=case, dt=DT)
    sim.plasticity(False)
    sim.run(15.0)
    assert sim.spike_counts("post").sum() == 1
    np.testing.assert_array_equal(sim.weights("plastic", format="list"), [0.5])
    sim.plasticity(True)
    sim.run(15.0)
    pre = sim.spike_trains("pre")[0]
    post = sim.spike_trains("post")[0]
    assert pre.size == 2 and post.size == 2
    x_pre = sum(math.exp(-round((post[1] - (p + DELAY)) / DT) * DT / PAIR.tau_plus) for p in pre)
    expected = 0.5 + PAIR.A_plus * 1.0 * x_pre
    w = sim.weights("plastic", format="list")[0]
    tol = backend.tol(case).weight_rel * (expected - 0.5) + 1e-12
    assert abs(w - expected) <= tol, f"w={w!r}, expected {expected!r}"


def test_plasticity_off_freezes_theta(backend):
    """With ``plasticity(False)`` the adaptive threshold neither grows at spikes nor decays."""
    case = "plasticity_off"
    net = nv.Network("theta_frozen")
    net.add_population("exc", 1, nv.IF_cond_exp_adaptive(i_offset=1.5, tau_theta=50.0, theta_plus=0.5, theta_init=2.0))
    sim = backend.compile(net, case=case, dt=DT, recordables=("theta",))
    sim.record("exc", "theta")
    sim.plasticity(False)
    sim.run(100.0)
    assert sim.spike_counts("exc").sum() > 2
    np.testing.assert_array_equal(sim.trace("exc", "theta")[1], 2.0)
    np.testing.assert_array_equal(sim.learned_state("exc")["theta"], [2.0])
