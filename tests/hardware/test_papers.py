"""The three papers' models at published size on each hardware target.

The default run checks the fit of each model (cores, chips and the limits broken, with
numbers that the oracle tests tie to NengoLoihi and sPyNNaker); the slow run repeats the
oracle comparison for the 123-module Modular SNN (Nordland, 3072 places / 25 per module)
and runs one inference of each model through the reference simulator into an energy
estimate for every target.
"""

from __future__ import annotations

import numpy as np
import pytest
from hw_models import locsnet, mbsnn, modular_snn

import neurovpr as nv
from neurovpr.hardware import check_network, estimate_energy, known_hwspecs, load_hwspec, read_activity, write_activity

# (model, hardware) -> (fits, chips, cores, limits broken)
EXPECTED = {
    ("modular", "spinn5"): (False, 1, 6, {"neuron model", "plasticity rule", "synaptic row length"}),
    ("modular", "kapoho-bay"): (False, 1, 6, {"neuron model", "plasticity rule"}),
    ("modular", "loihi2"): (False, 1, 4, {"neuron model", "plasticity rule"}),
    ("mbsnn", "spinn5"): (True, 4, 38, set()),
    ("mbsnn", "kapoho-bay"): (False, 1, 24, {"neuron model", "output axons per core"}),
    ("mbsnn", "loihi2"): (False, 1, 15, {"neuron model", "output axons per core", "synapse memory bits per core"}),
    ("locsnet", "spinn5"): (True, 4, 58, set()),
    ("locsnet", "kapoho-bay"): (False, 1, 42, {"output axons per core"}),
    ("locsnet", "loihi2"): (False, 1, 24, {"output axons per core"}),
}
MODELS = {"modular": lambda: modular_snn(1), "mbsnn": mbsnn, "locsnet": locsnet}


@pytest.fixture(scope="module")
def networks():
    return {}


def _network(cache: dict, name: str) -> nv.Network:
    if name not in cache:
        cache[name] = MODELS[name]()
    return cache[name]


@pytest.mark.parametrize(
    ("model", "hardware"),
    [pytest.param(m, h, marks=() if m == "modular" else pytest.mark.slow) for m, h in sorted(EXPECTED)],
)
def test_paper_model_fit(networks, model, hardware):
    report = check_network(_network(networks, model), hardware)
    fits, chips, cores, limits = EXPECTED[(model, hardware)]
    assert (report.fits, report.partition.chips, len(report.partition.cores)) == (fits, chips, cores)
    assert {v.limit for v in report.partition.violations} == limits


@pytest.mark.slow
@pytest.mark.parametrize(("hardware", "chips", "cores"), [("spinn5", 47, 738), ("kapoho-bay", 6, 738),
                                                          ("loihi2", 4, 492)])
def test_full_modular_snn_fit(hardware, chips, cores):
    report = check_network(modular_snn(123), hardware)
    assert (report.partition.chips, len(report.partition.cores)) == (chips, cores)
    assert not report.fits


@pytest.mark.slow
def test_full_modular_snn_matches_spynnaker(tmp_path):
    pytest.importorskip("spynnaker")
    from spinnaker_oracle import spinnaker_mapping

    net = modular_snn(123, plastic=False)
    report = check_network(net, "spinn5")
    oracle = spinnaker_mapping(net, tmp_path)
    assert oracle.error is None
    assert [(c.population, c.lo, c.hi - 1, *c.location) for c in report.partition.cores] == oracle.placements
    assert report.partition.chips == oracle.chips == 47


@pytest.mark.slow
def test_full_modular_snn_matches_nengo_loihi():
    pytest.importorskip("nengo_loihi")
    from nengo_oracle import nengo_blocks

    net = modular_snn(123, plastic=False)
    report = check_network(net, "kapoho-bay")
    mine = [(c.population, c.lo, c.hi, c.usage["input_axons"], c.usage["output_axons"], c.usage["synapse_bits"])
            for c in report.partition.cores]
    theirs = [(b.population, b.lo, b.hi, b.input_axons, b.output_axons, b.synapse_bits) for b in nengo_blocks(net)]
    assert mine == theirs


def _inference(name: str, net: nv.Network, rng: np.random.Generator) -> tuple[float, dict]:
    """One inference on the reference simulator: (duration ms, inputs)."""
    if name == "modular":
        return 350.0, {"pixels": rng.uniform(0.0, 63.75, 784)}  # Diehl & Cook: intensity / 4 Hz
    if name == "mbsnn":
        return 100.0, {}  # the network carries 100 ms of event-camera spikes
    return 100.0, {"input": rng.uniform(0.0, 100.0, 56 * 56)}


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(MODELS))
def test_energy_per_inference_of_each_paper_model(tmp_path, name):
    """Reference simulator activity -> activity.json -> joules per inference on each target."""
    net = modular_snn(1, plastic=False) if name == "modular" else MODELS[name]()
    rng = np.random.default_rng(0)
    duration, inputs = _inference(name, net, rng)
    sim = nv.compile(net, backend="reference", dt=1.0, seed=1)
    sim.run(duration, inputs=inputs)
    spikes = {p: int(sim.spike_counts(p).sum()) for p in net.populations}
    write_activity(tmp_path, sim.statistics(), 1, dt_ms=1.0, population_spikes=spikes)
    activity = read_activity(tmp_path)
    assert activity["steps"] == duration
    for hardware in known_hwspecs():
        report = estimate_energy(activity, hardware, network=net)
        if report.breakdown:
            assert report.joules_per_inference == pytest.approx(sum(report.breakdown.values()))
        else:
            assert report.joules_per_inference is None
        if load_hwspec(hardware).energy.synaptic_op_pJ is None:  # unpublished (SynSense chips): not estimated
            assert any("synaptic ops" in s for s in report.not_estimated)
            continue
        assert report.joules_per_inference > 0
        assert report.breakdown["static"] > 0
