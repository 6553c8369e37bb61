"""Seeded fuzzing of network, NIR, run, event and PN spike files: every mutation is refused cleanly or loads.

Each case mutates a valid file (truncation, bit flips, a byte range overwritten,
bytes inserted) with a seeded generator and loads it. The only outcomes allowed are
a project error (:class:`~neurovpr.errors.NeurovprError`) or a successful load,
within a time bound, and a loaded network file must equal the original (its checksum
catches any change that still parses). The default run covers a few seeds per
format; ``-m slow`` runs many more.
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
import scipy.io

import neurovpr as nv
from neurovpr.apps.modelapi import read_run_info
from neurovpr.data.events import read_events, read_pn_mat, write_events
from neurovpr.data.events.stream import EventStream
from neurovpr.errors import NeurovprError

FAST_SEEDS = range(6)
SLOW_SEEDS = range(6, 200)


def mutate(data: bytes, seed: int) -> bytes:
    """One seeded mutation of ``data``: truncate, flip bits, overwrite a range, or insert bytes."""
    rng = np.random.default_rng(seed)
    buf = bytearray(data)
    kind = seed % 4
    if kind == 0:
        return bytes(buf[: int(rng.integers(0, len(buf)))])
    if kind == 1:
        for pos in rng.integers(0, len(buf), size=int(rng.integers(1, 16))):
            buf[pos] ^= 1 << int(rng.integers(0, 8))
        return bytes(buf)
    start = int(rng.integers(0, len(buf)))
    chunk = rng.integers(0, 256, size=int(rng.integers(1, 64)), dtype=np.uint8).tobytes()
    if kind == 2:
        buf[start : start + len(chunk)] = chunk
        return bytes(buf[: len(data)])
    return bytes(buf[:start] + chunk + buf[start:])


def _network() -> nv.Network:
    net = nv.Network("fuzz")
    net.add_population("s", 5, nv.SpikeSourcePoisson(rate=np.linspace(1.0, 5.0, 5)))
    net.add_population("a", 4, nv.IF_curr_exp(tau_refrac=0.0, v_thresh=np.full(4, -50.0)))
    net.connect("s", "a", nv.AllToAllConnector(), nv.StaticSynapse(weight=np.arange(20.0).reshape(5, 4) / 100))
    return net


def _stream() -> EventStream:
    n = 50
    rng = np.random.default_rng(0)
    return EventStream(
        width=8, height=6, x=rng.integers(0, 8, n), y=rng.integers(0, 6, n), t=np.arange(n) * 10, p=rng.integers(0, 2, n)
    )


def _case(tmp: Path, name: str) -> tuple[Path, Callable[[Path], object], Callable[[object], None]]:
    """A valid file of ``name``'s format, its loader and a check of a successful load."""
    if name == "network":
        path, net = tmp / "net.h5", _network()
        nv.save(net, path)
        return path, nv.load, lambda got: (_ for _ in ()).throw(AssertionError("changed network loaded")) if got != net else None
    if name == "nir":
        pytest.importorskip("nir")
        from neurovpr.interop.nir import export_nir, import_nir

        path = tmp / "net.nir"
        export_nir(_network(), path)
        return path, import_nir, lambda got: None
    if name == "run":
        path = tmp / "run" / "run.json"
        path.parent.mkdir()
        path.write_text(json.dumps({"model": "modular", "backend": "reference", "seed": 0}))
        return path, lambda p: read_run_info(p.parent), lambda got: None
    if name == "events_h5":
        return write_events(_stream(), tmp / "ev.h5"), read_events, lambda got: None
    if name == "events_npz":
        return write_events(_stream(), tmp / "ev.npz"), read_events, lambda got: None
    if name == "events_csv":
        return write_events(_stream(), tmp / "ev.csv"), read_events, lambda got: None
    path = tmp / "pn.mat"
    scipy.io.savemat(path, {"t": np.arange(20.0), "idx": np.arange(20.0) % 7})
    return path, read_pn_mat, lambda got: None


FORMATS = ["network", "nir", "run", "events_h5", "events_npz", "events_csv", "pn_mat"]


def _fuzz(tmp_path: Path, name: str, seeds: range) -> None:
    path, load, check = _case(tmp_path, name)
    original = path.read_bytes()
    check(load(path))  # the valid file loads (and any first-use import cost is paid before timing)
    for seed in seeds:
        path.write_bytes(mutate(original, seed))
        start = time.perf_counter()
        try:
            got = load(path)
        except NeurovprError as exc:
            assert "\n" not in str(exc), f"{name} seed {seed}: {exc}"
        else:
            check(got)
        assert time.perf_counter() - start < 10.0, f"{name} seed {seed} took too long"


@pytest.mark.parametrize("name", FORMATS)
def test_fuzz_fast(tmp_path: Path, name: str) -> None:
    _fuzz(tmp_path, name, FAST_SEEDS)


@pytest.mark.slow
@pytest.mark.parametrize("name", FORMATS)
def test_fuzz_many_seeds(tmp_path: Path, name: str) -> None:
    _fuzz(tmp_path, name, SLOW_SEEDS)
