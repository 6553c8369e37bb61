"""Save/load: exact round trips of every IR type, clear errors on damaged files, atomic writes."""

from __future__ import annotations

import dataclasses
import json
import os
import traceback
from pathlib import Path

import h5py
import numpy as np
import pytest

import neurovpr as nv
from neurovpr import serialization
from neurovpr.errors import FileFormatError, ValidationError
from neurovpr.serialization import FORMAT_NAME, FORMAT_VERSION, NODE_TYPES


def full_network() -> nv.Network:
    """A network that uses every registered IR type and every kind of array."""
    rng = np.random.default_rng(0)
    net = nv.Network("every_type")
    net.add_population("poisson", 6, nv.SpikeSourcePoisson(rate=np.linspace(0.0, 50.0, 6), start=5.0))
    net.add_population("array", 3, nv.SpikeSourceArray.from_lists([[1.0, 2.5], [], [0.1, 7.0, 9.25]]))
    net.add_population(
        "curr",
        4,
        nv.IF_curr_exp(tau_m=np.array([10.0, 12.5, 15.0, 20.0]), i_offset=0.1),
        v_init=np.array([-65.0, -64.0, -63.0, -62.0]),
    )
    net.add_population("cond", 5, nv.IF_cond_exp(e_rev_I=-80.0), v_init=-60.0)
    net.add_population("adaptive", 5, nv.IF_cond_exp_adaptive(theta_init=rng.uniform(0.0, 1.0, 5), tau_theta=1e6))
    net.add_population("ca2", 3, nv.IF_curr_exp_ca2_adaptive(i_alpha=0.2, i_offset=0.02, tau_m=np.array([5.0, 6.0, 7.0])))
    net.add_population("soft_in", 4, nv.SoftLIF(sigma=0.05))
    net.add_population("soft_out", 2, nv.SoftLIF())
    net.add_population("image", 50, nv.SpikeSourcePoisson(rate=10.0, duration=200.0))
    net.add_population("feature", 27, nv.IF_curr_exp())

    net.connect(
        "poisson",
        "curr",
        nv.AllToAllConnector(),
        nv.StaticSynapse(weight=rng.normal(0.0, 1.0, (6, 4)), delay=nv.Uniform(low=1.0, high=2.0)),
    )
    net.connect(
        "curr",
        "curr",
        nv.AllToAllConnector(allow_self_connections=False),
        nv.StaticSynapse(weight=nv.Normal(mu=0.5, sigma=0.1, low=0.0), delay=np.full(12, 1.5)),
        receptor_type="inhibitory",
        name="lateral",
    )
    net.connect("adaptive", "cond", nv.OneToOneConnector(), nv.StaticSynapse(weight=np.linspace(0.1, 0.5, 5)))
    net.connect(
        "poisson",
        "adaptive",
        nv.FixedProbabilityConnector(p_connect=0.5, seed=7),
        nv.DiehlCookSTDP(weight=nv.Uniform(low=0.0, high=0.3), x_tar=0.1, mu=0.5),
    )
    net.connect(
        "poisson",
        "ca2",
        nv.FixedNumberPreConnector(n=nv.Normal(mu=3.0, sigma=1.0), seed=11),
        nv.STDPMechanism(
            timing_dependence=nv.SpikePairRule(tau_plus=1.25, tau_minus=0.1, A_plus=0.3, A_minus=0.15),
            weight_dependence=nv.AdditiveWeightDependence(w_min=0.0, w_max=0.5),
            weight=0.25,
            delay=2.0,
        ),
    )
    net.connect(
        "array",
        "ca2",
        nv.FixedNumberPreConnector(n=2),
        nv.STDPMechanism(
            weight_dependence=nv.MultiplicativeWeightDependence(w_min=0.0, w_max=1.0),
            weight=nv.Uniform(low=0.1, high=0.9),
        ),
    )
    net.connect(
        "array",
        "cond",
        nv.FromListConnector(conn_list=[[0, 1, 0.5, 1.0], [2, 3, 0.25, 2.5]]),
        receptor_type="inhibitory",
    )
    net.connect("soft_in", "soft_out", nv.AllToAllConnector(), nv.StaticSynapse(weight=rng.normal(size=(4, 2))))
    net.connect(
        "image",
        "feature",
        nv.ConvolutionConnector(input_shape=(2, 5, 5), kernel_shape=(3, 3), out_channels=3, stride=(2, 2), padding=(1, 1)),
        nv.StaticSynapse(weight=rng.normal(size=(3, 2, 3, 3)), delay=1.0),
    )
    return net


@pytest.fixture(scope="module")
def network() -> nv.Network:
    return full_network()


@pytest.fixture
def saved(tmp_path: Path, network: nv.Network) -> Path:
    path = tmp_path / "net.h5"
    nv.save(network, path)
    return path


def _types_in(data: object) -> set[str]:
    if isinstance(data, dict):
        found = {data["type"]} if "type" in data and "fields" in data else set()
        return found.union(*(_types_in(v) for v in data.values()))
    if isinstance(data, list):
        return set().union(*(_types_in(v) for v in data))
    return set()


def _contents(path: Path) -> tuple[dict, dict]:
    with h5py.File(path, "r") as f:
        attrs = {k: f.attrs[k] for k in f.attrs}
        arrays = {k: f["arrays"][k][()] for k in f["arrays"]}
        dtypes = {k: f["arrays"][k].dtype for k in f["arrays"]}
    return attrs, {k: (dtypes[k], np.asarray(v)) for k, v in arrays.items()}


def _load_error(path: Path) -> FileFormatError:
    with pytest.raises(FileFormatError) as info:
        nv.load(path)
    exc = info.value
    text = str(exc)
    assert str(path) in text and "\n" not in text and text.endswith(".")
    rendered = "".join(traceback.format_exception(exc))
    assert "h5py" not in rendered and "During handling" not in rendered and "direct cause" not in rendered
    return exc


# -- round trips ----------------------------------------------------------------------
def test_round_trip_every_type_is_equal(saved: Path, network: nv.Network) -> None:
    loaded = nv.load(saved)
    assert loaded == network
    assert list(loaded.populations) == list(network.populations)
    assert list(loaded.projections) == list(network.projections)
    attrs, _ = _contents(saved)
    assert _types_in(json.loads(attrs["graph"])) == set(NODE_TYPES), "the test network must use every IR type"


def test_round_trip_arrays_are_bit_identical(saved: Path, network: nv.Network) -> None:
    loaded = nv.load(saved)
    checked = 0

    def compare(a: object, b: object) -> None:
        nonlocal checked
        if isinstance(a, np.ndarray):
            assert isinstance(b, np.ndarray) and a.dtype == b.dtype and a.shape == b.shape
            assert a.tobytes() == b.tobytes()
            assert not b.flags.writeable
            checked += 1
        elif dataclasses.is_dataclass(a) and not isinstance(a, type):
            assert type(a) is type(b)
            for f in dataclasses.fields(a):
                compare(getattr(a, f.name), getattr(b, f.name))
        else:
            assert type(a) is type(b) and (a == b or (a != a and b != b))

    for name in network.populations:
        compare(network.populations[name], loaded.populations[name])
    for name in network.projections:
        compare(network.projections[name], loaded.projections[name])
    assert checked == 13
    assert loaded.populations["poisson"].cell_type.duration == float("inf")
    kernel = loaded.projections["image->feature"].synapse.weight
    assert kernel.shape == (3, 2, 3, 3) and kernel.dtype == np.float64
    assert loaded.populations["array"].cell_type.offsets.dtype == np.int64


def test_loaded_network_expands_to_the_same_connections(saved: Path, network: nv.Network) -> None:
    loaded = nv.load(saved)
    for name in network.projections:
        if name.startswith("soft_in"):
            continue
        a = nv.expand(network, name, dt=0.1, seed=5)
        b = nv.expand(loaded, name, dt=0.1, seed=5)
        for field in ("pre", "post", "weight", "delay"):
            np.testing.assert_array_equal(getattr(a, field), getattr(b, field))


def test_saving_the_loaded_network_gives_identical_graph_and_datasets(tmp_path: Path, saved: Path) -> None:
    again = tmp_path / "again.h5"
    nv.save(nv.load(saved), again)
    attrs1, arrays1 = _contents(saved)
    attrs2, arrays2 = _contents(again)
    assert attrs1 == attrs2
    assert arrays1.keys() == arrays2.keys() and len(arrays1) == 13
    for key, (dtype, values) in arrays1.items():
        assert arrays2[key][0] == dtype
        assert arrays2[key][1].shape == values.shape and arrays2[key][1].tobytes() == values.tobytes()


def test_file_layout_and_path_types(tmp_path: Path, network: nv.Network) -> None:
    path = tmp_path / "layout.h5"
    nv.save(network, str(path))
    with h5py.File(path, "r") as f:
        assert f.attrs["format"] == FORMAT_NAME == "neurovpr-network"
        assert isinstance(f.attrs["format_version"], np.integer) and f.attrs["format_version"] == FORMAT_VERSION == 1
        assert f.attrs["name"] == "every_type"
        graph = json.loads(f.attrs["graph"])
    assert set(graph) == {"populations", "projections"}
    assert graph["populations"][0]["fields"]["cell_type"]["fields"]["duration"] == {"$float": "inf"}
    assert graph["populations"][0]["fields"]["cell_type"]["fields"]["rate"] == {"$array": "/arrays/0"}
    assert nv.load(str(path)) == nv.load(path) == network


def test_node_registry_is_read_only_and_built_from_the_type_tables() -> None:
    from neurovpr.cells import CELL_TYPES
    from neurovpr.connectors import CONNECTORS
    from neurovpr.distributions import DISTRIBUTIONS
    from neurovpr.synapses import SYNAPSE_TYPES

    expected = {**CELL_TYPES, **SYNAPSE_TYPES, **CONNECTORS, **DISTRIBUTIONS, "Population": nv.Population}
    expected["Projection"] = nv.Projection
    assert dict(NODE_TYPES) == expected
    with pytest.raises(TypeError):
        NODE_TYPES["Evil"] = object  # type: ignore[index]


# -- what save refuses ------------------------------------------------------------------
def test_save_refuses_non_networks_and_unregistered_types(tmp_path: Path) -> None:
    with pytest.raises(ValidationError, match="expected a Network or a Simulation, got dict"):
        nv.save({}, tmp_path / "x.h5")

    @dataclasses.dataclass(frozen=True, slots=True, kw_only=True, eq=False)
    class CustomCell(nv.IF_curr_exp):
        pass

    net = nv.Network("custom")
    net.add_population("p", 2, CustomCell())
    with pytest.raises(ValidationError, match=r"population 'p'\.cell_type is a CustomCell, which is not a registered"):
        nv.save(net, tmp_path / "custom.h5")
    assert os.listdir(tmp_path) == []


# -- damaged and foreign files ----------------------------------------------------------
def test_missing_file(tmp_path: Path) -> None:
    exc = _load_error(tmp_path / "nothing.h5")
    assert str(exc) == f"Network file {str(tmp_path / 'nothing.h5')!r} does not exist."


def test_text_file_is_not_hdf5(tmp_path: Path) -> None:
    path = tmp_path / "notes.h5"
    path.write_text("just some text, not a network\n")
    assert str(_load_error(path)) == f"Network file {str(path)!r} is not an HDF5 file."
    empty = tmp_path / "empty.h5"
    empty.write_bytes(b"")
    assert str(_load_error(empty)).endswith("is empty.")


def test_truncated_file(saved: Path) -> None:
    data = saved.read_bytes()
    saved.write_bytes(data[: len(data) // 2])
    assert "is truncated" in str(_load_error(saved))


@pytest.mark.parametrize("cut", [0.02, 0.1, 0.3, 0.7, 0.9, 0.99])
def test_file_cut_anywhere_gives_one_error(saved: Path, cut: float) -> None:
    data = saved.read_bytes()
    saved.write_bytes(data[: max(1, int(len(data) * cut))])
    _load_error(saved)


def test_corrupted_middle_is_detected(saved: Path) -> None:
    data = bytearray(saved.read_bytes())
    mid = len(data) // 2
    data[mid : mid + 16] = bytes(b ^ 0xFF for b in data[mid : mid + 16])
    saved.write_bytes(bytes(data))
    assert "corrupted" in str(_load_error(saved))


def test_flipped_bytes_never_load_a_different_network(saved: Path, network: nv.Network) -> None:
    original = saved.read_bytes()
    errors = 0
    for fraction in np.linspace(0.0, 0.98, 25):
        data = bytearray(original)
        pos = int(len(data) * fraction)
        data[pos : pos + 4] = bytes(b ^ 0x5A for b in data[pos : pos + 4])
        saved.write_bytes(bytes(data))
        try:
            loaded = nv.load(saved)
        except FileFormatError as exc:
            assert "\n" not in str(exc)
            errors += 1
        else:
            assert loaded == network  # the flip hit unused space
    assert errors >= 15


def test_wrong_format_name(saved: Path) -> None:
    with h5py.File(saved, "r+") as f:
        f.attrs["format"] = "someone-elses-format"
    msg = str(_load_error(saved))
    assert "is not a neurovpr network file" in msg and "'someone-elses-format'" in msg
    with h5py.File(saved, "r+") as f:
        del f.attrs["format"]
    assert "has no 'format' attribute" in str(_load_error(saved))


def test_future_version(saved: Path) -> None:
    with h5py.File(saved, "r+") as f:
        f.attrs["format_version"] = np.int64(7)
    assert str(_load_error(saved)) == (
        f"Network file {str(saved)!r} was written by format version 7; this neurovpr reads version 1."
    )


def test_edited_content_fails_the_checksum(saved: Path) -> None:
    with h5py.File(saved, "r+") as f:
        f["arrays"]["0"][0] = 123.0
    assert "does not match the checksum" in str(_load_error(saved))


def _write_graph(path: Path, graph: str, arrays: list[np.ndarray] | None = None, name: str = "net") -> None:
    serialization._write_file(str(path), name, graph, arrays or [])


def _node(type_name: str, **fields: object) -> dict:
    return {"type": type_name, "fields": fields}


def _pop(cell: dict, name: str = "p", size: int = 2) -> dict:
    return _node("Population", name=name, size=size, cell_type=cell, v_init=None)


@pytest.mark.parametrize(
    ("graph", "arrays", "message"),
    [
        ("{not json", None, "has a graph that is not valid JSON"),
        ('{"populations": [], "projections": [], "x": NaN}', None, "not valid JSON"),
        ("[1, 2]", None, "has a graph that is not an object with 'populations' and 'projections'"),
        (
            json.dumps({"populations": [_pop(_node("Nope"))], "projections": []}),
            None,
            "populations[0] ('p').cell_type has unknown type 'Nope'",
        ),
        (
            json.dumps({"populations": [_pop(_node("IF_curr_exp", tau_mm=1.0))], "projections": []}),
            None,
            "populations[0] ('p').cell_type (IF_curr_exp) has unknown field(s) 'tau_mm'",
        ),
        (
            json.dumps({"populations": [_node("Population", name="p", cell_type=_node("IF_curr_exp"))], "projections": []}),
            None,
            "populations[0] ('p') (Population) lacks the field(s) 'size'",
        ),
        (
            json.dumps({"populations": [_pop(_node("IF_curr_exp", tau_m=-1.0))], "projections": []}),
            None,
            "populations[0] ('p').cell_type (IF_curr_exp) is invalid: IF_curr_exp.tau_m must be > 0.0 ms, got -1.0",
        ),
        (
            json.dumps({"populations": [_pop(_node("IF_curr_exp", tau_m="fast"))], "projections": []}),
            None,
            "IF_curr_exp.tau_m must be a number or a 1-D array, got 'fast'",
        ),
        (
            json.dumps({"populations": [_pop(_node("IF_curr_exp", tau_m={"$array": "/arrays/3"}))], "projections": []}),
            None,
            "populations[0] ('p').cell_type.tau_m refers to a missing array '/arrays/3'",
        ),
        (
            json.dumps({"populations": [_pop(_node("IF_curr_exp", tau_m={"$array": "/arrays/0"}))], "projections": []}),
            [np.array([10.0, 20.0, 30.0])],
            "IF_curr_exp.tau_m has 3 values for 2 neurons",
        ),
        (
            json.dumps({"populations": [_pop(_node("IF_curr_exp", tau_m={"$float": "fast"}))], "projections": []}),
            None,
            "has an invalid $float value 'fast'",
        ),
        (
            json.dumps({"populations": [_pop(_node("IF_curr_exp", tau_m={"x": 1}))], "projections": []}),
            None,
            "is an object with unexpected keys ['x']",
        ),
        (
            json.dumps({"populations": [_pop(_node("OneToOneConnector"))], "projections": []}),
            None,
            "cell_type must be a neurovpr cell type, got OneToOneConnector",
        ),
        (
            json.dumps({"populations": [_node("Uniform")], "projections": []}),
            None,
            "populations[0] is not a Population",
        ),
        (
            json.dumps({"populations": [_pop(_node("IF_curr_exp")), _pop(_node("IF_curr_exp"))], "projections": []}),
            None,
            "populations[1] ('p') cannot be added: Network 'net' already has a population named 'p'",
        ),
        (
            json.dumps(
                {
                    "populations": [_pop(_node("IF_curr_exp"))],
                    "projections": [
                        _node(
                            "Projection",
                            name="q->p",
                            pre="q",
                            post="p",
                            connector=_node("AllToAllConnector"),
                            synapse=_node("StaticSynapse"),
                        )
                    ],
                }
            ),
            None,
            "projections[0] ('q->p') cannot be added: Projection 'q->p': pre population 'q' does not exist",
        ),
    ],
)
def test_invalid_graphs_name_the_element(tmp_path: Path, graph: str, arrays: list | None, message: str) -> None:
    path = tmp_path / "bad.h5"
    _write_graph(path, graph, arrays)
    exc = _load_error(path)
    assert message in str(exc)


def test_deeply_nested_graph_is_refused(tmp_path: Path) -> None:
    value: object = 1.0
    for _ in range(200):
        value = [value]
    path = tmp_path / "deep.h5"
    _write_graph(path, json.dumps({"populations": [_pop(_node("IF_curr_exp", tau_m=value))], "projections": []}))
    assert "nested more than 64 levels deep" in str(_load_error(path))
    _write_graph(path, "[" * 100000 + "]" * 100000)
    assert "not valid JSON" in str(_load_error(path))


def test_object_string_and_filtered_datasets_are_refused(tmp_path: Path) -> None:
    graph = json.dumps({"populations": [], "projections": []})
    path = tmp_path / "strings.h5"
    _write_graph(path, graph)
    with h5py.File(path, "r+") as f:
        f["arrays"].create_dataset("0", data=["a", "bb"], dtype=h5py.string_dtype())
    assert "only plain numeric arrays are allowed" in str(_load_error(path))

    _write_graph(path, graph)
    with h5py.File(path, "r+") as f:
        f["arrays"].create_dataset("0", data=np.zeros(100), compression="gzip")
    assert "filtered (compressed) dataset /arrays/0" in str(_load_error(path))

    other = tmp_path / "other.h5"
    with h5py.File(other, "w") as f:
        f.create_dataset("x", data=np.zeros(3))
    _write_graph(path, graph)
    with h5py.File(path, "r+") as f:
        f["arrays"]["0"] = h5py.ExternalLink(str(other), "x")
    assert "is not a plain dataset" in str(_load_error(path))


def test_file_holds_no_pickled_or_object_data(saved: Path) -> None:
    kinds = set()

    def visit(name: str, obj: object) -> None:
        if isinstance(obj, h5py.Dataset):
            assert obj.dtype.kind in "biuf" and h5py.check_vlen_dtype(obj.dtype) is None, name
            kinds.add(obj.dtype.kind)
        for value in obj.attrs.values():
            assert isinstance(value, (str, np.integer)), (name, type(value))

    with h5py.File(saved, "r") as f:
        for value in f.attrs.values():
            assert isinstance(value, (str, np.integer))
        f.visititems(visit)
    assert kinds == {"f", "i"}
    raw = saved.read_bytes()
    for marker in (b"numpy.core", b"_reconstruct", b"builtins", b"copyreg", b"__main__"):
        assert marker not in raw  # class references every pickle of an object or array carries


# -- atomic writes ---------------------------------------------------------------------
def test_failed_write_leaves_previous_file_and_no_temporary(
    tmp_path: Path, saved: Path, network: nv.Network, monkeypatch: pytest.MonkeyPatch
) -> None:
    before = saved.read_bytes()
    listing = sorted(os.listdir(tmp_path))
    calls = []
    real_create = h5py.Group.create_dataset

    def failing_create(self: h5py.Group, name: str, *args: object, **kwargs: object) -> object:
        calls.append(name)
        if len(calls) == 3:
            raise OSError(28, "No space left on device")
        return real_create(self, name, *args, **kwargs)

    monkeypatch.setattr(h5py.Group, "create_dataset", failing_create)
    with pytest.raises(FileFormatError, match=r"cannot be written \(\[Errno 28\] No space left on device\)"):
        nv.save(network, saved)
    assert len(calls) == 3
    assert saved.read_bytes() == before
    assert sorted(os.listdir(tmp_path)) == listing

    def interrupted(*args: object, **kwargs: object) -> None:
        raise KeyboardInterrupt

    monkeypatch.setattr(h5py.Group, "create_dataset", interrupted)
    with pytest.raises(KeyboardInterrupt):
        nv.save(network, tmp_path / "new.h5")
    assert sorted(os.listdir(tmp_path)) == listing
    monkeypatch.undo()
    assert nv.load(saved) == network


def test_failed_rename_leaves_no_temporary(tmp_path: Path, network: nv.Network) -> None:
    folder = tmp_path / "target.h5"
    folder.mkdir()
    with pytest.raises(FileFormatError, match="cannot be written"):
        nv.save(network, folder)
    assert os.listdir(tmp_path) == ["target.h5"] and os.listdir(folder) == []
    with pytest.raises(FileFormatError, match=r"the folder .* does not exist"):
        nv.save(network, tmp_path / "missing" / "net.h5")
    assert os.listdir(tmp_path) == ["target.h5"]


def test_overwrite_replaces_the_whole_file(tmp_path: Path, saved: Path) -> None:
    small = nv.Network("small")
    small.add_population("only", 1, nv.IF_curr_exp())
    nv.save(small, saved)
    assert nv.load(saved) == small
    assert sorted(os.listdir(tmp_path)) == ["net.h5"]


# -- simulations ------------------------------------------------------------------------
def test_save_simulation_stores_learned_weights(tmp_path: Path) -> None:
    net = nv.Network("learner")
    net.add_population("pixels", 20, nv.SpikeSourcePoisson(rate=0.0))
    net.add_population("exc", 4, nv.IF_cond_exp_adaptive())
    net.connect("pixels", "exc", nv.FixedProbabilityConnector(p_connect=0.8), nv.DiehlCookSTDP(weight=0.1))
    sim = nv.compile(net, backend="reference", dt=0.5, seed=3)
    before = sim.weights("pixels->exc", format="list")
    sim.run(200.0, inputs={"pixels": np.full(20, 60.0)})
    after = sim.weights("pixels->exc", format="list")
    assert not np.array_equal(before, after)
    path = tmp_path / "learned.h5"
    nv.save(sim, path)
    loaded = nv.load(path)
    assert loaded == sim.to_network()
    np.testing.assert_array_equal(loaded.projections["pixels->exc"].synapse.weight, after)
    assert loaded.projections["pixels->exc"].connector.seed is not None
