"""The reference backend delivers a step's plastic arrivals in event order, however they are batched.

The kernel lists the synapses of a ring slot's short plastic events and handles them in one
loop per run of events of one projection, flushing its list when it is full or the
projection changes, and handles longer segments on their own
(``backends/reference/kernel_plasticity.py``). A projection of short and long segments,
interleaved with a second plastic projection from the same neurons, must give exactly what
the same synapses give when the first projection is split in two halves of postsynaptic
neurons (other segments, three projections instead of two): the same spikes, weights bit for
bit, conductances and activity counts. All source neurons also spike together, so that one slot holds
more short segments than the list has room for.
"""

from __future__ import annotations

import numpy as np

import neurovpr as nv

N_SRC, N_POST = 2000, 400  # a slot: more than 4,096 synapses of short segments (the list's room)
DT = 0.1


def _networks() -> tuple[nv.Network, nv.Network]:
    rng = np.random.default_rng(4)
    grid = np.setdiff1d(np.arange(1.0, 80.0, 0.5), [20.0, 50.0])
    times = [np.sort(np.r_[rng.choice(grid, size=3, replace=False), 20.0, 50.0]).tolist() for _ in range(N_SRC)]
    fan = np.where(np.arange(N_SRC) % 10 == 0, 12, 7)  # every tenth source: a segment too long to be listed
    pre = np.repeat(np.arange(N_SRC), fan)
    post = np.concatenate([rng.choice(N_POST, size=k, replace=False) for k in fan])
    weight = rng.uniform(0.0, 0.08, size=pre.size)
    delay = np.repeat(rng.choice([0.5, 1.0, 1.5], size=N_SRC), fan)  # one delay per source neuron
    rule = nv.DiehlCookSTDP(eta_pre=5e-3, eta_post=2e-2, w_max=0.1)
    other = nv.STDPMechanism(
        timing_dependence=nv.SpikePairRule(tau_plus=10.0, tau_minus=8.0, A_plus=0.02, A_minus=0.03),
        weight_dependence=nv.AdditiveWeightDependence(w_min=0.0, w_max=0.05),
        weight=0.02,
        delay=nv.Uniform(low=0.5, high=1.5),
    )
    sparse = np.stack([np.repeat(np.arange(N_SRC // 2), 3), rng.integers(0, N_POST, 3 * (N_SRC // 2))], axis=1)
    nets = []
    for halves in (1, 2):
        net = nv.Network(f"plastic-arrivals-{halves}")
        net.add_population("src", N_SRC, nv.SpikeSourceArray.from_lists(times))
        net.add_population("post", N_POST, nv.IF_cond_exp_adaptive(theta_plus=0.2, tau_theta=100.0, tau_refrac=2.0))
        bounds = np.linspace(0, N_POST, halves + 1)
        for h in range(halves):
            k = (post >= bounds[h]) & (post < bounds[h + 1])
            conn = np.stack([pre[k], post[k], weight[k], delay[k]], axis=1)
            net.connect("src", "post", nv.FromListConnector(conn), rule, name=f"main{h}")
        net.connect("src", "post", nv.FromListConnector(sparse), other, name="other")
        nets.append(net)
    return nets[0], nets[1]


def test_short_long_and_interleaved_segments_arrive_in_event_order() -> None:
    whole_net, split_net = _networks()
    sims = []
    for net in (whole_net, split_net):
        sim = nv.compile(net, backend="reference", dt=DT, seed=2)
        sim.record("post", "gsyn_exc")
        sim.run(60.0)
        sim.plasticity(False)
        sim.run(10.0)
        sim.plasticity(True)
        sim.run(30.0)
        sims.append(sim)
    whole, split = sims
    for pop in ("src", "post"):
        for a, b in zip(whole.spike_trains(pop), split.spike_trains(pop), strict=True):
            np.testing.assert_array_equal(a, b)
    assert whole.spike_counts("post").sum() > 100
    np.testing.assert_array_equal(whole.trace("post", "gsyn_exc")[1], split.trace("post", "gsyn_exc")[1])
    w_whole = whole.weights("main0", format="list")  # FromListConnector: list order
    (pre_w, post_w), parts = whole.connections("main0"), []
    for h in (0, 1):
        pre_h, post_h = split.connections(f"main{h}")
        parts.append(np.stack([pre_h, post_h, split.weights(f"main{h}", format="list")], axis=1))
    joined = np.concatenate(parts)
    joined = joined[np.lexsort((joined[:, 1], joined[:, 0]))]
    order = np.lexsort((post_w, pre_w))
    np.testing.assert_array_equal(joined[:, 2], w_whole[order])
    np.testing.assert_array_equal(whole.weights("other", format="list"), split.weights("other", format="list"))
    assert whole.statistics() == split.statistics()
    initial = nv.expand(whole_net, "main0", dt=DT, seed=2).weight
    assert (w_whole < initial).sum() > 100 and (w_whole > initial).sum() > 100  # depressed and potentiated
