"""The SpiNNaker checker against sPyNNaker's own mapping on a virtual SpiNN-5 board.

The oracle is the spinnaker backend's ``map_network`` (sPyNNaker's real partitioner,
placer and router). Every machine vertex sPyNNaker places must be one core of the
checker, in the same order, with the same population, atom range and (x, y, p)
location; the synaptic matrix region of every core must have the same size, and a
network sPyNNaker cannot map must be reported as a violation of the same limit.
"""

from __future__ import annotations

import numpy as np
import pytest

import neurovpr as nv
from neurovpr.hardware import check_network

pytest.importorskip("spynnaker")

from hw_models import locsnet, mbsnn, modular_snn, small_net
from spinnaker_oracle import spinnaker_mapping, spynnaker_equivalent


def _compare(network: nv.Network):
    report = check_network(network, "spinn5")
    oracle = spinnaker_mapping(network)
    assert oracle.error is None, oracle.error
    mine = [(c.population, c.lo, c.hi - 1, *c.location) for c in report.partition.cores]
    assert mine == oracle.placements
    assert report.partition.chips == oracle.chips
    assert [c.usage.get("synaptic_matrix_bytes") for c in report.partition.cores] == oracle.core_matrix_bytes
    return report


def test_small_network_matches_spynnaker():
    report = _compare(small_net())
    assert report.fits and len(report.partition.cores) == 4


def test_modular_module_matches_spynnaker():
    """784 Poisson (2 cores of 500) -> 400 exc (256 + 144) -> 400 inh, dense input rows.

    sPyNNaker has no Diehl & Cook neuron: it maps the same module with ``IF_cond_exp``
    excitatory neurons, which it partitions alike, and the checker reports the neuron
    model as the one violation.
    """
    net = modular_snn(1, plastic=False)
    report = _compare(net)
    assert [c.population for c in report.partition.cores] == ["pixels"] * 2 + ["exc"] * 2 + ["inh"] * 2
    assert [(v.limit, v.where) for v in report.partition.violations] == [("neuron model", "exc")]
    equivalent = check_network(spynnaker_equivalent(net), "spinn5")
    assert equivalent.fits and equivalent.partition.cores == report.partition.cores


@pytest.mark.slow
def test_plastic_modular_module_is_refused_as_in_spynnaker():
    """Learning module: 784-wide plastic rows onto 256-neuron cores need 258 words (sPyNNaker's
    pair STDP stands in for Diehl & Cook's rule, with rows of the same size)."""
    net = modular_snn(1, plastic=True)
    report = check_network(net, "spinn5")
    assert {v.limit for v in report.partition.violations} == {"neuron model", "plasticity rule", "synaptic row length"}
    assert {(v.where, v.value) for v in report.partition.violations if v.limit == "synaptic row length"} == {
        ("pixels->exc", 258)}
    oracle = spinnaker_mapping(net)
    assert oracle.error is not None and "SynapseRowTooBigException" in oracle.error


def test_signed_weights_rounded_delays_and_cross_population_no_self_match_spynnaker():
    """Three cases where the checker once disagreed with sPyNNaker, one per population.

    * ``signed``: per-synapse weights of both signs onto the excitatory receptor of a
      current-based population are two sPyNNaker projections (unsigned synaptic words),
      the negative weights onto the inhibitory receptor: two synaptic blocks, not one.
    * ``late``: a delay of 32.4 ms is 32 steps for sPyNNaker, within the 32 delay slots
      of a 256-neuron core: no delay-extension core.
    * ``cross``: an all-to-all without self-connections between two populations is an
      explicit list (sPyNNaker's own connector would keep ``i -> i``): rows of 2, not 3.
    """
    rng = np.random.default_rng(7)
    net = nv.Network("cases")
    net.add_population("src", 20, nv.SpikeSourcePoisson(rate=5.0))
    net.add_population("signed", 30, nv.IF_curr_exp())
    net.connect("src", "signed", nv.AllToAllConnector(), nv.StaticSynapse(weight=rng.normal(0.0, 0.2, (20, 30))))
    net.add_population("late", 256, nv.IF_curr_exp())
    delay = np.ones((20, 256))
    delay[3, 17] = 32.4
    net.connect("src", "late", nv.AllToAllConnector(), nv.StaticSynapse(weight=0.1, delay=delay))
    net.add_population("partner", 3, nv.IF_curr_exp())
    net.add_population("cross", 3, nv.IF_curr_exp())
    net.connect("partner", "cross", nv.AllToAllConnector(allow_self_connections=False), nv.StaticSynapse(weight=0.5),
                receptor_type="inhibitory")
    report = _compare(net)
    matrix = {c.population: c.usage.get("synaptic_matrix_bytes") for c in report.partition.cores}
    # signed: 8 + two blocks of 20 rows of (longest row + 3 header words) x 4 bytes, 16-byte aligned
    assert matrix["signed"] > 8 + 20 * (30 + 3) * 4
    assert matrix["late"] == 16 + 20 * (256 + 3) * 4 and "src:delays" not in matrix
    assert matrix["cross"] == 16 + 3 * (2 + 3) * 4


def _mixed() -> nv.Network:
    """Many populations over several chips, delay extensions, STDP rows, an array source."""
    net = nv.Network("mixed")
    net.add_population("src", 1200, nv.SpikeSourcePoisson(rate=5.0))
    net.add_population("arr", 700, nv.SpikeSourceArray.from_lists([[1.0]] * 700))
    prev = "src"
    for k, size in enumerate([300, 40, 700, 513, 256, 257, 1000, 90, 1500]):
        net.add_population(f"p{k}", size, nv.IF_curr_exp() if k % 2 else nv.IF_cond_exp())
        net.connect(prev, f"p{k}", nv.FixedProbabilityConnector(p_connect=0.05, seed=k), nv.StaticSynapse(weight=0.1))
        prev = f"p{k}"
    net.connect("arr", "p3", nv.AllToAllConnector(), nv.StaticSynapse(weight=0.2, delay=40.0))
    net.connect("p0", "p5", nv.FixedNumberPreConnector(n=3, seed=11),
                nv.StaticSynapse(weight=0.1, delay=nv.Uniform(low=1.0, high=70.0)))
    net.connect("p4", "p6", nv.FixedProbabilityConnector(p_connect=0.3, seed=12), nv.STDPMechanism(weight=0.1, delay=2.0))
    net.connect("p7", "p7", nv.AllToAllConnector(allow_self_connections=False), nv.StaticSynapse(weight=0.3),
                receptor_type="inhibitory")
    net.connect("p1", "p8", nv.FixedProbabilityConnector(p_connect=0.5, seed=13),
                nv.STDPMechanism(weight=0.05, delay=nv.Uniform(low=1.0, high=3.0)))
    return net


@pytest.mark.slow
def test_mixed_network_with_delays_and_stdp_matches_spynnaker():
    report = _compare(_mixed())
    kinds = [c.kind for c in report.partition.cores]
    assert kinds.count("delays") == 1 + 2  # arr (1 core) and p0 (2 cores) need delay extensions
    assert report.partition.chips == 3


@pytest.mark.slow
def test_mbsnn_matches_spynnaker():
    report = _compare(mbsnn())
    assert report.fits


@pytest.mark.slow
def test_locsnet_matches_spynnaker():
    report = _compare(locsnet())
    assert report.fits


def test_row_too_long_is_a_violation_as_in_spynnaker():
    """A plastic all-to-all row onto 256-neuron cores needs 258 words: sPyNNaker refuses it."""
    net = nv.Network("long_rows")
    net.add_population("pre", 20, nv.SpikeSourcePoisson(rate=1.0))
    net.add_population("post", 300, nv.IF_curr_exp())
    net.connect("pre", "post", nv.AllToAllConnector(), nv.STDPMechanism(weight=0.1))
    report = check_network(net, "spinn5")
    assert [(v.limit, v.value, v.maximum) for v in report.partition.violations] == [("synaptic row length", 258, 256)]
    oracle = spinnaker_mapping(net)
    assert oracle.error is not None and "SynapseRowTooBigException" in oracle.error


@pytest.mark.slow
def test_board_overflow_is_a_violation_as_in_spynnaker():
    net = nv.Network("too_big")
    net.add_population("a", 256 * 700, nv.IF_curr_exp())
    net.add_population("b", 256 * 100, nv.IF_curr_exp())
    report = check_network(net, "spinn5")
    assert not report.fits
    cores = [v for v in report.partition.violations if v.limit == "cores"]
    assert cores and cores[0].value == 800 and cores[0].maximum == 759
    oracle = spinnaker_mapping(net)
    assert oracle.error is not None and "PacmanPlaceException" in oracle.error


def test_placement_fills_chips_like_pacman():
    """Without the oracle: 20 populations of 2 cores fill (0,0) (15 free cores) then its neighbours."""
    net = nv.Network("fill")
    for k in range(20):
        net.add_population(f"p{k}", 400, nv.IF_curr_exp())
    cores = check_network(net, "spinn5").partition.cores
    assert [c.location for c in cores[:15]] == [(0, 0, p) for p in range(3, 18)]
    assert cores[15].location == (1, 0, 2)  # first neighbour over link 0 (east)
    assert np.all(np.diff([c.chip for c in cores]) >= 0)


def test_explicit_list_rows_follow_spynnaker_estimate():
    """Row lengths of explicit lists equal sPyNNaker's own estimate, even for unsorted lists,
    where sPyNNaker 7.4.1 groups the list in its original order and differs from the true count."""
    from spynnaker.pyNN.models.neural_projections.connectors import FromListConnector

    from neurovpr.hardware.spinnaker import _list_row_max

    rng = np.random.default_rng(0)
    differs = 0
    for _ in range(40):
        n = int(rng.integers(5, 400))
        pre, post = rng.integers(0, 50, n), rng.integers(0, 700, n)
        theirs = FromListConnector(np.stack([pre, post], axis=1)).get_n_connections_from_pre_vertex_maximum(256, None)
        assert _list_row_max(pre, post // 256) == theirs
        true_max = int(np.unique(pre * 3 + post // 256, return_counts=True)[1].max())
        differs += true_max != theirs
    assert differs > 0
