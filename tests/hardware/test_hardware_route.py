"""The one route to hardware: partition once (the compile's dt and seed), arithmetic from [formats], architectures by entry point.

A hwspec is found by its contents, not its name: a copy of a shipped hwspec under another
name checks and emulates exactly as the original does, and an architecture declared by
another package (``toy_architecture.py``) goes through the same route.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest
from hw_models import small_net

import neurovpr as nv
from neurovpr.errors import UnsupportedFeatureError, ValidationError
from neurovpr.hardware import check_network, get_architecture, hardware_target, known_architectures, load_hwspec
from neurovpr.hardware.hwspec import _hwspec_dir

pytest.importorskip("neurovpr.backends.reference.kernels_fixed")

HERE = Path(__file__).parent
SHIPPED = ("kapoho-bay", "loihi2", "spinn5")


def _copy(tmp_path: Path, name: str, new_name: str, **replace: str) -> Path:
    """The shipped hwspec ``name`` saved as ``new_name.toml`` with ``[hardware].name = new_name``."""
    text = (_hwspec_dir() / f"{name}.toml").read_text(encoding="utf-8")
    text = text.replace(f'name = "{name}"', f'name = "{new_name}"', 1)
    for old, new in replace.items():
        assert old in text, old
        text = text.replace(old, new)
    path = tmp_path / f"{new_name}.toml"
    path.write_text(text, encoding="utf-8")
    return path


def _emulated_net(seed: int = 11) -> nv.Network:
    """Spike arrays into two current-based layers (positive weights: every shipped arithmetic runs it)."""
    rng = np.random.default_rng(seed)
    net = nv.Network("route")
    trains = [np.sort(rng.choice(np.arange(1, 190), 30, replace=False)).astype(float) for _ in range(12)]
    net.add_population("src", 12, nv.SpikeSourceArray.from_lists(trains))
    net.add_population("hid", 9, nv.IF_curr_exp(tau_m=20.0, tau_syn_E=4.0, tau_refrac=2.0))
    net.add_population("out", 3, nv.IF_curr_exp(tau_m=10.0, tau_syn_E=3.0, tau_refrac=1.0))
    net.connect("src", "hid", nv.AllToAllConnector(), nv.StaticSynapse(weight=rng.uniform(0.2, 1.2, (12, 9))))
    net.connect("hid", "out", nv.FixedProbabilityConnector(p_connect=0.6), nv.StaticSynapse(weight=1.5))
    return net


def _run(net: nv.Network, hardware: str | Path) -> nv.Simulation:
    sim = nv.compile(net, backend="reference", dt=1.0, seed=5, hardware=str(hardware))
    sim.record("out", "v")
    sim.run(200.0)
    return sim


def _partition_rows(partition) -> list[tuple]:
    return [(c.population, c.lo, c.hi, c.kind, c.chip, c.location, c.usage, c.limits) for c in partition.cores]


@pytest.mark.parametrize("name", SHIPPED)
def test_a_renamed_copy_checks_and_emulates_as_the_original(tmp_path, name):
    """Same partition, verdict and notes; same integers, spikes and membrane in the emulated arithmetic."""
    path = _copy(tmp_path, name, "my-board")
    original, copy = load_hwspec(name), load_hwspec(path)
    assert copy.name == "my-board" and copy.formats == original.formats and copy.rules == original.rules
    for net in (small_net(), _emulated_net()):
        a, b = check_network(net, name, seed=2), check_network(net, path, seed=2)
        assert a.fits == b.fits and a.partition.chips == b.partition.chips
        assert _partition_rows(a.partition) == _partition_rows(b.partition)
        assert [v.message.replace(name, "my-board") for v in a.partition.violations] == [
            v.message for v in b.partition.violations
        ]
    mine, theirs = _run(_emulated_net(), path), _run(_emulated_net(), name)
    assert mine.spike_counts("hid").sum() > 0 and mine.spike_counts("out").sum() > 0
    for pop in ("hid", "out"):
        for got, want in zip(mine.spike_trains(pop), theirs.spike_trains(pop), strict=True):
            np.testing.assert_array_equal(got, want)
    np.testing.assert_array_equal(mine.trace("out", "v")[1], theirs.trace("out", "v")[1])
    np.testing.assert_array_equal(mine.quantised.params, theirs.quantised.params)
    np.testing.assert_array_equal(mine.quantised.s_val, theirs.quantised.s_val)


def test_compile_partitions_once_with_its_dt_and_seed():
    """The simulation's target holds the partition made at the compile's dt and seed; the emulation's core
    blocks are its slices."""
    net = nv.Network("split")
    net.add_population("src", 4, nv.SpikeSourceArray.from_lists([[5.0], [6.0], [7.0], [8.0]]))
    net.add_population("big", 1500, nv.IF_curr_exp(tau_syn_E=3.0))
    net.connect("src", "big", nv.FixedProbabilityConnector(p_connect=0.5), nv.StaticSynapse(weight=0.8))
    sim = nv.compile(net, backend="reference", dt=1.0, seed=9, hardware="kapoho-bay")
    target = sim.hardware
    assert target is not None and target.name == "kapoho-bay" and target.dt == 1.0 and target.seed == 9
    again = check_network(net, "kapoho-bay", seed=9, dt=1.0)
    assert _partition_rows(target.partition) == _partition_rows(again.partition)
    neurons = [(c.lo, c.hi) for c in target.partition.cores if c.population == "big"]
    assert len(neurons) == 2
    assert [(b["lo"], b["hi"]) for b in sim.quantised.blocks] == neurons
    assert nv.compile(net, backend="reference", dt=0.5, seed=9).hardware is None


def test_the_verdict_uses_the_callers_dt():
    """A delay that fits at the chip's 1 ms step breaks the delay limit at the caller's 0.1 ms step."""
    net = nv.Network("delays")
    net.add_population("src", 2, nv.SpikeSourcePoisson(rate=5.0))
    net.add_population("n", 2, nv.IF_curr_exp())
    net.connect("src", "n", nv.OneToOneConnector(), nv.StaticSynapse(weight=0.5, delay=20.0))
    assert hardware_target(net, "kapoho-bay", dt=1.0, seed=0).report.fits
    with pytest.raises(ValidationError, match=r"does not fit kapoho-bay at dt=0\.1 ms .*delay of 200 steps"):
        hardware_target(net, "kapoho-bay", dt=0.1, seed=0)
    with pytest.raises(ValidationError, match=r"does not fit kapoho-bay at dt=0\.1 ms"):
        nv.compile(net, backend="nengo-loihi", dt=0.1, seed=0, hardware="kapoho-bay")


def test_arithmetic_comes_from_formats_not_the_name(tmp_path):
    """A loihi2 copy that declares the loihi1 arithmetic computes as kapoho-bay does; without one it is checked
    but not emulated; the backend names what it computes in."""
    as_loihi1 = _copy(tmp_path, "loihi2", "loihi2-as-loihi1", **{'arithmetic = "loihi2"': 'arithmetic = "loihi1"'})
    net = _emulated_net()
    kapoho, mine = _run(net, "kapoho-bay"), _run(net, as_loihi1)
    assert mine.quantised.variant == "loihi1"
    for got, want in zip(mine.spike_trains("out"), kapoho.spike_trains("out"), strict=True):
        np.testing.assert_array_equal(got, want)
    bare = _copy(tmp_path, "loihi2", "no-arithmetic", **{'arithmetic = "loihi2"\n': ""})
    assert load_hwspec(bare).formats.arithmetic is None and check_network(net, bare).fits
    with pytest.raises(UnsupportedFeatureError, match=r"cannot emulate hardware 'no-arithmetic': its hwspec declares "
                                                       r"an arithmetic \(\[formats\]\.arithmetic is not set\)"):  # fmt: skip
        nv.compile(net, backend="reference", dt=1.0, seed=0, hardware=str(bare))
    other = _copy(tmp_path, "loihi2", "future", **{'arithmetic = "loihi2"': 'arithmetic = "loihi3"'})
    with pytest.raises(UnsupportedFeatureError, match=r"declares the loihi3 arithmetic, the backend computes in: "
                                                       r"loihi1, loihi2, speck, spinnaker, xylo"):  # fmt: skip
        nv.compile(net, backend="reference", dt=1.0, seed=0, hardware=str(other))


def test_partitioners_are_registered_by_architecture(tmp_path):
    assert {"loihi", "spinnaker"} <= set(known_architectures())
    assert get_architecture("loihi").table == "synapse_encoding"
    with pytest.raises(ValidationError, match=r"\[hardware\]\.partitioner: Unknown architecture 'nxsdk'; known "):
        load_hwspec(_copy(tmp_path, "kapoho-bay", "nx", **{'partitioner = "loihi"': 'partitioner = "nxsdk"'}))


@pytest.fixture
def toy_site(tmp_path, monkeypatch) -> Path:
    """An out-of-tree package declaring the ``toychip`` architecture, on ``sys.path`` for this test."""
    site = tmp_path / "site"
    site.mkdir()
    shutil.copy(HERE / "toy_architecture.py", site / "toy_architecture.py")
    info = site / "toy_architecture-0.1.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: toy-architecture\nVersion: 0.1\n", encoding="utf-8")
    (info / "entry_points.txt").write_text("[neurovpr.architectures]\ntoychip = toy_architecture:TOY\n", encoding="utf-8")
    monkeypatch.syspath_prepend(str(site))
    return site


def test_an_architecture_from_another_package_goes_through_the_same_route(tmp_path, toy_site):
    """One hwspec and one registered partitioner: checked with its own table, emulated in the arithmetic its
    [formats] names, on the core blocks its partitioner made."""
    text = (_hwspec_dir() / "kapoho-bay.toml").read_text(encoding="utf-8")
    head, _, rest = text.partition("[synapse_encoding]")
    rest = rest[rest.index("\n[formats]") :]
    path = tmp_path / "toy.toml"
    path.write_text(
        head.replace('name = "kapoho-bay"', 'name = "toy"').replace('partitioner = "loihi"', 'partitioner = "toychip"')
        + "[toy]\nmax_cores_per_population = 1\n"
        + rest,
        encoding="utf-8",
    )
    assert "toychip" in known_architectures()
    spec = load_hwspec(path)
    assert type(spec.rules).__name__ == "ToyRules" and spec.rules.max_cores_per_population == 1
    net = _emulated_net()
    report = check_network(net, path)
    assert report.fits and [(c.population, c.lo, c.hi) for c in report.partition.cores] == [("hid", 0, 9), ("out", 0, 3)]
    toy, kapoho = _run(net, path), _run(net, "kapoho-bay")
    for got, want in zip(toy.spike_trains("out"), kapoho.spike_trains("out"), strict=True):
        np.testing.assert_array_equal(got, want)
    big = nv.Network("big")
    big.add_population("n", 2000, nv.IF_curr_exp())
    broken = check_network(big, path).partition.violations
    assert [v.limit for v in broken] == ["cores per population"]
    with pytest.raises(ValidationError, match=r"missing table \[toy\] \(required by the toychip partitioner\)"):
        bad = tmp_path / "bad.toml"
        bad.write_text(path.read_text(encoding="utf-8").replace("[toy]\nmax_cores_per_population = 1\n", ""))
        load_hwspec(bad)
