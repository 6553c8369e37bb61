"""Save/load: exact round trips of every IR type, what save refuses, atomic writes, saved simulations.

Damaged and foreign files are in ``test_serialization_damage.py``.
"""

from __future__ import annotations

import dataclasses
import json
import os
from pathlib import Path

import h5py
import numpy as np
import pytest
from network_files import contents, types_in

import neurovpr as nv
from neurovpr.errors import FileFormatError, ValidationError
from neurovpr.ir.serialization import FORMAT_NAME, FORMAT_VERSION, NODE_TYPES


# -- round trips ----------------------------------------------------------------------
def test_round_trip_every_type_is_equal(saved: Path, network: nv.Network) -> None:
    loaded = nv.load(saved)
    assert loaded == network
    assert list(loaded.populations) == list(network.populations)
    assert list(loaded.projections) == list(network.projections)
    attrs, _ = contents(saved)
    assert types_in(json.loads(attrs["graph"])) == set(NODE_TYPES), "the test network must use every IR type"


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
    assert checked == 14
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
    attrs1, arrays1 = contents(saved)
    attrs2, arrays2 = contents(again)
    assert attrs1 == attrs2
    assert arrays1.keys() == arrays2.keys() and len(arrays1) == 14
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
    from neurovpr.ir.cells import CELL_TYPES
    from neurovpr.ir.connectors import CONNECTORS
    from neurovpr.ir.distributions import DISTRIBUTIONS
    from neurovpr.ir.synapses import SYNAPSE_TYPES

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
