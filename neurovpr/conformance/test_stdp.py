"""Weight change of one pre/post pair under each plasticity rule, against the formula.

A presynaptic ``SpikeSourceArray`` spike reaches the postsynaptic neuron through the
plastic synapse with delay ``d``; a second array source forces the postsynaptic spike
through a strong static synapse. The exact spike times are read back from
``spike_trains`` and ``dt_pair = t_post - (t_pre + d)`` (delays are axonal).
"""

from __future__ import annotations

import math

import pytest

import neurovpr as nv

from .analytic import diehl_cook_pair_weight, pair_stdp_weight
from .networks import DELAY, DT, PAIR, pair_network

T_STOP = 60.0
T_DRIVE = 20.0
#: pre spike times: arrival before the post spike, after it, and at the same instant
#: (the forced post spike comes at 20.3 ms on the reference grid; dt_pair is read back).
T_PRE = {"pre_first": 10.0, "post_first": 30.0, "same_instant": 20.3 - DELAY}

RULES = {
    "stdp_additive": nv.STDPMechanism(
        timing_dependence=PAIR,
        weight_dependence=nv.AdditiveWeightDependence(w_min=0.0, w_max=1.0),
        weight=0.5,
        delay=DELAY,
    ),
    "stdp_multiplicative": nv.STDPMechanism(
        timing_dependence=PAIR,
        weight_dependence=nv.MultiplicativeWeightDependence(w_min=0.1, w_max=1.0),
        weight=0.3,
        delay=DELAY,
    ),
    "stdp_diehl_cook": nv.DiehlCookSTDP(
        weight=0.4, delay=DELAY, eta_pre=0.02, eta_post=0.1, x_tar=0.1, w_max=1.0, mu=1.0, tau_pre=20.0, tau_post=15.0
    ),
}


def _run_pair(backend, case: str, synapse: nv.Synapse, t_pre: list[float], t_drive: list[float]):
    sim = backend.compile(pair_network(synapse, t_pre, t_drive), case=case, dt=DT)
    sim.run(T_STOP)
    pre_times = sim.spike_trains("pre")[0]
    post_times = sim.spike_trains("post")[0]
    assert pre_times.size == len(t_pre), f"pre source emitted {pre_times.tolist()}, expected {t_pre}"
    assert post_times.size == len(t_drive), f"post fired at {post_times.tolist()}, expected one spike per drive spike"
    weight = sim.weights("plastic", format="list")
    assert weight.shape == (1,)
    return pre_times, post_times, float(weight[0])


def _on_grid(x: float) -> float:
    return round(x / DT) * DT


@pytest.mark.parametrize("timing", list(T_PRE))
@pytest.mark.parametrize("case", list(RULES))
def test_one_pair(backend, case, timing):
    """One pair changes the weight by the rule's formula (``analytic.pair_stdp_weight``,
    ``analytic.diehl_cook_pair_weight``):

    additive: ``+A_plus w_max exp(-dt_pair / tau_plus)`` for ``dt_pair > 0``,
    ``-A_minus w_max exp(dt_pair / tau_minus)`` for ``dt_pair <= 0``; multiplicative with
    ``w_max - w0`` and ``w0 - w_min`` in place of ``w_max``; Diehl & Cook:
    ``+eta_post (exp(-dt_pair / tau_pre) - x_tar) (w_max - w0)^mu`` for ``dt_pair > 0``,
    ``-eta_post x_tar (w_max - w0)^mu - eta_pre exp(dt_pair / tau_post)`` otherwise.
    An arrival at the instant of the post spike counts as ``dt_pair = 0`` (its own case,
    ``stdp_same_instant``, as the order of simultaneous events differs between simulators).
    """
    syn = RULES[case]
    if timing == "same_instant":
        backend.require(case)
        pre, post, w = _run_pair(backend, "stdp_same_instant", syn, [T_PRE[timing]], [T_DRIVE])
    else:
        pre, post, w = _run_pair(backend, case, syn, [T_PRE[timing]], [T_DRIVE])
    dt_pair = _on_grid(post[0] - (pre[0] + DELAY))
    if timing == "pre_first":
        assert dt_pair > 0
    elif timing == "post_first":
        assert dt_pair < 0
    w0 = float(syn.weight)
    if isinstance(syn, nv.STDPMechanism):
        td, wd = syn.timing_dependence, syn.weight_dependence
        expected = pair_stdp_weight(
            w0=w0, dt_pair=dt_pair, tau_plus=td.tau_plus, tau_minus=td.tau_minus, A_plus=td.A_plus,
            A_minus=td.A_minus, w_min=wd.w_min, w_max=wd.w_max,
            multiplicative=isinstance(wd, nv.MultiplicativeWeightDependence),
        )
    else:
        expected = diehl_cook_pair_weight(
            w0=w0, dt_pair=dt_pair, eta_pre=syn.eta_pre, eta_post=syn.eta_post, x_tar=syn.x_tar,
            w_max=syn.w_max, mu=syn.mu, tau_pre=syn.tau_pre, tau_post=syn.tau_post,
        )
    assert abs(expected - w0) > 1e-3
    tol = backend.tol(case).weight_rel * abs(expected - w0) + 1e-12
    assert abs(w - expected) <= tol, f"{case} {timing}: dt_pair={dt_pair:g} ms, w={w!r}, expected {expected!r}"


def test_diehl_cook_triplet(backend):
    """Diehl & Cook's triplet form (``tau_post2``, ``mu = 0``): one pre spike, then two post spikes.

    The arrival at ``t_a`` meets ``x_post = 0``; the first post spike at ``t1`` sees
    ``x_post2 = 0`` and changes nothing; the second, at ``t2``, gives
    ``w = w0 + eta_post (exp(-(t2 - t_a) / tau_pre) - x_tar) exp(-(t2 - t1) / tau_post2)``.
    """
    case = "stdp_diehl_cook_triplet"
    syn = nv.DiehlCookSTDP(
        weight=0.5, delay=DELAY, eta_pre=0.02, eta_post=0.1, x_tar=0.1, w_max=1.0, mu=0.0,
        tau_pre=20.0, tau_post=15.0, tau_post2=40.0,
    )
    pre, post, w = _run_pair(backend, case, syn, [10.0], [T_DRIVE, 35.0])
    t_a = pre[0] + DELAY
    t1, t2 = post
    assert t_a < t1 < t2
    factor = (math.exp(-_on_grid(t2 - t_a) / syn.tau_pre) - syn.x_tar) * math.exp(-_on_grid(t2 - t1) / syn.tau_post2)
    expected = 0.5 + syn.eta_post * factor
    tol = backend.tol(case).weight_rel * abs(expected - 0.5) + 1e-12
    assert abs(w - expected) <= tol, f"w={w!r}, expected {expected!r} (t_a={t_a:g}, t1={t1:g}, t2={t2:g})"


def test_potentiating_pre_term(backend):
    """The Modular SNN authors' rule: ``pre_term="potentiate"``, triplet post term, ``x_tar = 0``, ``mu = 0``.

    Post spike at ``t1``, arrival at ``t_a > t1``, post spike at ``t2``: the arrival gives
    ``w1 = w0 + eta_pre exp(-(t_a - t1) / tau_post)`` (a potentiation), the second post spike
    ``w2 = w1 + eta_post exp(-(t2 - t_a) / tau_pre) exp(-(t2 - t1) / tau_post2)``.
    """
    case = "stdp_potentiating_pre"
    syn = nv.DiehlCookSTDP(
        weight=0.5, delay=DELAY, eta_pre=0.02, eta_post=0.1, w_max=1.0, mu=0.0,
        tau_pre=20.0, tau_post=15.0, tau_post2=40.0, pre_term="potentiate",
    )  # fmt: skip
    pre, post, w = _run_pair(backend, case, syn, [30.0], [T_DRIVE, 45.0])
    t_a = pre[0] + DELAY
    t1, t2 = post
    assert t1 < t_a < t2
    w1 = 0.5 + syn.eta_pre * math.exp(-_on_grid(t_a - t1) / syn.tau_post)
    expected = w1 + syn.eta_post * math.exp(-_on_grid(t2 - t_a) / syn.tau_pre) * math.exp(-_on_grid(t2 - t1) / syn.tau_post2)
    tol = backend.tol(case).weight_rel * abs(expected - 0.5) + 1e-12
    assert abs(w - expected) <= tol, f"w={w!r}, expected {expected!r} (t1={t1:g}, t_a={t_a:g}, t2={t2:g})"
