"""Networks with too many populations and model options past the memory limit are refused before any work."""

from __future__ import annotations

from pathlib import Path

import pytest

import neurovpr as nv
from neurovpr.hardware import check_network
from neurovpr.resources import DEFAULT_MAX_NODES, ResourceLimitError


def _many(n: int) -> nv.Network:
    net = nv.Network("many")
    net.add_population("src", 1, nv.SpikeSourcePoisson(rate=20.0))
    for i in range(n):
        net.add_population(f"p{i}", 1, nv.IF_curr_exp())
    return net


@pytest.fixture
def many_file(tmp_path: Path) -> Path:
    path = tmp_path / "many.h5"
    nv.save(_many(60), path)
    return path


@pytest.mark.parametrize("command", ["energy", "check"])
def test_a_file_with_too_many_populations_is_refused_before_decoding(command, many_file, monkeypatch, cli_refused) -> None:
    monkeypatch.setenv("NEUROVPR_MAX_NODES", "50")
    cli_refused(
        [command, "--file", str(many_file), "--hw", "spinn5"],
        f"Network file {str(many_file)!r} holds 61 populations and 0 projections (61 in all); "
        "the limit is 50 (NEUROVPR_MAX_NODES).",
    )
    monkeypatch.setenv("NEUROVPR_MAX_NODES", "100")
    assert len(nv.load(many_file).populations) == 61


def test_compile_and_check_refuse_a_network_with_too_many_populations(monkeypatch) -> None:
    net = _many(60)
    monkeypatch.setenv("NEUROVPR_MAX_NODES", "50")
    with pytest.raises(ResourceLimitError, match=r"compile: network 'many' holds 61 populations .* the limit is 50"):
        nv.compile(net, backend="reference")
    with pytest.raises(ResourceLimitError, match=r"check: network 'many' holds 61 populations"):
        check_network(net, "spinn5")
    monkeypatch.setenv("NEUROVPR_MAX_NODES", "lots")
    with pytest.raises(nv.ValidationError, match=r"NEUROVPR_MAX_NODES='lots' must be a positive whole number"):
        nv.compile(net, backend="reference")


def test_the_default_node_limit_names_its_variable() -> None:
    with pytest.raises(ResourceLimitError, match=rf"the limit is {DEFAULT_MAX_NODES} \(the default; set NEUROVPR_MAX_NODES"):
        nv.compile(_many(DEFAULT_MAX_NODES), backend="reference")
