"""Hostile NIR files (stride 0, metadata of the wrong type, negative delays) get one sentence and exit 2."""

from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np
import pytest

import neurovpr as nv

nir = pytest.importorskip("nir")

from neurovpr.interop.nir import import_nir  # noqa: E402


def _lif(n: int) -> nir.LIF:
    return nir.LIF(tau=np.full(n, 0.01), r=np.ones(n), v_leak=np.zeros(n), v_threshold=np.ones(n), v_reset=np.zeros(n))


def _conv_graph(**metadata) -> nir.NIRGraph:
    conv = nir.Conv2d(input_shape=(4, 4), weight=np.ones((2, 1, 3, 3)), stride=1, padding=0, dilation=1, groups=1,
                      bias=np.zeros(2))  # fmt: skip
    nodes = {"in": nir.Input(input_type={"input": np.array([1, 4, 4])}), "c": conv, "n": _lif(8),
             "o": nir.Output(output_type={"output": np.array([8])})}  # fmt: skip
    return nir.NIRGraph(nodes=nodes, edges=[("in", "c"), ("c", "n"), ("n", "o")], type_check=False, metadata=metadata)


def _write(graph: nir.NIRGraph, path: Path) -> Path:
    nir.write(path, graph)
    return path


def _import_refused(path: Path, tmp_path: Path, cli_refused, pattern: str) -> None:
    with pytest.raises(nv.NeurovprError, match=pattern):
        import_nir(path)
    out = tmp_path / "out.h5"
    cli_refused(["import", str(path), "--out", str(out)], f"NIR file {str(path)!r}")
    assert not out.exists()


def test_conv2d_stride_0_is_refused(tmp_path: Path, cli_refused) -> None:
    path = _write(_conv_graph(), tmp_path / "conv.nir")
    assert "n" in import_nir(path).network.populations  # the file as written imports
    with h5py.File(path, "a") as f:
        f["node/nodes/c/stride"][...] = 0
    _import_refused(path, tmp_path, cli_refused, r"node 'c' \(Conv2d\) has stride \[0, 0\]; every stride must be >= 1")


@pytest.mark.parametrize(
    ("metadata", "pattern"),
    [
        ({"neurovpr_dt_ms": "fast"}, r"metadata 'neurovpr_dt_ms' is 'fast', expected a positive number of ms"),
        ({"neurovpr_seed": -3}, r"metadata 'neurovpr_seed' is -3, expected an integer >= 0"),
        ({"neurovpr_allow_refractory": 7}, r"metadata 'neurovpr_allow_refractory' is 7, expected 0 or 1"),
        ({"neurovpr_integration": "rk4"}, r"metadata 'neurovpr_integration' is 'rk4', expected 'exact' or 'euler'"),
        ({"neurovpr_outputs": np.arange(3)}, r"metadata 'neurovpr_outputs' is an array of shape \(3,\), expected text"),
    ],
)
def test_metadata_of_the_wrong_type_is_refused_by_name(metadata, pattern, tmp_path: Path, cli_refused) -> None:
    _import_refused(_write(_conv_graph(**metadata), tmp_path / "meta.nir"), tmp_path, cli_refused, pattern)


def test_a_negative_delay_is_named(tmp_path: Path, cli_refused) -> None:
    nodes = {"in": nir.Input(input_type={"input": np.array([4])}), "w": nir.Linear(weight=np.ones((4, 4))),
             "d": nir.Delay(delay=np.array([0.001, -0.002, 0.001, 0.001])), "n": _lif(4),
             "o": nir.Output(output_type={"output": np.array([4])})}  # fmt: skip
    graph = nir.NIRGraph(nodes=nodes, edges=[("in", "w"), ("w", "d"), ("d", "n"), ("n", "o")], type_check=False)
    path = _write(graph, tmp_path / "delay.nir")
    _import_refused(path, tmp_path, cli_refused, r"NIR node 'd' \(Delay\): delay\[1\] is -0.002 s; every delay must be")
