"""Energy per inference from a run's activity, the activity file, CPU energy, ``neurovpr energy``."""

from __future__ import annotations

import json

import pytest
from hw_models import small_net

import neurovpr as nv
from neurovpr.cli import main as cli
from neurovpr.errors import ValidationError
from neurovpr.hardware import (
    CpuEnergyMeter,
    check_network,
    estimate_energy,
    load_hwspec,
    rapl_status,
    read_activity,
    write_activity,
)

STATS = {"steps": 7000, "neuron_updates": 700000, "spikes": 5000, "synaptic_events": 40000, "plastic_updates": 0,
         "weight_reads": 3}


@pytest.fixture
def neurovpr_main(monkeypatch):
    monkeypatch.setattr(cli, "COMMANDS", tuple(dict.fromkeys((*cli.COMMANDS, "check", "energy"))))
    return cli.main


def test_activity_file_round_trip(tmp_path):
    path = write_activity(tmp_path / "run", STATS, 10, dt_ms=0.5, population_spikes={"a": 3000, "b": 2000})
    assert path.name == "activity.json" and not list(path.parent.glob("*.tmp"))
    act = read_activity(tmp_path / "run")
    assert act["inferences"] == 10 and act["dt_ms"] == 0.5
    assert act["steps"] == 700 and act["synaptic_events"] == 4000 and act["plastic_updates"] == 0
    assert act["population_spikes"] == {"a": 300, "b": 200}
    assert "weight_reads" not in json.loads(path.read_text())


def test_activity_errors_name_the_field(tmp_path):
    with pytest.raises(ValidationError, match="statistics lack the count 'synaptic_events'"):
        write_activity(tmp_path, {"steps": 1, "neuron_updates": 1, "spikes": 1}, 1)
    with pytest.raises(ValidationError, match="inferences must be an integer >= 1, got 0"):
        write_activity(tmp_path, STATS, 0)
    with pytest.raises(ValidationError, match=r"statistics\['spikes'\] must be a finite number >= 0, got -1"):
        write_activity(tmp_path, {**STATS, "spikes": -1}, 1)
    (tmp_path / "activity.json").write_text('{"version": 1, "inferences": 2, "steps": 1}')
    with pytest.raises(ValidationError, match="lacks the count 'neuron_updates'"):
        read_activity(tmp_path)
    (tmp_path / "activity.json").write_text("{not json")
    with pytest.raises(ValidationError, match="is not valid JSON"):
        read_activity(tmp_path)


def test_energy_uses_only_hwspec_figures(tmp_path):
    write_activity(tmp_path, STATS, 10, dt_ms=0.5)
    act = read_activity(tmp_path)
    net = small_net()
    spec = load_hwspec("kapoho-bay")
    e = spec.energy
    rep = estimate_energy(act, spec, network=net)
    hw_steps = 700 * 0.5 / spec.timing.time_step_ms  # 350 steps of 1 ms
    updates = 70000 * 0.5
    expected = {
        "synaptic_ops": 4000 * e.synaptic_op_pJ * 1e-12,
        "synaptic_updates": 0.0,
        "neuron_updates": ((updates - 500) * e.neuron_update_pJ + 500 * e.neuron_active_update_pJ) * 1e-12,
        "spikes_within_chip": 500 * e.spike_within_chip_pJ * 1e-12,
        "static": e.static_power_per_chip_W * 1 * hw_steps * e.wall_time_per_step_s,
    }
    assert rep.breakdown == pytest.approx(expected)
    assert rep.joules_per_inference == pytest.approx(sum(expected.values()))
    assert rep.chips == 1 and rep.cores == 3 and rep.seconds_per_inference == pytest.approx(0.35)
    out = rep.as_dict()
    assert {"hardware", "joules_per_inference", "breakdown"} <= set(out) and out["hardware"] == "kapoho-bay"

    sp = load_hwspec("spinn5")
    rep = estimate_energy(act, sp, network=net)
    assert rep.breakdown["static"] == pytest.approx(sp.energy.board_static_power_W * 0.35)
    assert rep.breakdown["active_cores"] == pytest.approx(sp.energy.active_core_power_W * 4 * 0.35)
    assert rep.breakdown["synaptic_ops"] == pytest.approx(4000 * sp.energy.synaptic_op_pJ * 1e-12)


def test_spikes_between_chips_estimated_from_the_partition():
    """Two populations on different Loihi chips: every spike of the first crosses once."""
    net = nv.Network("two_chips")
    net.add_population("a", 128 * 1024, nv.IF_curr_exp())
    net.add_population("b", 10, nv.IF_curr_exp())
    net.connect("a", "b", nv.FromListConnector(conn_list=[[0, 0], [131071, 9]]), nv.StaticSynapse(weight=0.1))
    part = check_network(net, "kapoho-bay").partition
    assert part.chips == 2
    act = {"steps": 10, "neuron_updates": 10, "spikes": 100, "synaptic_events": 0,
           "population_spikes": {"a": 100, "b": 0}, "dt_ms": 1.0}
    rep = estimate_energy(act, "kapoho-bay", network=net, partition=part)
    # a's 128 cores fill chip 0; b is on chip 1: all 100 spikes of a cross, and Loihi has no figure for it
    assert any("100 spikes between chips" in s for s in rep.not_estimated)
    assert rep.breakdown["spikes_within_chip"] == 0.0
    rep = estimate_energy({**act, "spikes_between_chips": 40}, "spinn5")
    assert rep.breakdown["spikes_between_chips"] == pytest.approx(40 * 2000e-12)


def test_rapl_status_and_meter_on_a_powercap_tree(tmp_path):
    ok, reason = rapl_status(tmp_path / "absent")
    assert not ok and "no RAPL energy counters" in reason
    with CpuEnergyMeter(tmp_path / "absent") as meter:
        pass
    assert meter.joules is None and not meter.available and meter.seconds >= 0
    # The kernel's powercap layout: one intel-rapl:N folder per package with energy_uj.
    dom = tmp_path / "intel-rapl:0"
    dom.mkdir()
    (dom / "energy_uj").write_text("262000000\n")
    (dom / "max_energy_range_uj").write_text("262143328850\n")
    sub = tmp_path / "intel-rapl:0:0"  # a sub-domain (core), must not be counted twice
    sub.mkdir()
    (sub / "energy_uj").write_text("5\n")
    assert rapl_status(tmp_path) == (True, "available")
    with CpuEnergyMeter(tmp_path) as meter:
        (dom / "energy_uj").write_text("263500000\n")
    assert meter.joules == pytest.approx(1.5)
    with CpuEnergyMeter(tmp_path) as meter:  # counter wrapped around
        (dom / "energy_uj").write_text("1000000\n")
    assert meter.joules == pytest.approx((262143328850 - 263500000 + 1000000) * 1e-6)


def test_this_machine_reports_cpu_energy_or_says_why_not():
    ok, reason = rapl_status()
    assert ok or reason.startswith("no RAPL") or "not readable" in reason
    rep = estimate_energy({"steps": 1, "neuron_updates": 1, "spikes": 0, "synaptic_events": 0}, "loihi2")
    assert rep.cpu["joules_per_inference"] is None and rep.cpu["reason"]


def test_cli_energy(tmp_path, capsys, neurovpr_main):
    run = tmp_path / "run"
    write_activity(run, STATS, 10, dt_ms=0.5, cpu_seconds=20.0, cpu_joules=300.0)
    nv.save(small_net(), run / "network.h5")
    assert neurovpr_main(["energy", "--run", str(run), "--hw", "kapoho-bay", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["hardware"] == "kapoho-bay" and out["cores"] == 3 and out["joules_per_inference"] > 0
    assert set(out["breakdown"]) >= {"synaptic_ops", "neuron_updates", "static"}
    assert out["cpu"]["joules_per_inference"] == pytest.approx(30.0)
    assert out["synaptic_operations"]["Effective_ACs"] == STATS["synaptic_events"] / 10
    assert neurovpr_main(["energy", "--run", str(run), "--hw", "spinn5"]) == 0
    text = capsys.readouterr().out
    assert "J per inference" in text and "static" in text and "measured CPU: 30 J" in text
    assert f"{STATS['synaptic_events'] / 10:g} accumulates (NeuroBench Effective_ACs" in text
    assert neurovpr_main(["energy", "--run", str(tmp_path), "--hw", "spinn5"]) == 2
    assert "has no activity.json" in capsys.readouterr().err


def test_cli_energy_partitions_at_the_runs_time_step(tmp_path, capsys, neurovpr_main):
    """``energy --run`` counts the cores of the partition ``check --run`` makes: the step run.json records, --seed."""
    from hw_models import sub_ms_net

    from neurovpr.hardware import check_network

    run = tmp_path / "run"
    write_activity(run, STATS, 10, dt_ms=0.1)
    nv.save(sub_ms_net(), run / "network.h5")
    (run / "run.json").write_text(json.dumps({"model": "mbsnn", "dt_ms": 0.1}), encoding="utf-8")
    cores = {dt: len(check_network(sub_ms_net(), "spinn5", dt=dt, seed=3).partition.cores) for dt in (0.1, 1.0)}
    assert cores[0.1] > cores[1.0]
    for command in ("energy", "check"):
        assert neurovpr_main([command, "--run", str(run), "--hw", "spinn5", "--seed", "3", "--json"]) == 0
        assert json.loads(capsys.readouterr().out)["cores"] == cores[0.1]
