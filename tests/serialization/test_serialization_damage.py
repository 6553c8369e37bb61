"""Load: damaged, truncated, foreign and hand-made invalid files each give one clear error."""

from __future__ import annotations

import json
from pathlib import Path

import h5py
import numpy as np
import pytest
from network_files import load_error

import neurovpr as nv
from neurovpr.errors import FileFormatError
from neurovpr.ir import serialization


# -- damaged and foreign files ----------------------------------------------------------
def test_missing_file(tmp_path: Path) -> None:
    exc = load_error(tmp_path / "nothing.h5")
    assert str(exc) == f"Network file {str(tmp_path / 'nothing.h5')!r} does not exist."


def test_text_file_is_not_hdf5(tmp_path: Path) -> None:
    path = tmp_path / "notes.h5"
    path.write_text("just some text, not a network\n")
    assert str(load_error(path)) == f"Network file {str(path)!r} is not an HDF5 file."
    empty = tmp_path / "empty.h5"
    empty.write_bytes(b"")
    assert str(load_error(empty)).endswith("is empty.")


def test_truncated_file(saved: Path) -> None:
    data = saved.read_bytes()
    saved.write_bytes(data[: len(data) // 2])
    assert "is truncated" in str(load_error(saved))


@pytest.mark.parametrize("cut", [0.02, 0.1, 0.3, 0.7, 0.9, 0.99])
def test_file_cut_anywhere_gives_one_error(saved: Path, cut: float) -> None:
    data = saved.read_bytes()
    saved.write_bytes(data[: max(1, int(len(data) * cut))])
    load_error(saved)


def test_corrupted_middle_is_detected(saved: Path) -> None:
    data = bytearray(saved.read_bytes())
    mid = len(data) // 2
    data[mid : mid + 16] = bytes(b ^ 0xFF for b in data[mid : mid + 16])
    saved.write_bytes(bytes(data))
    assert "corrupted" in str(load_error(saved))


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
    msg = str(load_error(saved))
    assert "is not a neurovpr network file" in msg and "'someone-elses-format'" in msg
    with h5py.File(saved, "r+") as f:
        del f.attrs["format"]
    assert "has no 'format' attribute" in str(load_error(saved))


def test_future_version(saved: Path) -> None:
    with h5py.File(saved, "r+") as f:
        f.attrs["format_version"] = np.int64(7)
    assert str(load_error(saved)) == (
        f"Network file {str(saved)!r} was written by format version 7; this neurovpr reads version 1."
    )


def test_edited_content_fails_the_checksum(saved: Path) -> None:
    with h5py.File(saved, "r+") as f:
        f["arrays"]["0"][0] = 123.0
    assert "does not match the checksum" in str(load_error(saved))


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
    exc = load_error(path)
    assert message in str(exc)


def test_deeply_nested_graph_is_refused(tmp_path: Path) -> None:
    value: object = 1.0
    for _ in range(200):
        value = [value]
    path = tmp_path / "deep.h5"
    _write_graph(path, json.dumps({"populations": [_pop(_node("IF_curr_exp", tau_m=value))], "projections": []}))
    assert "nested more than 64 levels deep" in str(load_error(path))
    _write_graph(path, "[" * 100000 + "]" * 100000)
    assert "not valid JSON" in str(load_error(path))


def test_object_string_and_filtered_datasets_are_refused(tmp_path: Path) -> None:
    graph = json.dumps({"populations": [], "projections": []})
    path = tmp_path / "strings.h5"
    _write_graph(path, graph)
    with h5py.File(path, "r+") as f:
        f["arrays"].create_dataset("0", data=["a", "bb"], dtype=h5py.string_dtype())
    assert "/arrays/0 that is not a plain numeric dataset" in str(load_error(path))

    _write_graph(path, graph)
    with h5py.File(path, "r+") as f:
        f["arrays"].create_dataset("0", data=np.zeros(100), compression="gzip")
    assert "dataset /arrays/0 with the filter(s) gzip; this kind of file uses none" in str(load_error(path))

    other = tmp_path / "other.h5"
    with h5py.File(other, "w") as f:
        f.create_dataset("x", data=np.zeros(3))
    _write_graph(path, graph)
    with h5py.File(path, "r+") as f:
        f["arrays"]["0"] = h5py.ExternalLink(str(other), "x")
    assert "has an external link /arrays/0" in str(load_error(path))


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
