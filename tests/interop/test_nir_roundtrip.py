"""Export to NIR and import back: weights bit for bit, every node type, the same spikes."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import neurovpr as nv

nir = pytest.importorskip("nir")

from neurovpr.interop.nir import export_nir, import_nir, network_to_nir, nir_to_network, read_graph  # noqa: E402


def _lif(**kw) -> nv.IF_curr_exp:
    base = {"tau_refrac": 0.0, "v_rest": 0.0, "v_reset": 0.0, "v_thresh": 1.0, "tau_syn_E": 2.0, "tau_syn_I": 2.0}
    return nv.IF_curr_exp(**{**base, **kw})


def locsnet_shaped(seed: int = 0, n_places: int = 10) -> nv.Network:
    """LoCS-Net's shape with the core API: 56x56 input, three conv layers, a dense place layer."""
    rng = np.random.default_rng(seed)
    net = nv.Network("locsnet_shaped")
    net.add_population("input", 56 * 56, nv.SpikeSourcePoisson(rate=0.0))
    shape, prev = (1, 56, 56), "input"
    for name, (filters, k, s) in zip(("conv1", "conv2", "conv3"), ((8, 5, 2), (16, 3, 2), (32, 3, 2)), strict=True):
        conn = nv.ConvolutionConnector(input_shape=shape, kernel_shape=(k, k), out_channels=filters, stride=(s, s))
        net.add_population(name, int(np.prod(conn.output_shape)), _lif(cm=0.5, tau_m=20.0))
        net.connect(prev, name, conn, nv.StaticSynapse(weight=rng.normal(0, 0.3, conn.weight_shape), delay=1.0))
        shape, prev = conn.output_shape, name
    bias = rng.normal(0, 0.01, n_places)
    net.add_population("places", n_places, _lif(cm=0.5, tau_m=20.0, i_offset=bias))
    net.connect(prev, "places", nv.AllToAllConnector(), nv.StaticSynapse(weight=rng.normal(0, 0.1, (800, n_places)), delay=1.0))
    return net


def _assert_same_weights(a: nv.Network, b: nv.Network) -> None:
    assert set(a.projections) == set(b.projections)
    for name, p in a.projections.items():
        q = b.projections[name]
        assert (q.pre, q.post, type(q.connector)) == (p.pre, p.post, type(p.connector)), name
        assert q.synapse.weight.dtype == np.float64
        assert q.synapse.weight.shape == p.synapse.weight.shape
        assert q.synapse.weight.tobytes() == p.synapse.weight.tobytes(), f"{name}: weights differ"
        assert q.synapse.delay == p.synapse.delay


def test_locsnet_shaped_network_round_trips_bit_identically(tmp_path: Path) -> None:
    net = locsnet_shaped()
    export_nir(net, tmp_path / "locs.nir")
    graph = read_graph(tmp_path / "locs.nir")
    kinds = {k: type(v).__name__ for k, v in graph.nodes.items()}
    assert kinds["conv1->conv2"] == "Conv2d" and kinds["conv3->places"] == "Linear" and kinds["places"] == "CubaLIF"
    plain = import_nir(tmp_path / "locs.nir", use_metadata=False)  # from the NIR nodes alone
    assert not plain.restored and plain.outputs == {"output": "places"} and plain.inputs == {"input": "input"}
    _assert_same_weights(net, plain.network)
    for name, pop in net.populations.items():
        assert plain.network.populations[name].size == pop.size
    restored = import_nir(tmp_path / "locs.nir")
    assert restored.restored and restored.network == net


def test_real_locsnet_round_trips_bit_identically(tmp_path: Path) -> None:
    conversion = pytest.importorskip("neurovpr.models.locsnet.conversion", reason="LoCS-Net model not installed")
    architecture = pytest.importorskip("neurovpr.models.locsnet.architecture")
    arch = architecture.paper_architecture(n_places=12)
    rng = np.random.default_rng(3)
    params = {k: rng.normal(0, 0.1, s) for k, s in arch.parameter_shapes().items()}
    net = conversion.to_spiking_network(arch, params, conversion.SpikingParameters())
    with pytest.raises(nv.ValidationError, match="refractory"):
        export_nir(net, tmp_path / "x.nir")
    export_nir(net, tmp_path / "locsnet.nir", allow_refractory=True, dt=1.0)
    _assert_same_weights(net, import_nir(tmp_path / "locsnet.nir", use_metadata=False).network)
    assert import_nir(tmp_path / "locsnet.nir").network == net


@pytest.mark.parametrize("integration", ["exact", "euler"])
def test_imported_network_spikes_like_the_original(integration: str) -> None:
    rng = np.random.default_rng(5)
    net = nv.Network("ff")
    net.add_population("inp", 30, nv.SpikeSourceArray.from_lists([[]] * 30))
    net.add_population("hid", 20, _lif(cm=0.2, tau_m=8.0, i_offset=0.02))
    net.add_population("lat", 20, _lif(cm=0.3, tau_m=5.0, tau_syn_E=1e-6, tau_syn_I=1e-6))
    net.add_population("out", 6, _lif(cm=0.25, tau_m=12.0))
    random = nv.FixedProbabilityConnector(p_connect=0.5, seed=2)
    net.connect("inp", "hid", random, nv.StaticSynapse(weight=nv.Uniform(low=0.0, high=0.6)))
    net.connect("hid", "lat", nv.OneToOneConnector(), nv.StaticSynapse(weight=rng.uniform(2e5, 4e5, 20), delay=0.3))
    net.connect("hid", "out", nv.AllToAllConnector(), nv.StaticSynapse(weight=rng.uniform(0.0, 0.4, (20, 6))))
    net.connect("lat", "out", nv.AllToAllConnector(), nv.StaticSynapse(weight=0.2), receptor_type="inhibitory")
    graph = network_to_nir(net, integration=integration, seed=4)
    back = nir_to_network(graph, use_metadata=False).network
    times = [sorted(rng.uniform(0, 80, 12).round(1)) for _ in range(30)]
    counts = []
    for network in (net, back):
        sim = nv.compile(network, backend="reference", dt=0.1, seed=4)
        sim.run(100.0, inputs={"inp": times})
        counts.append({p: sim.spike_trains(p) for p in ("hid", "lat", "out")})
    for pop in ("hid", "lat", "out"):
        assert counts[0][pop][0].size > 5, pop
        np.testing.assert_allclose(counts[1][pop][0], counts[0][pop][0], atol=1e-9)
        np.testing.assert_array_equal(counts[1][pop][1], counts[0][pop][1])


def test_every_supported_nir_node_imports(tmp_path: Path) -> None:
    """A graph with every node type neurovpr maps, a nested subgraph included, through a file and back."""
    rng = np.random.default_rng(0)
    sub = nir.NIRGraph(
        nodes={"i": nir.Input(input_type={"input": np.array([6])}), "lif": nir.LIF(tau=np.full(6, 0.01), r=np.full(6, 2.0),
               v_leak=np.zeros(6), v_threshold=np.ones(6), v_reset=np.zeros(6)), "rec": nir.Linear(weight=0.1 * np.eye(6)),
               "o": nir.Output(output_type={"output": np.array([6])})},
        edges=[("i", "lif"), ("lif", "rec"), ("rec", "lif"), ("lif", "o")],
    )  # fmt: skip
    cuba = {"tau_syn": np.full((2, 4, 4), 0.002), "tau_mem": np.full((2, 4, 4), 0.01), "r": np.full((2, 4, 4), 5.0),
            "v_leak": np.zeros((2, 4, 4)), "w_in": np.ones((2, 4, 4))}  # fmt: skip
    nodes = {
        "in": nir.Input(input_type={"input": np.array([1, 8, 8])}),
        "conv": nir.Conv2d(input_shape=(8, 8), weight=20 * rng.normal(size=(2, 1, 3, 3)), stride=1, padding=1, dilation=1,
                           groups=1, bias=np.array([0.1, -0.1])),
        "c1": nir.CubaLIF(v_threshold=np.ones((2, 8, 8)), v_reset=np.zeros((2, 8, 8)),
                          **{k: np.resize(v, (2, 8, 8)) for k, v in cuba.items()}),
        "sum": nir.SumPool2d(kernel_size=np.array([2, 2]), stride=np.array([2, 2]), padding=np.array([0, 0])),
        "c2": nir.CubaLI(**cuba),
        "avg": nir.AvgPool2d(kernel_size=np.array([2, 2]), stride=np.array([2, 2]), padding=np.array([0, 0])),
        "scale": nir.Scale(scale=rng.uniform(0.5, 1, (2, 2, 2))),
        "dly": nir.Delay(delay=np.full((2, 2, 2), 0.002)),
        "i2": nir.I(r=np.full((2, 2, 2), 3.0)),
        "flat": nir.Flatten(input_type={"input": np.array([2, 2, 2])}, start_dim=0, end_dim=-1),
        "aff": nir.Affine(weight=rng.normal(size=(6, 8)), bias=np.zeros(6)),
        "sub": sub,
        "lin": nir.Linear(weight=rng.normal(size=(3, 6))),
        "if": nir.IF(r=np.full(3, 1.0), v_threshold=np.ones(3), v_reset=np.zeros(3)),
        "li": nir.LI(tau=np.full(3, 0.02), r=np.ones(3), v_leak=np.zeros(3)),
        "out": nir.Output(output_type={"output": np.array([3])}),
    }
    edges = [("in", "conv"), ("conv", "c1"), ("c1", "sum"), ("sum", "c2"), ("c2", "avg"), ("avg", "scale"), ("scale", "dly"),
             ("dly", "i2"), ("i2", "flat"), ("flat", "aff"), ("aff", "sub"), ("sub", "lin"), ("lin", "if"), ("if", "li"),
             ("if", "out")]  # fmt: skip
    graph = nir.NIRGraph(nodes=nodes, edges=edges, type_check=False)
    nir.write(tmp_path / "all.nir", graph)
    result = import_nir(tmp_path / "all.nir")
    net = result.network
    assert result.outputs == {"out": "if"} and result.inputs == {"in": "in"}
    kinds = {name: type(p.connector).__name__ for name, p in net.projections.items()}
    assert kinds["conv"] == "ConvolutionConnector" and kinds["aff"] == "AllToAllConnector"
    assert kinds["c2->i2"] == "FromListConnector"  # avg pool (2 channels) then scale, composed
    assert kinds["sum"] == "FromListConnector"  # sum pool over 2 channels
    assert net.projections["c2->i2"].synapse.delay == pytest.approx(2.0)  # the Delay node
    assert net.projections["sub.rec"].pre == net.projections["sub.rec"].post == "sub.lif"
    assert np.isposinf(net.populations["li"].cell_type.v_thresh)
    assert np.isposinf(net.populations["c2"].cell_type.v_thresh)
    sizes = {name: p.size for name, p in net.populations.items()}
    assert sizes == {"in": 64, "c1": 128, "c2": 32, "i2": 8, "sub.lif": 6, "if": 3, "li": 3}
    sim = nv.compile(net, backend="reference", dt=0.1, seed=0)
    sim.run(20.0, inputs={"in": [[1.0, 5.0]] * 64})
    assert sim.spike_counts("c1").sum() > 0
    again = nir_to_network(network_to_nir(net, embed_network=False)).network  # and out again
    assert {n: p.size for n, p in again.populations.items()} == sizes


def test_chained_linear_nodes_compose_exactly() -> None:
    rng = np.random.default_rng(2)
    w1, w2, b1 = rng.normal(size=(5, 4)), rng.normal(size=(3, 5)), rng.normal(size=5)
    graph = nir.NIRGraph(
        nodes={"in": nir.Input(input_type={"input": np.array([4])}), "a": nir.Affine(weight=w1, bias=b1),
               "b": nir.Linear(weight=w2), "n": nir.LIF(tau=np.full(3, 0.01), r=np.ones(3), v_leak=np.zeros(3),
                                                       v_threshold=np.ones(3), v_reset=np.zeros(3))},
        edges=[("in", "a"), ("a", "b"), ("b", "n")],
    )  # fmt: skip
    result = nir_to_network(graph)
    proj = next(iter(result.network.projections.values()))
    dense = np.zeros((4, 3))
    cl = proj.connector.conn_list
    dense[cl[:, 0].astype(int), cl[:, 1].astype(int)] = cl[:, 2]
    np.testing.assert_allclose(dense, (w2 @ w1).T, rtol=1e-12)
    cell = result.network.populations["n"].cell_type
    np.testing.assert_allclose(cell.i_offset, (w2 @ b1) * cell.cm / 10.0, rtol=1e-12)  # LIF: r b cm / tau
    assert any("multiplied" in note for note in result.notes)


def test_delays_per_pre_and_per_post_neuron_round_trip() -> None:
    net = nv.Network("delays")
    net.add_population("a", 4, nv.SpikeSourceArray.from_lists([[]] * 4))
    net.add_population("b", 3, _lif())
    net.add_population("c", 3, _lif())
    pre_delays = np.repeat([1.0, 2.0, 3.0, 4.0], 3)  # canonical (pre, post) order
    net.connect("a", "b", nv.AllToAllConnector(), nv.StaticSynapse(weight=0.5, delay=pre_delays))
    net.connect("a", "c", nv.AllToAllConnector(), nv.StaticSynapse(weight=0.5, delay=np.tile([1.5, 2.5, 3.5], 4)))
    graph = network_to_nir(net, embed_network=False)
    assert {type(n).__name__ for n in graph.nodes.values()} >= {"Delay"}
    back = nir_to_network(graph).network
    for name, want in (("a->b", pre_delays), ("a->c", np.tile([1.5, 2.5, 3.5], 4))):
        got = nv.expand(back, name, dt=0.1, seed=0)
        np.testing.assert_allclose(got.delay, want, rtol=1e-12)
