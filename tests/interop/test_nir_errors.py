"""What NIR cannot express is refused by name; broken or foreign NIR files get one sentence."""

from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np
import pytest

import neurovpr as nv

nir = pytest.importorskip("nir")

from neurovpr.interop.nir import export_nir, import_nir, network_to_nir, nir_to_network  # noqa: E402


def _net(post_cell: nv.ir.cells.CellType, synapse: nv.ir.synapses.Synapse | None = None, **connect) -> nv.Network:
    net = nv.Network("bad")
    net.add_population("src", 4, nv.SpikeSourcePoisson(rate=10.0))
    net.add_population("dst", 3, post_cell)
    net.connect("src", "dst", nv.AllToAllConnector(), synapse or nv.StaticSynapse(weight=0.1), **connect)
    return net


_OK = {"tau_refrac": 0.0}


@pytest.mark.parametrize(
    ("net", "pattern"),
    [
        (_net(nv.IF_cond_exp(**_OK)), r"Population 'dst' \(IF_cond_exp\) has conductance-based synapses"),
        (_net(nv.IF_cond_exp_adaptive(**_OK)), r"'dst' \(IF_cond_exp_adaptive\) has conductance-based synapses and an adaptive"),
        (_net(nv.IF_curr_exp_ca2_adaptive(**_OK)), r"'dst' \(IF_curr_exp_ca2_adaptive\) has a Ca2\+-activated adaptation"),
        (_net(nv.IF_curr_exp(**_OK), nv.STDPMechanism(weight=0.1)), r"Projection 'src->dst' learns with STDPMechanism"),
        (_net(nv.IF_curr_exp(**_OK), nv.DiehlCookSTDP(weight=0.1)), r"Projection 'src->dst' learns with DiehlCookSTDP"),
        (_net(nv.IF_curr_exp(tau_refrac=2.0)), r"Population 'dst' has tau_refrac = 2.0 ms"),
    ],
)
def test_export_refuses_what_nir_cannot_express(net: nv.Network, pattern: str) -> None:
    with pytest.raises(nv.ValidationError, match=pattern):
        network_to_nir(net)


def test_export_refuses_two_synaptic_time_constants() -> None:
    net = _net(nv.IF_curr_exp(tau_syn_I=3.0, **_OK))
    net.connect("src", "dst", nv.AllToAllConnector(), nv.StaticSynapse(weight=0.1), receptor_type="inhibitory", name="inh")
    with pytest.raises(nv.ValidationError, match=r"Population 'dst' receives inhibitory input with tau_syn_I != tau_syn_E"):
        network_to_nir(net)
    only_inhibitory = nv.Network("inh_only")
    only_inhibitory.add_population("src", 4, nv.SpikeSourceArray.from_lists([[]] * 4))
    only_inhibitory.add_population("dst", 3, nv.IF_curr_exp(tau_syn_I=3.0, **_OK))
    only_inhibitory.connect("src", "dst", nv.AllToAllConnector(), nv.StaticSynapse(weight=0.1), receptor_type="inhibitory")
    graph = network_to_nir(only_inhibitory, embed_network=False)
    np.testing.assert_allclose(graph.nodes["dst"].tau_syn, 3e-3)  # the one synapse it uses
    np.testing.assert_array_equal(graph.nodes["src->dst"].weight, -0.1)  # the receptor gives the sign


def test_export_refuses_softlif_and_mixed_delays() -> None:
    net = nv.Network("rate")
    net.add_population("a", 2, nv.SoftLIF())
    with pytest.raises(nv.ValidationError, match=r"Population 'a' \(SoftLIF\) has a rate"):
        network_to_nir(net)
    net = _net(nv.IF_curr_exp(**_OK), nv.StaticSynapse(weight=0.1, delay=np.arange(1.0, 13.0)))
    with pytest.raises(nv.ValidationError, match=r"Projection 'src->dst' has delays that vary with both"):
        network_to_nir(net)


def test_export_refuses_dense_input_to_a_feature_map() -> None:
    net = nv.Network("maps")
    net.add_population("a", 16, nv.SpikeSourceArray.from_lists([[]] * 16))
    net.add_population("b", 16, nv.IF_curr_exp(**_OK))
    net.add_population("c", 4, nv.IF_curr_exp(**_OK))
    conv = nv.ConvolutionConnector(input_shape=(1, 4, 4), kernel_shape=(3, 3), out_channels=1)
    net.connect("a", "b", nv.AllToAllConnector(), nv.StaticSynapse(weight=0.1))
    net.connect("b", "c", conv, nv.StaticSynapse(weight=np.ones(conv.weight_shape)))
    with pytest.raises(nv.ValidationError, match=r"Projection 'a->b' is dense onto the feature map 'b' \(1, 4, 4\)"):
        network_to_nir(net)


def test_refractory_periods_can_be_kept_in_metadata(tmp_path: Path) -> None:
    net = _net(nv.IF_curr_exp(tau_refrac=2.0))
    notes = export_nir(net, tmp_path / "r.nir", allow_refractory=True)
    assert any("refractory period is kept in neurovpr metadata only" in n for n in notes)
    assert any("SpikeSourcePoisson" in n for n in notes)
    assert import_nir(tmp_path / "r.nir").network == net
    plain = import_nir(tmp_path / "r.nir", use_metadata=False).network
    assert plain.populations["dst"].cell_type.tau_refrac == 0.0


def _graph(middle: dict, edges: list) -> nir.NIRGraph:
    nodes = {"in": nir.Input(input_type={"input": np.array([4])}), **middle}
    return nir.NIRGraph(nodes=nodes, edges=edges, type_check=False)


def _lif(n: int = 4) -> nir.LIF:
    return nir.LIF(tau=np.full(n, 0.01), r=np.ones(n), v_leak=np.zeros(n), v_threshold=np.ones(n), v_reset=np.zeros(n))


@pytest.mark.parametrize(
    ("graph", "pattern"),
    [
        (_graph({"t": nir.Threshold(threshold=np.ones(4)), "n": _lif()}, [("in", "t"), ("t", "n")]),
         r"NIR node 't' is a Threshold, which has no neurovpr equivalent"),
        (_graph({"w": nir.Linear(weight=np.ones((4, 4))), "o": nir.Output(output_type={"output": np.array([4])})},
                [("in", "w"), ("w", "o")]), r"NIR Output 'o' is fed by linear node\(s\) \['w'\]"),
        (_graph({"a": nir.Linear(weight=np.ones((4, 4))), "b": nir.Linear(weight=np.ones((4, 4))), "n": _lif()},
                [("in", "a"), ("a", "b"), ("b", "a"), ("b", "n")]), r"cycle through linear nodes only"),
        (_graph({"w": nir.Linear(weight=np.ones((3, 5))), "n": _lif(3)}, [("in", "w"), ("w", "n")]),
         r"NIR node 'w' \(Linear\): weight \(3, 5\) does not take an input of shape \(4,\)"),
        (_graph({"n": nir.LIF(tau=np.full(4, 1e-5), r=np.ones(4), v_leak=np.zeros(4), v_threshold=np.ones(4),
                              v_reset=np.zeros(4))}, [("in", "n")]), None),
    ],
)  # fmt: skip
def test_import_names_what_it_cannot_map(graph: nir.NIRGraph, pattern: str | None) -> None:
    if pattern is None:  # an Euler time constant at or below the step has no decaying equivalent
        with pytest.raises(nv.ValidationError, match=r"NIR LIF node 'n': tau = 1e-05 s is not longer than the Euler step"):
            nir_to_network(graph, integration="euler")
        return
    with pytest.raises(nv.ValidationError, match=pattern):
        nir_to_network(graph)


def test_broken_and_foreign_files_get_one_sentence(tmp_path: Path) -> None:
    with pytest.raises(nv.FileFormatError, match=r"NIR file '.*missing.nir' does not exist"):
        import_nir(tmp_path / "missing.nir")
    (tmp_path / "text.nir").write_text("not hdf5")
    with pytest.raises(nv.FileFormatError, match=r"is not an HDF5 file"):
        import_nir(tmp_path / "text.nir")
    nv.save(_net(nv.IF_curr_exp()), tmp_path / "network.h5")
    with pytest.raises(nv.FileFormatError, match=r"has no /node group, so it is not a NIR graph"):
        import_nir(tmp_path / "network.h5")
    net = _net(nv.IF_curr_exp(**_OK))
    export_nir(net, tmp_path / "ok.nir")
    data = (tmp_path / "ok.nir").read_bytes()
    (tmp_path / "cut.nir").write_bytes(data[: len(data) // 2])
    with pytest.raises(nv.FileFormatError, match=r"NIR file '.*cut.nir' is truncated or unreadable"):
        import_nir(tmp_path / "cut.nir")
    with h5py.File(tmp_path / "ok.nir", "a") as f:
        f["node/nodes/dst/type"][...] = np.bytes_("Bogus")
    with pytest.raises(nv.FileFormatError, match=r"node 'dst' has the type 'Bogus', which NIR does not define \(known: "):
        import_nir(tmp_path / "ok.nir")


def test_a_changed_graph_is_not_restored_from_metadata(tmp_path: Path) -> None:
    net = _net(nv.IF_curr_exp(**_OK))
    graph = network_to_nir(net)
    graph.nodes["src->dst"].weight = graph.nodes["src->dst"].weight * 2  # what a peer's training would do
    result = nir_to_network(graph)
    assert not result.restored and any("a peer changed it" in n for n in result.notes)
    np.testing.assert_array_equal(result.network.projections["src->dst"].synapse.weight, 0.2)
