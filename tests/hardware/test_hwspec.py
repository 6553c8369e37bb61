"""Loading and validating hwspecs: the shipped files, and bad files named precisely."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from neurovpr.errors import ValidationError
from neurovpr.hardware import known_hwspecs, load_hwspec

HWSPEC_DIR = Path(__file__).resolve().parents[2] / "hwspecs"


def test_known_hwspecs_are_the_three_targets():
    assert {"spinn5", "kapoho-bay", "loihi2"} <= set(known_hwspecs())


@pytest.mark.parametrize("name", ["spinn5", "kapoho-bay", "loihi2"])
def test_shipped_hwspecs_load(name):
    spec = load_hwspec(name)
    assert spec.name == name
    assert spec.partitioner in ("loihi", "spinnaker")
    assert spec.timing.time_step_ms == 1.0
    assert spec.energy.synaptic_op_pJ > 0 and spec.energy.static_power_per_chip_W > 0
    with pytest.raises(AttributeError):
        spec.hardware.name = "other"  # frozen


def test_published_limits():
    kb, l2, sp = load_hwspec("kapoho-bay"), load_hwspec("loihi2"), load_hwspec("spinn5")
    assert (kb.chip.n_chips, kb.chip.cores_per_chip, kb.core.max_neurons) == (2, 128, 1024)
    assert (kb.core.max_input_axons, kb.core.max_output_axons, kb.core.synapse_memory_bits) == (4096, 4096, 16384 * 64)
    assert (l2.chip.n_chips, l2.core.max_neurons) == (1, 8192)
    assert (sp.chip.n_chips, sp.chip.cores_per_chip, sp.core.max_neurons) == (48, 18, 256)
    assert sp.core.max_input_axons is None and sp.rules.poisson_sources_per_core == 500
    assert kb.formats.decay_bits == 12 and kb.formats.voltage_bits == 24 and kb.formats.weight_bits == 8
    assert sp.formats.state_format == "s16.15" and sp.formats.weight_bits == 16
    assert (kb.formats.arithmetic, l2.formats.arithmetic, sp.formats.arithmetic) == ("loihi1", "loihi2", "spinnaker")
    assert kb.energy.synaptic_op_pJ == 23.6 and kb.energy.spike_between_chips_pJ is None


@pytest.mark.parametrize("name", ["spinn5", "kapoho-bay", "loihi2"])
def test_every_number_has_a_source_comment(name):
    """Each key = value line sits in a block (between blank lines) that carries a comment."""
    text = (HWSPEC_DIR / f"{name}.toml").read_text()
    blocks = re.split(r"\n\s*\n", text)
    for block in blocks:
        lines = block.splitlines()
        keys = [ln for ln in lines if re.match(r"^[a-z_]+\s*=", ln) and ln.split("=")[0].strip() not in
                ("name", "title", "partitioner", "toolchain", "basis")]
        if keys:
            assert any(ln.lstrip().startswith("#") for ln in lines), f"{name}: no source comment for {keys}"


def test_unknown_name_lists_the_known_ones():
    with pytest.raises(ValidationError, match=r"Unknown hardware 'truenorth'; known hwspecs: .*kapoho-bay.*spinn5"):
        load_hwspec("truenorth")


def _write(tmp_path, text, name="bad.toml"):
    path = tmp_path / name
    path.write_text(text)
    return path


def test_missing_field_is_named(tmp_path):
    text = (HWSPEC_DIR / "kapoho-bay.toml").read_text().replace("max_input_axons = 4096\n", "")
    with pytest.raises(ValidationError, match=r"missing field \[core\]\.max_input_axons"):
        load_hwspec(_write(tmp_path, text))
    # Per-operation energies may be unpublished (optional); the basis of the figures may not be left out.
    text = re.sub(r"\nbasis = [^\n]*", "", (HWSPEC_DIR / "spinn5.toml").read_text())
    with pytest.raises(ValidationError, match=r"missing field \[energy\]\.basis"):
        load_hwspec(_write(tmp_path, text))


def test_missing_table_and_partitioner_table(tmp_path):
    text = (HWSPEC_DIR / "spinn5.toml").read_text()
    no_timing = re.sub(r"\[timing\].*?(?=\n\[energy\])", "", text, flags=re.S)
    with pytest.raises(ValidationError, match=r"missing table \[timing\]"):
        load_hwspec(_write(tmp_path, no_timing))
    no_rules = re.sub(r"\[spinnaker\].*?(?=\n\[formats\])", "", text, flags=re.S)
    with pytest.raises(ValidationError, match=r"missing table \[spinnaker\] \(required by the spinnaker partitioner\)"):
        load_hwspec(_write(tmp_path, no_rules))


def test_malformed_and_mistyped_files(tmp_path):
    with pytest.raises(ValidationError, match="is not valid TOML"):
        load_hwspec(_write(tmp_path, "[hardware\nname = 1"))
    text = (HWSPEC_DIR / "kapoho-bay.toml").read_text()
    with pytest.raises(ValidationError, match=r"\[core\]\.max_neurons must be an integer, got 'many'"):
        load_hwspec(_write(tmp_path, text.replace("max_neurons = 1024", 'max_neurons = "many"')))
    with pytest.raises(ValidationError, match=r"\[chip\]\.n_chips must be >= 1, got 0"):
        load_hwspec(_write(tmp_path, text.replace("n_chips = 2", "n_chips = 0")))
    with pytest.raises(ValidationError, match=r"unknown field \[core\]\.max_neuron "):
        load_hwspec(_write(tmp_path, text.replace("max_neurons = 1024", "max_neuron = 1024")))
    with pytest.raises(ValidationError, match=r"partitioner: Unknown architecture 'nxsdk'; known architectures: loihi, "):
        load_hwspec(_write(tmp_path, text.replace('partitioner = "loihi"', 'partitioner = "nxsdk"')))
    with pytest.raises(ValidationError, match="does not exist"):
        load_hwspec(tmp_path / "absent.toml")
