"""Event and PN spike files that declare more than they hold, or point outside themselves, are refused before reading."""

from __future__ import annotations

import struct
import time
from pathlib import Path

import h5py
import numpy as np
import pytest
import scipy.io

from neurovpr.data.events import read_events, read_pn_mat, write_events
from neurovpr.data.events.stream import EventStream
from neurovpr.errors import FileFormatError, NeurovprError
from neurovpr.fileio import is_temp_name
from neurovpr.resources import ResourceLimitError


def _stream() -> EventStream:
    x = np.array([0, 1, 2], dtype=np.int64)
    return EventStream(width=4, height=4, x=x, y=x, t=np.array([1, 2, 3], dtype=np.int64), p=np.array([0, 1, 0]))


def _refused(call, error=NeurovprError, match: str = "") -> None:
    start = time.perf_counter()
    with pytest.raises(error, match=match):
        call()
    assert time.perf_counter() - start < 10.0


def test_mat_declaring_1e11_values_is_refused_before_reading(tmp_path: Path) -> None:
    path = tmp_path / "forged.mat"
    scipy.io.savemat(path, {"t": np.arange(3.0).reshape(1, 3), "idx": np.zeros((1, 3))}, do_compression=False)
    data = path.read_bytes()
    dims = struct.pack("<iiii", 5, 8, 1, 3)
    assert dims in data
    path.write_bytes(data.replace(dims, struct.pack("<iiii", 5, 8, 100_000, 1_000_000), 1))
    _refused(lambda: read_pn_mat(path), FileFormatError, r"forged\.mat' is forged: array 't' declares 1e\+11 values")


def test_mat_with_a_huge_pn_index_or_time_is_refused(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    path = tmp_path / "idx.mat"
    scipy.io.savemat(path, {"t": np.array([0.0, 1.0]), "idx": np.array([0.0, 1e9])})
    monkeypatch.setenv("NEUROVPR_MAX_MEMORY", "8G")
    _refused(lambda: read_pn_mat(path), ResourceLimitError, r"1000000001 PNs .* needs about 59.6 GiB of memory to count")


def test_mat73_external_storage_is_refused(tmp_path: Path) -> None:
    path, secret = tmp_path / "v73.mat", tmp_path / "secret.bin"
    secret.write_bytes(np.arange(4.0).tobytes())
    with h5py.File(path, "w", userblock_size=512) as f:
        f.create_dataset("t", shape=(4,), dtype="f8", external=[(str(secret), 0, 32)])
        f["idx"] = np.zeros(4)
    with open(path, "r+b") as fh:  # MATLAB's 128-byte v7.3 header in the user block
        fh.write(b"MATLAB 7.3 MAT-file".ljust(116) + b"\x00" * 8 + b"\x00\x02IM")
    _refused(lambda: read_pn_mat(path), FileFormatError, r"dataset /t with external storage")


def test_event_hdf5_links_and_forged_npz_are_refused(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    h5 = write_events(_stream(), tmp_path / "ev.h5")
    assert read_events(h5).x.tolist() == [0, 1, 2]
    with h5py.File(h5, "r+") as f:
        del f["events/x"]
        f["events/x"] = h5py.ExternalLink(str(tmp_path / "other.h5"), "x")
    _refused(lambda: read_events(h5), FileFormatError, r"external link /events/x")

    npz = write_events(_stream(), tmp_path / "ev.npz")
    monkeypatch.setenv("NEUROVPR_MAX_MEMORY", "50")
    _refused(lambda: read_events(npz), ResourceLimitError, r"reading events file .*ev\.npz")
    monkeypatch.delenv("NEUROVPR_MAX_MEMORY")
    npy = tmp_path / "ev.npy"
    np.save(npy, np.zeros((3, 4), dtype=np.int64))
    data = npy.read_bytes().replace(b"(3, 4)", b"(9999999999, 4)".ljust(6))
    npy.write_bytes(data)
    _refused(lambda: read_events(npy, sensor_size=(4, 4)), FileFormatError, r"is truncated or forged")
    assert not [p for p in tmp_path.iterdir() if is_temp_name(p.name)]
