"""`neurovpr export/import` and `check`/`energy` on a NIR file, through the real entry point."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import neurovpr as nv
from neurovpr.cli import main as cli

pytest.importorskip("nir")


@pytest.fixture
def neurovpr_main(monkeypatch):
    """The ``neurovpr`` entry point with the subcommands this feature adds registered."""
    monkeypatch.setattr(cli, "COMMANDS", tuple(dict.fromkeys((*cli.COMMANDS, "check", "energy", "export", "import"))))
    return cli.main


def _net() -> nv.Network:
    rng = np.random.default_rng(0)
    net = nv.Network("small")
    net.add_population("pixels", 64, nv.SpikeSourcePoisson(rate=0.0))
    net.add_population("feat", 36, nv.IF_curr_exp(tau_refrac=0.0, cm=0.2))
    net.add_population("places", 5, nv.IF_curr_exp(tau_refrac=0.0, cm=0.2))
    conv = nv.ConvolutionConnector(input_shape=(1, 8, 8), kernel_shape=(3, 3), out_channels=1)
    net.connect("pixels", "feat", conv, nv.StaticSynapse(weight=rng.uniform(0, 1, conv.weight_shape)))
    net.connect("feat", "places", nv.AllToAllConnector(), nv.StaticSynapse(weight=rng.uniform(0, 1, (36, 5))))
    return net


def test_export_then_import_on_the_command_line(tmp_path: Path, capsys, neurovpr_main) -> None:
    net = _net()
    run = tmp_path / "run"
    run.mkdir()
    nv.save(net, run / "network.h5")
    assert neurovpr_main(["export", "--run", str(run), "--format", "nir", "--out", str(tmp_path / "a.nir"), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["nodes"]["feat"] == "CubaLIF" and out["nodes"]["pixels->feat"] == "Conv2d" and out["notes"]
    assert neurovpr_main(["export", "--file", str(run / "network.h5"), "--format", "nir", "--out", str(tmp_path / "b.nir"),
                          "--integration", "euler", "--dt", "1.0"]) == 0  # fmt: skip
    assert "wrote" in capsys.readouterr().out
    assert neurovpr_main(["import", str(tmp_path / "a.nir"), "--out", str(tmp_path / "back.h5"), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["restored"] and out["outputs"] == {"output": "places"}
    assert nv.load(tmp_path / "back.h5") == net
    assert neurovpr_main(["import", str(tmp_path / "b.nir"), "--out", str(tmp_path / "plain.h5"), "--no-metadata"]) == 0
    text = capsys.readouterr().out
    assert "output 'output' <- population 'places'" in text
    plain = nv.load(tmp_path / "plain.h5")
    assert plain.projections["feat->places"].synapse.weight.tobytes() == net.projections["feat->places"].synapse.weight.tobytes()


def test_bad_exports_and_imports_exit_2_with_one_sentence(tmp_path: Path, capsys, neurovpr_main) -> None:
    net = nv.Network("cond")
    net.add_population("a", 2, nv.SpikeSourcePoisson(rate=1.0))
    net.add_population("b", 2, nv.IF_cond_exp())
    nv.save(net, tmp_path / "cond.h5")
    args = ["export", "--file", str(tmp_path / "cond.h5"), "--format", "nir", "--out", str(tmp_path / "c.nir")]
    assert neurovpr_main(args) == 2
    err = capsys.readouterr().err
    assert "Population 'b' (IF_cond_exp) has conductance-based synapses" in err and err.count("\n") == 1
    assert not (tmp_path / "c.nir").exists()
    (tmp_path / "junk.nir").write_bytes(b"\x89HDF junk")
    assert neurovpr_main(["import", str(tmp_path / "junk.nir"), "--out", str(tmp_path / "j.h5")]) == 2
    err = capsys.readouterr().err
    assert "is not an HDF5 file" in err and err.count("\n") == 1 and not (tmp_path / "j.h5").exists()


def test_check_and_energy_take_a_nir_file(tmp_path: Path, capsys, neurovpr_main) -> None:
    from neurovpr.interop.nir import export_nir

    export_nir(_net(), tmp_path / "g.nir", embed_network=False)
    assert neurovpr_main(["check", "--file", str(tmp_path / "g.nir"), "--hw", "kapoho-bay", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["fits"] is True and {p["name"] for p in out["populations"]} >= {"feat", "places"}
    assert neurovpr_main(["energy", "--file", str(tmp_path / "g.nir"), "--hw", "loihi2", "--rate", "50", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["joules_per_inference"] > 0


def test_probe_activity_counts_a_run() -> None:
    from neurovpr.interop.activity import probe_activity

    activity = probe_activity(_net(), rate_hz=100.0, duration_ms=50.0, dt=1.0, seed=1)
    assert activity["steps"] == 50 and activity["population_spikes"]["pixels"] > 0
    assert activity["synaptic_events"] > 0 and activity["inferences"] == 1
    with pytest.raises(nv.ValidationError, match=r"rate 2000 Hz exceeds one spike per 1 ms step"):
        probe_activity(_net(), rate_hz=2000.0, dt=1.0)
