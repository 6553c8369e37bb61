"""The one safe HDF5 reader: nothing outside the file is read, forged sizes are refused before reading."""

from __future__ import annotations

import time
from pathlib import Path

import h5py
import numpy as np
import pytest

import neurovpr as nv
from neurovpr.errors import FileFormatError
from neurovpr.hdf5 import HDF5Rules, open_hdf5
from neurovpr.ir import serialization
from neurovpr.resources import ResourceLimitError


def _network() -> nv.Network:
    net = nv.Network("small")
    net.add_population("src", 4, nv.SpikeSourcePoisson(rate=10.0))
    net.add_population("dst", 3, nv.IF_curr_exp())
    net.connect("src", "dst", nv.FromListConnector(conn_list=[(0, 0, 0.5, 1.0), (1, 2, 0.25, 1.0)]), nv.StaticSynapse())
    return net


def _reforge(path: Path, make_array) -> None:
    """Replace /arrays/0 by what ``make_array(group)`` creates and recompute the checksum over what it reads."""
    with h5py.File(path, "r+") as f:
        original = np.array(f["arrays/0"][()])
        del f["arrays/0"]
        make_array(f["arrays"], original)
        arrays = [np.array(f["arrays"][str(i)][()]) for i in range(len(f["arrays"]))]
        f.attrs["content_sha256"] = serialization._digest(str(f.attrs["name"]), str(f.attrs["graph"]), arrays)


def _load_refused(path: Path, pattern: str) -> None:
    start = time.perf_counter()
    with pytest.raises(FileFormatError, match=pattern):
        nv.load(path)
    assert time.perf_counter() - start < 10.0


@pytest.fixture
def saved(tmp_path: Path) -> Path:
    path = tmp_path / "net.h5"
    nv.save(_network(), path)
    return path


def test_external_storage_with_valid_checksum_is_refused(saved: Path, tmp_path: Path) -> None:
    secret = tmp_path / "secret.bin"

    def external(group, original):
        secret.write_bytes(np.ascontiguousarray(original).tobytes())
        group.create_dataset("0", shape=original.shape, dtype=original.dtype, external=[(str(secret), 0, original.nbytes)])

    _reforge(saved, external)
    _load_refused(saved, r"dataset /arrays/0 with external storage \(its bytes lie in another file\); refused")


def test_virtual_dataset_with_valid_checksum_is_refused(saved: Path, tmp_path: Path) -> None:
    other = tmp_path / "other.h5"

    def virtual(group, original):
        with h5py.File(other, "w") as o:
            o["x"] = original
        layout = h5py.VirtualLayout(shape=original.shape, dtype=original.dtype)
        layout[...] = h5py.VirtualSource(str(other), "x", shape=original.shape)
        group.create_virtual_dataset("0", layout)

    _reforge(saved, virtual)
    _load_refused(saved, r"virtual dataset /arrays/0, which reads other datasets or files; refused")


def test_soft_and_external_links_are_refused(saved: Path, tmp_path: Path) -> None:
    other = tmp_path / "other.h5"
    with h5py.File(other, "w") as o:
        o["x"] = np.zeros(3)
    with h5py.File(saved, "r+") as f:
        f["arrays/1"] = h5py.ExternalLink(str(other), "x")
    _load_refused(saved, r"external link /arrays/1 to '.*other.h5'; refused")
    with h5py.File(saved, "r+") as f:
        del f["arrays/1"]
        f["arrays/1"] = h5py.SoftLink("/arrays/0")
    _load_refused(saved, r"has a SoftLink at /arrays/1; only plain")
    with h5py.File(saved, "r+") as f:
        del f["arrays/1"]
        f["arrays/1"] = f["arrays/0"]  # a second hard link to the same dataset
    _load_refused(saved, r"reaches the object /arrays/(0|1) by more than one link")


def test_declared_size_past_the_file_is_refused_before_reading(saved: Path) -> None:
    with h5py.File(saved, "r+") as f:
        f["arrays"].create_dataset("1", shape=(100_000, 1_000_000), dtype="f8")  # 745 GiB declared, never written
    _load_refused(saved, r"is truncated or forged: dataset /arrays/1 declares 745.1 GiB, more than the whole file")


def test_compressed_bomb_and_memory_limit(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    rules = HDF5Rules(what="Test file", filters=("gzip",))
    path = tmp_path / "bomb.h5"
    with h5py.File(path, "w") as f:
        f.create_dataset("zeros", data=np.zeros(2_000_000), compression="gzip", chunks=(250_000,))
        f.create_dataset("forged", shape=(10**9,), dtype="f8", compression="gzip", chunks=(10**6,))  # no chunk written
    with pytest.raises(FileFormatError, match=r"compressed dataset /forged declares 7.5 GiB from 0 B of stored data"):
        with open_hdf5(path, rules):
            pass
    with h5py.File(path, "r+") as f:
        del f["forged"]
    monkeypatch.setenv("NEUROVPR_MAX_MEMORY", "1M")
    with pytest.raises(
        ResourceLimitError,
        match=r"dataset /zeros \(2000000 of float64\) would need about 15.3 MiB.*limit is 1.0 MiB \(NEUROVPR_MAX_MEMORY\)",
    ):
        with open_hdf5(path, rules):
            pass
    monkeypatch.setenv("NEUROVPR_MAX_MEMORY", "1G")
    with open_hdf5(path, rules) as f:
        assert f["zeros"].shape == (2_000_000,)
    with pytest.raises(FileFormatError, match=r"with the filter\(s\) gzip; this kind of file uses none"):
        with open_hdf5(path, HDF5Rules(what="Test file")):
            pass


def test_nir_declared_linear_is_refused_before_reading(tmp_path: Path) -> None:
    pytest.importorskip("nir")
    from neurovpr.interop.nir import export_nir, import_nir

    path = tmp_path / "net.nir"
    net = nv.Network("n")
    net.add_population("src", 4, nv.SpikeSourcePoisson(rate=10.0))
    net.add_population("dst", 3, nv.IF_curr_exp(tau_refrac=0.0))
    net.connect("src", "dst", nv.AllToAllConnector(), nv.StaticSynapse(weight=0.1))
    export_nir(net, path)
    with h5py.File(path, "r+") as f:
        weight = f["node/nodes/src->dst/weight"]
        del f["node/nodes/src->dst/weight"]
        f["node/nodes/src->dst"].create_dataset("weight", shape=(100_000, 1_000_000), dtype="f8")
        assert weight is not None
    start = time.perf_counter()
    with pytest.raises(
        FileFormatError, match=r"NIR file .* is truncated or forged: dataset /node/nodes/src->dst/weight declares 745.1 GiB"
    ):
        import_nir(path)
    assert time.perf_counter() - start < 10.0
