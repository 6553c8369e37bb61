"""The SpiNNaker checker against sPyNNaker's own mapping on a virtual SpiNN-5 board.

The oracle is the spinnaker backend's ``map_network`` (sPyNNaker's real partitioner,
placer and router). Every machine vertex sPyNNaker places must be one core of the
checker, in the same order, with the same population, kind, atom range and (x, y, p)
location; the synaptic matrix region of every core must have the same size, and a
network sPyNNaker cannot map must be reported as a violation of the same limit. This
holds at sPyNNaker's default 1 ms step and at sub-millisecond steps, where sPyNNaker
gives populations separate neuron and synapse cores.
"""

from __future__ import annotations

import dataclasses
import re
from collections import Counter

import numpy as np
import pytest

import neurovpr as nv
from neurovpr.errors import ValidationError
from neurovpr.hardware import HwSpec, check_network, load_hwspec

pytest.importorskip("spynnaker")

from hw_models import locsnet, mbsnn, modular_snn, small_net, sub_ms_net, synapse_bound_net
from spinnaker_oracle import spinnaker_mapping, spynnaker_equivalent

#: The checker's core kinds by the names the oracle gives sPyNNaker's machine vertices.
_KINDS = {"sources": "source"}


def _spinn5(dt: float) -> HwSpec:
    """The SpiNN-5 spec run at a time step of ``dt`` ms."""
    spec = load_hwspec("spinn5")
    return dataclasses.replace(spec, timing=dataclasses.replace(spec.timing, time_step_ms=dt))


def _compare(network: nv.Network, dt: float = 1.0):
    report = check_network(network, _spinn5(dt))
    oracle = spinnaker_mapping(network, dt=dt)
    assert oracle.error is None, oracle.error
    mine = [(c.population, c.lo, c.hi - 1, *c.location) for c in report.partition.cores]
    assert mine == oracle.placements
    assert [_KINDS.get(c.kind, c.kind) for c in report.partition.cores] == oracle.kinds
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

    from neurovpr.hardware.spinnaker_rows import list_row_max as _list_row_max

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


@pytest.mark.parametrize(("dt", "shortest", "longest"), [(0.1, 0.1, 6.0), (0.5, 0.5, 30.0), (1.0, 1.0, 60.0)])
def test_sub_ms_network_matches_spynnaker(dt, shortest, longest):
    """Neuron and synapse cores below 1 ms, combined cores at 1 ms, with delay extensions.

    Below 1 ms every population with synaptic input has per slice a lead synapse core
    (holding the synaptic matrix), further synapse cores for STDP input (``r``), the
    core of a one-to-one Poisson source of its size (``drive``, ``lonely``) and the
    neuron core, on one chip; ``idle`` has no input and keeps a combined core. ``r -> p``
    delays reach twice the 32-step ring buffer of ``p``, with delays of exactly 32 steps
    (counted in both of its synaptic matrices, as sPyNNaker does).
    """
    report = _compare(sub_ms_net(shortest_delay=shortest, longest_delay=longest), dt)
    cores = report.partition.cores
    count = Counter(c.population for c in cores)
    assert count["r:delays"] == 3
    if dt == 1.0:
        assert not any(c.kind == "synapses" for c in cores) and count["drive"] == 1
        return
    assert count["p:synapses"] == 2 and count["q:synapses"] == 1 and count["r:synapses"] == 6
    assert [c.kind for c in cores if c.population.startswith("p")] == ["synapses", "neurons"] * 2
    assert [(c.lo, c.hi) for c in cores if c.population == "drive"] == [(0, 256), (256, 300)]
    for group in ([c for c in cores if c.population in ("p", "p:synapses", "drive")][k::2] for k in (0, 1)):
        assert len({c.location[:2] for c in group}) == 1
    assert [c.kind for c in cores if c.population == "idle"] == ["neurons"]
    assert report.partition.cores_of("idle")[0].usage["synaptic_matrix_bytes"] == 8


def test_step_of_whole_microseconds_rounds_delays_as_in_spynnaker():
    """At 0.1234 ms sPyNNaker runs 124 us steps (it rounds the step up to whole microseconds).

    A 4.02 ms delay is 32.4 of its steps, 32: within the 32 delay slots of ``near``, no
    delay extension (at exactly 0.1234 ms it would be 32.6, 33 steps, and need one);
    4.06 ms is 32.7 steps, 33: ``far`` needs a delay extension for ``src_far``.
    """
    net = nv.Network("us_step")
    for name, delay in (("near", 4.02), ("far", 4.06)):
        net.add_population(f"src_{name}", 100, nv.SpikeSourcePoisson(rate=5.0))
        net.add_population(name, 300, nv.IF_curr_exp())
        net.connect(f"src_{name}", name, nv.AllToAllConnector(), nv.StaticSynapse(weight=0.1, delay=delay))
    report = _compare(net, 0.1234)
    count = Counter(c.population for c in report.partition.cores)
    assert count["src_far:delays"] == 1 and "src_near:delays" not in count
    assert count["near:synapses"] == count["near"] == 2  # below 1 ms: separate synapse cores
    assert report.partition.notes[0] == "sPyNNaker runs whole microseconds: the 0.1234 ms step runs as 0.124 ms."


def test_step_rounded_up_to_one_ms_keeps_combined_cores_as_in_spynnaker():
    """0.9995 ms is 1000 us for sPyNNaker, not below 1 ms: combined neuron-and-synapse cores."""
    report = _compare(sub_ms_net(shortest_delay=1.0, longest_delay=60.0), 0.9995)
    assert not any(c.kind == "synapses" for c in report.partition.cores)
    assert Counter(c.population for c in report.partition.cores)["r:delays"] == 3


def test_synapse_cores_capped_and_poisson_kept_apart_as_in_spynnaker():
    """17 synapse cores wanted, 15 given; a group of 16 cores skips chips with fewer free."""
    report = _compare(synapse_bound_net(), 0.1)
    cores = report.partition.cores
    post = [c for c in cores if c.population in ("post", "post:synapses")]
    assert [c.kind for c in post] == ["synapses"] * 15 + ["neurons"]
    assert {c.location[:2] for c in post} == {(0, 1)}
    assert [c.location for c in cores if c.population == "drive"] == [(0, 0, 9)]


def test_reduced_mbsnn_at_sub_ms_step_matches_spynnaker():
    """MBSNN with 2 x 1000 KCs at 0.1 ms: STDP KC->KC input needs several synapse cores."""
    report = _compare(mbsnn(n_kc=1000), 0.1)
    count = Counter(c.population for c in report.partition.cores)
    assert count["kc2:synapses"] > count["kc2"] == 4 and count["kc1:synapses"] == count["kc1"]


@pytest.mark.slow
def test_mbsnn_at_sub_ms_step_matches_spynnaker():
    """Paper size at 0.1 ms: 16 KC2 slices of 15 synapse cores and a neuron core, one chip each."""
    report = _compare(mbsnn(), 0.1)
    count = Counter(c.population for c in report.partition.cores)
    assert count["kc2:synapses"] == 15 * 16
    assert report.partition.chips == 19 and report.fits


def test_sub_ms_rules_are_read_from_the_hwspec(tmp_path):
    """The sub-ms constants come from the hwspec, and a missing one is named."""
    text = load_hwspec("spinn5").source
    with open(text, encoding="utf-8") as f:
        toml = f.read()
    path = tmp_path / "no_rate.toml"
    path.write_text(re.sub(r"(?m)^stdp_synapses_per_second = .*$", "", toml), encoding="utf-8")
    with pytest.raises(ValidationError, match=r"missing field \[spinnaker\]\.stdp_synapses_per_second"):
        load_hwspec(path)
    faster = tmp_path / "faster.toml"
    faster.write_text(re.sub(r"(?m)^stdp_synapses_per_second = .*$", "stdp_synapses_per_second = 100000000", toml),
                      encoding="utf-8")
    spec = load_hwspec(faster)
    spec = dataclasses.replace(spec, timing=dataclasses.replace(spec.timing, time_step_ms=0.1))
    cores = check_network(synapse_bound_net(), spec).partition.cores
    assert sum(c.population == "post:synapses" for c in cores) == 1
