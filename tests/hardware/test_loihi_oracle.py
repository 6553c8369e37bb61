"""The Loihi checker against NengoLoihi's own block splitting, validation and allocation.

Every block NengoLoihi makes must match one core of the checker exactly: population,
compartment range, input axons, output axon slots and synapse bits, and every block
NengoLoihi's validation rejects must be reported with NengoLoihi's own wording.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import neurovpr as nv
from neurovpr.hardware import check_network, load_hwspec

pytest.importorskip("nengo_loihi")

from hw_models import locsnet, mbsnn, modular_snn, small_net
from nengo_oracle import nengo_blocks, nengo_chips

HWSPEC_DIR = Path(__file__).resolve().parents[2] / "hwspecs"


def _compare(network: nv.Network, hardware: str = "kapoho-bay"):
    report = check_network(network, hardware)
    mine = [
        (c.population, c.lo, c.hi, c.usage["neurons"], c.usage["input_axons"], c.usage["output_axons"],
         c.usage["synapse_bits"])
        for c in report.partition.cores
    ]
    oracle = nengo_blocks(network)
    theirs = [(b.population, b.lo, b.hi, b.compartments, b.input_axons, b.output_axons, b.synapse_bits)
              for b in oracle]
    assert mine == theirs
    # NengoLoihi's validation stops at the first broken limit of a block: it must be one of ours.
    ours = [v.message for v in report.partition.violations]
    for block in oracle:
        if block.error is not None:
            reason = block.error.split("): ", 1)[1]
            assert any(reason in m for m in ours), (block.error, ours)
    failing = {(b.population, b.lo, b.hi) for b in oracle if b.error is not None}
    assert len(failing) == len({v.where for v in report.partition.violations
                                if v.limit.endswith("per core")}), (failing, ours)
    return report


def test_small_network_matches_nengo_loihi():
    report = _compare(small_net())
    assert report.fits and len(report.partition.cores) == 3


def test_modular_module_matches_nengo_loihi():
    """784 -> 400 -> 400 with dense input: the excitatory block splits into 5 by synapse memory."""
    net = modular_snn(1, plastic=False)
    # NengoLoihi maps current-based LIF only; the mapping itself does not depend on the model.
    report = _compare(net)
    assert [c.population for c in report.partition.cores] == ["exc"] * 5 + ["inh"]
    assert {v.limit for v in report.partition.violations} == {"neuron model"}


def test_small_convolution_and_dense_layer_match_nengo_loihi():
    report = _compare(locsnet(n_places=300, input_hw=24, channels=(4, 8, 8)))
    assert len(report.partition.cores) >= 4


def test_dense_block_that_cannot_be_split_matches_nengo_loihi_errors():
    """700 x 700 dense recurrence: splitting by memory multiplies the output axons past 4096."""
    net = nv.Network("dense")
    net.add_population("src", 300, nv.SpikeSourcePoisson(rate=1.0))
    net.add_population("a", 700, nv.IF_curr_exp())
    net.add_population("b", 700, nv.IF_curr_exp())
    rng = np.random.default_rng(0)
    net.connect("src", "a", nv.AllToAllConnector(), nv.StaticSynapse(weight=rng.uniform(0, 1, (300, 700))))
    net.connect("a", "b", nv.OneToOneConnector(), nv.StaticSynapse(weight=0.5))
    net.connect("b", "a", nv.AllToAllConnector(allow_self_connections=False), nv.StaticSynapse(weight=0.3),
                receptor_type="inhibitory")
    report = _compare(net)
    assert not report.fits
    broken = [v for v in report.partition.violations if v.limit == "output axons per core"]
    assert broken and broken[0].value == 4200 and broken[0].excess == 104


def test_chip_count_matches_greedy_allocator(tmp_path):
    """One core per block, filling chip after chip: the rule of Greedy(cores_per_chip=N)."""
    text = (HWSPEC_DIR / "kapoho-bay.toml").read_text().replace("app_cores_per_chip = 128", "app_cores_per_chip = 4")
    (tmp_path / "small-chips.toml").write_text(text)
    spec = load_hwspec(tmp_path / "small-chips.toml")
    net = nv.Network("chips")
    net.add_population("src", 5, nv.SpikeSourcePoisson(rate=1.0))
    for k in range(7):
        net.add_population(f"p{k}", 3 if k else 2000, nv.IF_curr_exp())  # p0 splits into 2 blocks
        net.connect("src", f"p{k}", nv.AllToAllConnector(), nv.StaticSynapse(weight=0.1))
    report = check_network(net, spec)
    assert len(report.partition.cores) == 8
    assert report.partition.chips == nengo_chips(net, n_chips=2, cores_per_chip=4) == 2
    assert report.fits and [c.chip for c in report.partition.cores] == [0, 0, 0, 0, 1, 1, 1, 1]
    net.add_population("p7", 3, nv.IF_curr_exp())
    report = check_network(net, spec)
    assert report.partition.chips == nengo_chips(net, n_chips=3, cores_per_chip=4) == 3
    with pytest.raises(AssertionError, match="needs more chips"):
        nengo_chips(net, n_chips=2, cores_per_chip=4)
    broken = [v for v in report.partition.violations if v.limit == "chips"]
    assert broken and broken[0].value == 3 and broken[0].maximum == 2
    assert check_network(net, "kapoho-bay").partition.chips == 1  # 128 cores per chip


@pytest.mark.slow
def test_locsnet_matches_nengo_loihi():
    report = _compare(locsnet())
    assert not report.fits  # NengoLoihi's default split leaves conv1 with 4374 output axons


@pytest.mark.slow
def test_mbsnn_matches_nengo_loihi():
    # NengoLoihi runs no STDP (and drops zero weights), so the test-time network is compared.
    _compare(mbsnn(plastic=False))


@pytest.mark.slow
def test_three_modules_match_nengo_loihi():
    _compare(modular_snn(3, plastic=False))


def test_loihi2_uses_its_own_limits():
    """Same rules, Loihi 2 limits: 8192 neurons per core and a shared 192 KB memory."""
    spec = load_hwspec("loihi2")
    report = check_network(modular_snn(1, plastic=False), spec)
    for core in report.partition.cores:
        assert core.usage["neurons"] <= 8192
        assert core.limits["synapse_bits"] == 192 * 1024 * 8
    assert len(report.partition.cores) < len(check_network(modular_snn(1, plastic=False), "kapoho-bay").partition.cores)
