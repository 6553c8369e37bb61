"""The reference backend's structured convolutions give the synapse-by-synapse results bit for bit.

A convolution projection is delivered from its kernel (``backends/reference/convolution.py``);
the same synapses listed one by one (``FromListConnector``) go the generic way. Spikes and
membrane traces must agree exactly, for any geometry, receptor and delay, for a convolution
split into feature groups, and after weights are set (kept as a kernel, or turned into
per-synapse values that move the projection to the generic way).
"""

from __future__ import annotations

import numpy as np
import pytest

import neurovpr as nv

GEOMETRIES = [
    # input_shape, kernel, out_channels, stride, padding
    ((1, 9, 9), (3, 3), 2, (1, 1), (0, 0)),
    ((2, 11, 8), (3, 2), 3, (2, 1), (1, 0)),
    ((3, 10, 10), (5, 5), 4, (2, 2), (2, 1)),
]


def _networks(
    geometry: tuple, *, groups: int = 1, receptor: str = "excitatory", delay: float = 1.0, seed: int = 0
) -> tuple[nv.Network, nv.Network]:
    """(convolution, explicit list) versions of input -> fm (split into ``groups``) -> out (a second convolution)."""
    input_shape, kernel, out_channels, stride, padding = geometry
    rng = np.random.default_rng(seed)
    conv = nv.ConvolutionConnector(input_shape=input_shape, kernel_shape=kernel, out_channels=out_channels * groups,
                                   stride=stride, padding=padding)  # fmt: skip
    weights = rng.uniform(-0.5, 3.0, size=conv.weight_shape)
    if receptor == "inhibitory":  # the receptor gives the sign; a bias keeps the maps firing
        weights = np.abs(weights)
    oh, ow = conv.output_hw
    second = nv.ConvolutionConnector(input_shape=(out_channels * groups, oh, ow), kernel_shape=(2, 2), out_channels=2)
    w2 = rng.uniform(-1.0, 4.0, size=second.weight_shape)
    nets = []
    for structured in (True, False):
        net = nv.Network("conv" if structured else "list")
        net.add_population("img", int(np.prod(input_shape)), nv.SpikeSourcePoisson(rate=150.0))
        bias = 0.8 if receptor == "inhibitory" else 0.0
        cell = nv.IF_curr_exp(tau_m=10.0, v_thresh=-60.0, tau_syn_E=2.0, tau_syn_I=3.0, i_offset=bias)
        for g in range(groups):
            net.add_population(f"fm{g}", out_channels * oh * ow, cell)
        net.add_population("out", int(np.prod(second.output_shape)), cell)
        for g in range(groups):
            part = nv.ConvolutionConnector(input_shape=input_shape, kernel_shape=kernel, out_channels=out_channels,
                                           stride=stride, padding=padding)  # fmt: skip
            kern = weights[g * out_channels : (g + 1) * out_channels]
            if structured:
                net.connect("img", f"fm{g}", part, nv.StaticSynapse(weight=kern, delay=delay), receptor_type=receptor)
            else:
                c = _listed(net, "img", f"fm{g}", part, kern, delay)
                net.connect("img", f"fm{g}", nv.FromListConnector(conn_list=c), nv.StaticSynapse(delay=delay),
                            receptor_type=receptor)  # fmt: skip
        # the second layer reads all groups as one map: one projection per group with its channels
        for g in range(groups):
            sub = nv.ConvolutionConnector(input_shape=(out_channels, oh, ow), kernel_shape=(2, 2), out_channels=2)
            kern = w2[:, g * out_channels : (g + 1) * out_channels]
            if structured:
                net.connect(f"fm{g}", "out", sub, nv.StaticSynapse(weight=kern), name=f"fm{g}->out")
            else:
                c = _listed(net, f"fm{g}", "out", sub, kern, 0.5)  # None resolves to dt
                net.connect(f"fm{g}", "out", nv.FromListConnector(conn_list=c), nv.StaticSynapse(), name=f"fm{g}->out")
        nets.append(net)
    return nets[0], nets[1]


def _listed(net: nv.Network, pre: str, post: str, conn: nv.ConvolutionConnector, kernel: np.ndarray, delay: float):
    probe = nv.Network("probe")
    probe.add_population(pre, net.populations[pre].size, nv.SpikeSourcePoisson())
    probe.add_population(post, int(np.prod(conn.output_shape)), nv.IF_curr_exp())
    probe.connect(pre, post, conn, nv.StaticSynapse(weight=kernel))
    c = nv.expand(probe, f"{pre}->{post}", dt=0.5, seed=0)
    return np.column_stack([c.pre, c.post, c.weight, np.full(len(c), delay)])


def _run(net: nv.Network, steps_ms: float = 60.0, weights: dict | None = None) -> tuple[nv.Simulation, list]:
    sim = nv.compile(net, backend="reference", dt=0.5, seed=3)
    neurons = [p for p, pop in net.populations.items() if not isinstance(pop.cell_type, nv.SpikeSourcePoisson)]
    for pop in neurons:
        sim.record(pop, "v")
    sim.run(steps_ms / 2)
    for name, values in (weights or {}).items():
        sim.set_weights(name, values(sim.weights(name, format="list")))
    sim.run(steps_ms / 2)
    out = []
    for pop in neurons:
        out += [sim.spike_trains(pop), sim.trace(pop, "v")[1]]
    return sim, out


def _assert_same(a: list, b: list) -> None:
    spikes = 0
    for x, y in zip(a, b, strict=True):
        for xa, ya in zip(x if isinstance(x, tuple) else (x,), y if isinstance(y, tuple) else (y,), strict=True):
            assert np.array_equal(xa, ya)
        if isinstance(x, tuple):
            spikes += x[0].size
    assert spikes > 0, "the test network must spike"


@pytest.mark.parametrize("geometry", GEOMETRIES)
@pytest.mark.parametrize(("receptor", "delay"), [("excitatory", 0.5), ("inhibitory", 2.0)])
def test_structured_convolution_matches_synapse_list(geometry: tuple, receptor: str, delay: float) -> None:
    conv, listed = _networks(geometry, receptor=receptor, delay=delay)
    sim, got = _run(conv)
    assert [spec.names for spec in sim._lay.conv_specs] == [("img->fm0",), ("fm0->out",)]
    _assert_same(got, _run(listed)[1])


def test_feature_groups_are_one_convolution_and_match_synapse_list() -> None:
    conv, listed = _networks(GEOMETRIES[1], groups=3)
    sim, got = _run(conv)
    names = [spec.names for spec in sim._lay.conv_specs]
    assert names[0] == ("img->fm0", "img->fm1", "img->fm2")  # one convolution with all output channels
    _assert_same(got, _run(listed)[1])


@pytest.mark.parametrize("per_synapse", [False, True])
def test_setting_weights_keeps_results_exact(per_synapse: bool) -> None:
    conv, listed = _networks(GEOMETRIES[2], groups=2)
    rng = np.random.default_rng(5)
    if per_synapse:  # the weights no longer share a kernel: the group goes the generic way

        def change(w: np.ndarray) -> np.ndarray:
            return w * rng.uniform(0.5, 1.5, size=w.size)
    else:

        def change(w: np.ndarray) -> np.ndarray:
            return w * 1.75 - 0.25

    sim, got = _run(conv, weights={"img->fm1": change})
    structured = [name for spec in sim._lay.conv_specs for name in spec.names]
    assert ("img->fm1" in structured) is not per_synapse
    rng = np.random.default_rng(5)
    _assert_same(got, _run(listed, weights={"img->fm1": change})[1])


def test_dense_rows_match_shuffled_synapse_list() -> None:
    """A row of consecutive targets is added as a slice; the same synapses in shuffled order go one by one."""
    rng = np.random.default_rng(7)
    weights = rng.uniform(-1.0, 2.5, size=(40, 30))
    pre, post = np.meshgrid(np.arange(40), np.arange(30), indexing="ij")
    listing = np.column_stack([pre.ravel(), post.ravel(), weights.ravel()])[rng.permutation(pre.size)]
    results, runs = [], []
    for connector, synapse in (
        (nv.AllToAllConnector(), nv.StaticSynapse(weight=weights, delay=1.5)),
        (nv.FromListConnector(conn_list=listing), nv.StaticSynapse(delay=1.5)),
    ):
        net = nv.Network("dense")
        net.add_population("src", 40, nv.SpikeSourcePoisson(rate=80.0))
        net.add_population("dst", 30, nv.IF_curr_exp(tau_m=10.0, v_thresh=-62.0, i_offset=0.2))
        net.connect("src", "dst", connector, synapse)
        sim, out = _run(net)
        runs.append(sim._lay.d_seg[:, 2])
        results.append(out)
    assert np.all(runs[0] >= 0) and np.all(runs[1] == -1)
    _assert_same(results[0], results[1])
