"""Fit reports, unsupported features as violations, nv.compile(hardware=...), ``neurovpr check``."""

from __future__ import annotations

import json

import numpy as np
import pytest
from hw_models import locsnet, modular_snn, small_net, sub_ms_net
from PIL import Image

import neurovpr as nv
from neurovpr.cli import main as cli
from neurovpr.errors import ValidationError
from neurovpr.hardware import check_network, hardware_target
from neurovpr.hardware.plots import plot_utilisation


@pytest.fixture
def neurovpr_main(monkeypatch):
    """The real ``neurovpr`` entry point with the check and energy subcommands registered."""
    commands = tuple(dict.fromkeys((*cli.COMMANDS, "check", "energy")))
    monkeypatch.setattr(cli, "COMMANDS", commands)
    return cli.main


def test_report_json_follows_the_contract():
    report = check_network(small_net(), "spinn5")
    out = report.as_dict()
    assert {"hardware", "fits", "chips", "cores", "populations", "violations"} <= set(out)
    assert out["hardware"] == "spinn5" and out["fits"] is True and out["cores"] == 4 and out["chips"] == 1
    by_name = {p["name"]: p for p in out["populations"]}
    assert {"name", "neurons", "cores"} <= set(by_name["a"])
    assert by_name["src"]["neurons"] == 60 and by_name["a"]["cores"] == 1
    assert by_name["a"]["max_utilisation"]["neurons"] == pytest.approx(50 / 256, abs=1e-6)
    json.dumps(out)  # JSON-serialisable


def test_unsupported_features_are_violations_not_exceptions():
    net = nv.Network("features")
    net.add_population("src", 300, nv.SpikeSourcePoisson(rate=1.0))
    net.add_population("cond", 100, nv.IF_cond_exp())
    net.add_population("cur", 300, nv.IF_curr_exp())
    net.connect("src", "cond", nv.AllToAllConnector(), nv.DiehlCookSTDP(weight=0.1))
    net.connect("src", "cur", nv.OneToOneConnector(), nv.StaticSynapse(weight=0.1, delay=100.0))
    kb = check_network(net, "kapoho-bay")
    limits = {v.limit: v for v in kb.partition.violations}
    assert set(limits) == {"neuron model", "plasticity rule", "delay"}
    assert "IF_cond_exp is not available on kapoho-bay" in limits["neuron model"].message
    assert limits["delay"].value == 100 and limits["delay"].maximum == 62 and limits["delay"].excess == 38
    sp = check_network(net, "spinn5")
    # 100 ms exceeds the 32 delay slots of a 256-neuron core: a delay-extension core is added.
    assert {v.limit for v in sp.partition.violations} == {"plasticity rule"}
    assert sum(c.kind == "delays" for c in sp.partition.cores) == 1


def test_every_violation_names_what_and_how_much():
    net = nv.Network("dense")
    net.add_population("src", 300, nv.SpikeSourcePoisson(rate=1.0))
    net.add_population("a", 700, nv.IF_curr_exp())
    net.add_population("b", 700, nv.IF_curr_exp())
    net.connect("src", "a", nv.AllToAllConnector(), nv.StaticSynapse(weight=np.linspace(0.1, 1.0, 300 * 700)))
    net.connect("b", "a", nv.AllToAllConnector(allow_self_connections=False), nv.StaticSynapse(weight=0.3))
    net.connect("a", "b", nv.OneToOneConnector(), nv.StaticSynapse(weight=0.3, delay=80.0))
    report = check_network(net, "kapoho-bay")
    assert {v.limit for v in report.partition.violations} == {"output axons per core", "delay"}
    for v in report.partition.violations:
        assert v.where and v.message.endswith(".") and v.value > v.maximum
        assert str(int(v.value)) in v.message and str(int(v.maximum)) in v.message


def test_table_lists_populations_and_violations():
    text = check_network(modular_snn(1), "kapoho-bay").table()
    assert "exc" in text and "neuron model" in text and "does NOT fit" in text


def test_hardware_target_and_nv_compile():
    target = hardware_target(small_net(), "kapoho-bay", dt=1.0, seed=3)
    assert target.name == "kapoho-bay" and target.dt == 1.0 and target.seed == 3
    assert target.partition is target.report.partition and target.report.fits
    with pytest.raises(ValidationError) as info:
        hardware_target(modular_snn(1), "kapoho-bay", dt=1.0, seed=0)
    msg = str(info.value)
    assert msg.startswith("Network 'modular_snn' does not fit kapoho-bay at dt=1 ms (3 limit(s) broken; first:")
    assert msg.count(". ") == 0 and msg.endswith(").")  # one sentence
    with pytest.raises(ValidationError, match="does not fit kapoho-bay"):
        nv.compile(modular_snn(1), backend="reference", hardware="kapoho-bay")
    with pytest.raises(ValidationError, match="Unknown hardware 'loihi3'; known hwspecs"):
        nv.compile(small_net(), backend="reference", hardware="loihi3")


def test_utilisation_plot(tmp_path):
    report = check_network(locsnet(n_places=300, input_hw=24, channels=(4, 8, 8)), "kapoho-bay")
    path = plot_utilisation(report, tmp_path / "util.png")
    with Image.open(path) as img:
        assert img.format == "PNG" and img.size[0] > 500 and img.size[1] > 300
        pixels = np.asarray(img.convert("RGB")).reshape(-1, 3)
        assert len(np.unique(pixels, axis=0)) > 10  # bars drawn, not a blank canvas
    plot_utilisation(check_network(small_net(), "spinn5"), tmp_path / "spinn.png")
    assert (tmp_path / "spinn.png").stat().st_size > 10_000


def test_cli_check_file_fits_and_json(tmp_path, capsys, neurovpr_main):
    path = tmp_path / "small.h5"
    nv.save(small_net(), path)
    assert neurovpr_main(["check", "--file", str(path), "--hw", "spinn5", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["fits"] is True and out["hardware"] == "spinn5" and out["cores"] == 4
    assert neurovpr_main(["check", "--file", str(path), "--hw", "kapoho-bay"]) == 0
    assert "fits" in capsys.readouterr().out


def test_cli_check_dt_splits_spinnaker_cores_below_1ms(tmp_path, capsys, neurovpr_main):
    """--dt 0.1 checks at that step: sPyNNaker's separate synapse cores appear (agreement: test_spinnaker_oracle)."""
    path = tmp_path / "sub_ms.h5"
    nv.save(sub_ms_net(), path)
    at = {}
    for dt in ("1.0", "0.1"):
        assert neurovpr_main(["check", "--file", str(path), "--hw", "spinn5", "--dt", dt, "--json"]) == 0
        at[dt] = json.loads(capsys.readouterr().out)
    kinds = {p["kind"] for p in at["0.1"]["populations"]}
    assert "synapses" in kinds and "synapses" not in {p["kind"] for p in at["1.0"]["populations"]}
    assert at["0.1"]["cores"] > at["1.0"]["cores"]
    assert at["0.1"]["cores"] == len(check_network(sub_ms_net(), "spinn5", dt=0.1).partition.cores)
    for row in at["0.1"]["populations"]:
        if row["kind"] == "synapses":
            assert row["neurons"] == 0
    with pytest.raises(ValidationError, match="time step dt must be a positive number of ms, got -1"):
        check_network(sub_ms_net(), "spinn5", dt=-1.0)


def test_cli_check_run_dir_does_not_fit(tmp_path, capsys, neurovpr_main):
    run = tmp_path / "run"
    run.mkdir()
    nv.save(modular_snn(1), run / "network.h5")
    assert neurovpr_main(["check", "--run", str(run), "--hw", "kapoho-bay", "--json"]) == 1
    out = json.loads(capsys.readouterr().out)
    assert out["fits"] is False and out["violations"] and (run / "utilisation_kapoho-bay.png").is_file()


def test_cli_check_run_uses_the_time_step_the_run_records(tmp_path, capsys, neurovpr_main):
    """Without --dt, ``check --run`` checks at the step run.json records (``dt_ms``, written by every model)."""
    run = tmp_path / "run"
    run.mkdir()
    nv.save(sub_ms_net(), run / "network.h5")
    cores = {dt: len(check_network(sub_ms_net(), "spinn5", dt=dt).partition.cores) for dt in (0.1, 1.0)}
    assert cores[0.1] > cores[1.0]  # separate synapse cores below 1 ms

    def check(*extra: str) -> dict:
        assert neurovpr_main(["check", "--run", str(run), "--hw", "spinn5", "--json", *extra]) == 0
        return json.loads(capsys.readouterr().out)

    (run / "run.json").write_text(json.dumps({"model": "mbsnn", "dt_ms": 0.1}), encoding="utf-8")
    out = check()
    assert (out["dt_ms"], out["cores"], out["dt_source"]) == (0.1, cores[0.1], f"{run / 'run.json'} dt_ms")
    out = check("--dt", "1.0")
    assert (out["dt_ms"], out["cores"], out["dt_source"]) == (1.0, cores[1.0], "--dt")
    assert neurovpr_main(["check", "--run", str(run), "--hw", "spinn5"]) == 0
    table = capsys.readouterr().out
    assert "network 'sub_ms', time step 0.1 ms" in table and f"time step 0.1 ms from {run / 'run.json'} dt_ms" in table

    (run / "run.json").write_text(json.dumps({"model": "other"}), encoding="utf-8")
    out = check()
    assert (out["dt_ms"], out["cores"], out["dt_source"]) == (1.0, cores[1.0], "spinn5 [timing].time_step_ms")
    (run / "run.json").write_text(json.dumps({"model": "mbsnn", "dt_ms": "fast"}), encoding="utf-8")
    assert neurovpr_main(["check", "--run", str(run), "--hw", "spinn5"]) == 2
    err = capsys.readouterr().err
    assert "time step dt_ms must be a positive number of ms, got 'fast'." in err and err.count("\n") == 1


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--file", "{tmp}/absent.h5", "--hw", "spinn5"], "Network file '{tmp}/absent.h5' does not exist."),
        (["--run", "{tmp}", "--hw", "spinn5"], "Run directory '{tmp}' has no network.h5."),
        (["--run", "{tmp}/nope", "--hw", "spinn5"], "Run directory '{tmp}/nope' does not exist."),
        (["--file", "{tmp}/graph.nir", "--hw", "spinn5"], "Network file '{tmp}/graph.nir' does not exist."),
        (["--file", "{tmp}/x.h5", "--hw", "truenorth"], "Unknown hardware 'truenorth'; known hwspecs: kapoho-bay"),
    ],
)
def test_cli_check_bad_input_exits_2(tmp_path, capsys, neurovpr_main, args, message):
    args = [a.format(tmp=tmp_path) for a in args]
    assert neurovpr_main(["check", *args]) == 2
    err = capsys.readouterr().err
    assert message.format(tmp=tmp_path) in err and err.count("\n") == 1


def test_cli_check_corrupt_network_file_exits_2(tmp_path, capsys, neurovpr_main):
    path = tmp_path / "bad.h5"
    path.write_bytes(b"not an hdf5 file" * 10)
    assert neurovpr_main(["check", "--file", str(path), "--hw", "spinn5"]) == 2
    assert "bad.h5" in capsys.readouterr().err


def test_check_respects_connector_seed():
    """The same seed gives the same partition; the fit is computed on the expanded connections."""
    net = small_net()
    a = check_network(net, "kapoho-bay", seed=1).as_dict()
    b = check_network(net, "kapoho-bay", seed=1).as_dict()
    assert a == b
    assert np.isfinite(a["cores"])
