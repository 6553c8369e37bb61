"""``neurovpr check --hw xylo`` / ``--hw speck``: the verdict, the named limit, exit codes; energy without published figures."""

from __future__ import annotations

import json

import pytest
from hw_models import locsnet
from synsense_oracles import xylo_chain

import neurovpr as nv
from neurovpr.cli import main as cli
from neurovpr.hardware import estimate_energy, load_hwspec


@pytest.fixture
def neurovpr_main(monkeypatch):
    """The real ``neurovpr`` entry point with the check subcommand registered."""
    monkeypatch.setattr(cli, "COMMANDS", tuple(dict.fromkeys((*cli.COMMANDS, "check", "energy"))))
    return cli.main


@pytest.mark.parametrize("name,partitioner", [("xylo", "xylo"), ("speck", "speck")])
def test_synsense_hwspecs_load(name, partitioner):
    spec = load_hwspec(name)
    assert spec.partitioner == partitioner and spec.chip.n_chips == 1
    assert spec.energy.synaptic_op_pJ is None  # not published: left out, never invented


def test_cli_check_xylo_fits_and_refuses_naming_the_limit(tmp_path, capsys, neurovpr_main):
    fits, too_big = tmp_path / "fits.h5", tmp_path / "too_big.h5"
    nv.save(xylo_chain(16, [100], 8), fits)
    nv.save(xylo_chain(17, [100], 8), too_big)
    assert neurovpr_main(["check", "--file", str(fits), "--hw", "xylo", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["fits"] is True and [p["name"] for p in out["populations"]] == ["in", "h0", "out"]
    assert neurovpr_main(["check", "--file", str(too_big), "--hw", "xylo"]) == 1
    text = capsys.readouterr().out
    assert "does NOT fit" in text and "input channels: Network" in text and "17 input channels" in text


def test_cli_check_speck_fits_and_refuses_naming_the_limit(tmp_path, capsys, neurovpr_main):
    small, paper = tmp_path / "small.h5", tmp_path / "paper.h5"
    nv.save(locsnet(n_places=16), small)
    nv.save(locsnet(), paper)
    assert neurovpr_main(["check", "--file", str(small), "--hw", "speck", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["fits"] is True and out["cores"] == 4
    assert neurovpr_main(["check", "--file", str(paper), "--hw", "speck", "--json"]) == 1
    out = json.loads(capsys.readouterr().out)
    (v,) = out["violations"]
    assert v["limit"] == "kernel memory" and v["where"] == "places" and v["maximum"] == 65536


def test_energy_leaves_unpublished_figures_out():
    activity = {"steps": 100, "dt_ms": 1.0, "neuron_updates": 1000, "spikes": 50, "synaptic_events": 400}
    xylo = estimate_energy(activity, "xylo")
    assert xylo.joules_per_inference is None and xylo.breakdown == {}  # no total rather than 0 J
    assert "energy not estimated" in xylo.table()
    assert any("synaptic ops" in s for s in xylo.not_estimated) and any("static" in s for s in xylo.not_estimated)
    speck = estimate_energy(activity, "speck")
    assert speck.breakdown == {"static": pytest.approx(0.00042 * 0.1)}
