"""The PyNN backends: translation, refusals, and real runs on NEST and Brian2 through PyNN."""

from __future__ import annotations

import math

import numpy as np
import pytest

import neurovpr as nv
from neurovpr.backends import pynn as pynn_backend
from neurovpr.backends.pynn.translation import from_pynn_weights, to_pynn_weights, translate
from neurovpr.errors import BackendUnavailableError, SimulationError, UnsupportedFeatureError
from neurovpr.ir.connectivity import expand

pytest.importorskip("pyNN")
NEST = pynn_backend.BACKEND
BRIAN2 = pynn_backend.BACKEND_BRIAN2


def _needs(backend: pynn_backend.PyNNBackend) -> None:
    reason = backend.unavailable_reason()
    if reason is not None:
        pytest.skip(reason)


def _input_network(seed: int = 3) -> nv.Network:
    """20 array sources -> 10 current-based LIF <-> 5 conductance-based LIF (random weights and delays)."""
    rng = np.random.default_rng(seed)
    net = nv.Network("small")
    trains = [np.unique(np.round(rng.uniform(0.0, 100.0, 15), 1)) for _ in range(20)]
    net.add_population("inp", 20, nv.SpikeSourceArray.from_lists(trains))
    net.add_population("exc", 10, nv.IF_curr_exp(tau_syn_E=2.0, tau_syn_I=4.0, tau_refrac=2.0))
    net.add_population("inh", 5, nv.IF_cond_exp(tau_refrac=1.0))
    net.connect(
        "inp", "exc", nv.FixedProbabilityConnector(p_connect=0.5),
        nv.StaticSynapse(weight=nv.Uniform(low=0.5, high=2.5), delay=nv.Uniform(low=0.1, high=3.0)),
    )
    net.connect("exc", "inh", nv.AllToAllConnector(), nv.StaticSynapse(weight=0.05, delay=1.0))
    net.connect(
        "inh", "exc", nv.AllToAllConnector(), nv.StaticSynapse(weight=1.0, delay=0.5), receptor_type="inhibitory"
    )
    return net


def _stdp(**timing: float) -> nv.STDPMechanism:
    rule = {"tau_plus": 16.8, "tau_minus": 33.7, "A_plus": 0.05, "A_minus": 0.04, **timing}
    return nv.STDPMechanism(
        timing_dependence=nv.SpikePairRule(**rule),
        weight_dependence=nv.AdditiveWeightDependence(w_min=0.0, w_max=1.0),
        weight=0.5,
        delay=1.5,
    )


def _pair_network(t_pre: list[float], t_drive: list[float]) -> nv.Network:
    net = nv.Network("pair")
    net.add_population("pre", 1, nv.SpikeSourceArray.from_lists([t_pre]))
    net.add_population("drive", 1, nv.SpikeSourceArray.from_lists([t_drive]))
    net.add_population("post", 1, nv.IF_curr_exp(tau_m=10.0, tau_syn_E=1.0, tau_refrac=5.0, v_reset=-70.0))
    net.connect("pre", "post", nv.AllToAllConnector(), _stdp(), name="plastic")
    net.connect("drive", "post", nv.AllToAllConnector(), nv.StaticSynapse(weight=100.0, delay=0.1), name="drive")
    return net


# -- translation ------------------------------------------------------------------
def test_translation_of_every_supported_type() -> None:
    """Cell types, parameters, sources, connectors and synapses map to PyNN's names and values."""
    net = nv.Network("all_types")
    net.add_population("poisson", 6, nv.SpikeSourcePoisson(rate=np.arange(6.0), start=5.0, duration=50.0))
    net.add_population("array", 4, nv.SpikeSourceArray.from_lists([[1.0], [], [2.0, 3.0], [4.0]]))
    curr = nv.IF_curr_exp(cm=0.5, tau_m=12.0, tau_refrac=1.5, tau_syn_E=3.0, tau_syn_I=3.0, v_rest=-61.0,
                          v_reset=-66.0, v_thresh=-52.0, i_offset=np.linspace(0, 0.1, 6))
    net.add_population("curr", 6, curr, v_init=-60.0)
    net.add_population("cond", 6, nv.IF_cond_exp(e_rev_E=5.0, e_rev_I=-75.0))
    net.connect("poisson", "curr", nv.OneToOneConnector(), nv.StaticSynapse(weight=0.2, delay=0.26))
    net.connect("array", "curr", nv.AllToAllConnector(), _stdp(), name="stdp")
    net.connect("curr", "curr", nv.AllToAllConnector(allow_self_connections=False),
                nv.StaticSynapse(weight=0.3), receptor_type="inhibitory", name="lateral")
    net.connect("curr", "cond", nv.FixedNumberPreConnector(n=2), nv.StaticSynapse(weight=0.01),
                receptor_type="inhibitory", name="to_cond")
    net.connect("poisson", "cond", nv.FromListConnector(conn_list=np.array([[0, 1, 0.4], [5, 2, -0.0]])),
                nv.StaticSynapse(), name="listed")
    signed = np.array([[0.5, -0.25, 0.0, 1.0, -1.0, 0.1]] * 4)
    net.connect("array", "curr", nv.AllToAllConnector(), nv.StaticSynapse(weight=signed), name="signed")
    net.connect("cond", "cond", nv.FixedProbabilityConnector(p_connect=0.5, seed=4),
                nv.STDPMechanism(weight_dependence=nv.MultiplicativeWeightDependence(w_max=0.2), weight=0.1),
                name="mult")
    plan = translate(net, dt=0.1, seed=9)

    kinds = {name: (p.pynn_type, p.is_source) for name, p in plan.populations.items()}
    assert kinds == {"poisson": ("SpikeSourcePoisson", True), "array": ("SpikeSourceArray", True),
                     "curr": ("IF_curr_exp", False), "cond": ("IF_cond_exp", False)}
    assert plan.populations["curr"].parameters["cm"] == 0.5
    assert plan.populations["curr"].parameters["v_thresh"] == -52.0
    np.testing.assert_array_equal(plan.populations["curr"].parameters["i_offset"], np.linspace(0, 0.1, 6))
    assert plan.populations["curr"].initial_values == {"v": -60.0}
    assert plan.populations["cond"].initial_values == {"v": -65.0}
    assert plan.populations["cond"].parameters["e_rev_I"] == -75.0
    np.testing.assert_array_equal(plan.populations["poisson"].parameters["rate"], np.arange(6.0))

    modes = {(p.label, p.receptor_type, p.mode) for p in plan.parts}
    assert modes == {
        ("poisson->curr", "excitatory", "plain"),
        ("stdp", "excitatory", "plain"),
        ("lateral", "inhibitory", "negate"),
        ("to_cond", "inhibitory", "plain"),
        ("listed", "excitatory", "plain"),
        ("signed[+]", "excitatory", "positive"),
        ("signed[-]", "inhibitory", "negative"),
        ("mult", "excitatory", "plain"),
    }
    for name in net.projections:
        canon = expand(net, name, dt=0.1, seed=9)
        conns = plan.connections[name]
        np.testing.assert_array_equal(conns.pre, canon.pre)
        np.testing.assert_array_equal(conns.post, canon.post)
        np.testing.assert_array_equal(conns.weight, canon.weight)
        total = sum(
            from_pynn_weights(plan.parts[k].mode, to_pynn_weights(plan.parts[k].mode, canon.weight))
            for k in plan.parts_of[name]
        )
        np.testing.assert_array_equal(total, canon.weight)  # the parts of a projection add up to its weights
    np.testing.assert_allclose(plan.connections["poisson->curr"].delay, 0.3)  # 0.26 ms rounds to 3 steps
    stdp = next(p for p in plan.parts if p.label == "stdp").synapse
    assert stdp.timing == ("SpikePairRule", {"tau_plus": 16.8, "tau_minus": 33.7, "A_plus": 0.05, "A_minus": 0.04})
    assert stdp.weight_dependence == ("AdditiveWeightDependence", {"w_min": 0.0, "w_max": 1.0})
    mult = next(p for p in plan.parts if p.label == "mult").synapse
    assert mult.weight_dependence is not None and mult.weight_dependence[0] == "MultiplicativeWeightDependence"
    assert to_pynn_weights("negate", np.array([0.3]))[0] == -0.3  # PyNN's negative inhibitory currents


# -- refusals ---------------------------------------------------------------------
@pytest.mark.parametrize(
    ("build", "backend", "words"),
    [
        (lambda n: n.add_population("x", 2, nv.IF_cond_exp_adaptive()), NEST, ["IF_cond_exp_adaptive", "theta"]),
        (lambda n: n.add_population("x", 2, nv.IF_curr_exp_ca2_adaptive()), BRIAN2,
         ["IF_curr_exp_ca2_adaptive", "sPyNNaker"]),
    ],
)
def test_unsupported_cell_types_are_refused_by_name(build, backend, words) -> None:
    net = nv.Network("refused")
    build(net)
    with pytest.raises(UnsupportedFeatureError) as err:
        backend.compile(net, dt=0.1, seed=1)
    for word in words:
        assert word in str(err.value)
    assert str(err.value).startswith(f"Backend {backend.name!r} cannot run")


def _two(cell: nv.ir.cells.CellType) -> nv.Network:
    net = nv.Network("refused")
    net.add_population("a", 2, nv.SpikeSourceArray.from_lists([[1.0], [2.0]]))
    net.add_population("b", 2, cell)
    return net


def test_parameter_level_refusals_name_the_projection_and_reason() -> None:
    net = _two(nv.IF_curr_exp())
    net.connect("a", "b", nv.AllToAllConnector(), nv.DiehlCookSTDP(weight=0.1), name="dc")
    with pytest.raises(UnsupportedFeatureError, match=r"DiehlCookSTDP \(projection 'dc'\)"):
        NEST.compile(net, dt=0.1, seed=1)

    net = _two(nv.IF_curr_exp())
    net.connect("a", "b", nv.AllToAllConnector(), nv.STDPMechanism(
        weight_dependence=nv.AdditiveWeightDependence(w_min=0.1, w_max=1.0), weight=0.5), name="wmin")
    assert "w_min=0.1 (projection 'wmin')" in NEST.unsupported_features(net)[0]
    assert BRIAN2.unsupported_features(net) == []

    net = _two(nv.IF_curr_exp())
    net.connect("a", "b", nv.AllToAllConnector(), _stdp(tau_minus=10.0), name="p1")
    net.connect("a", "b", nv.OneToOneConnector(), _stdp(tau_minus=20.0), name="p2")
    assert "tau_minus" in NEST.unsupported_features(net)[0] and "'p2'" in NEST.unsupported_features(net)[0]

    net = _two(nv.IF_curr_exp())
    net.connect("a", "b", nv.AllToAllConnector(), _stdp(), receptor_type="inhibitory", name="inh_stdp")
    for backend in (NEST, BRIAN2):
        assert "inhibitory receptor of current-based population 'b'" in backend.unsupported_features(net)[0]

    net = _two(nv.IF_curr_exp(tau_m=5.0, tau_syn_E=5.0))
    assert "tau_m == tau_syn_E == 5 ms" in BRIAN2.unsupported_features(net)[0]
    assert NEST.unsupported_features(net) == []

    net = _two(nv.IF_curr_exp(tau_syn_E=2.0, tau_syn_I=4.0))
    net.connect("a", "b", nv.OneToOneConnector(), nv.StaticSynapse(weight=-0.5), name="negative")
    with pytest.raises(UnsupportedFeatureError, match=r"'negative'.*tau_syn_E == tau_syn_I"):
        translate(net, dt=0.1, seed=1)


def test_missing_simulator_names_the_extra() -> None:
    backend = pynn_backend.PyNNBackend(
        name="pynn", simulator="nest", description="", requires=("pyNN", "neurovpr_no_such_simulator"),
        capabilities=NEST.capabilities,
    )
    with pytest.raises(BackendUnavailableError, match=r"pip install 'neurovpr\[pynn\]'"):
        backend.compile(_input_network(), dt=0.1, seed=1)


# -- NEST -------------------------------------------------------------------------
def test_nest_spikes_equal_reference() -> None:
    """A NEST run through PyNN gives the reference backend's spike trains, spike for spike."""
    _needs(NEST)
    reference = pytest.importorskip("neurovpr.backends.reference").BACKEND
    net = _input_network()
    trains, stats = {}, {}
    for backend in (reference, NEST):
        sim = backend.compile(net, dt=0.1, seed=4)
        sim.run(120.0)
        trains[backend.name] = {pop: sim.spike_trains(pop) for pop in ("inp", "exc", "inh")}
        stats[backend.name] = sim.statistics()
        if backend is NEST:
            np.testing.assert_array_equal(sim.connections("inp->exc")[0], expand(net, "inp->exc", dt=0.1, seed=4).pre)
            np.testing.assert_allclose(
                sim.weights("inp->exc", format="list"), expand(net, "inp->exc", dt=0.1, seed=4).weight, rtol=1e-12
            )
            sim.close()
    assert trains["reference"]["exc"][0].size > 10 and trains["reference"]["inh"][0].size > 10
    for pop in ("inp", "exc", "inh"):
        np.testing.assert_array_equal(trains["pynn"][pop][1], trains["reference"][pop][1], err_msg=pop)
        np.testing.assert_allclose(trains["pynn"][pop][0], trains["reference"][pop][0], rtol=0, atol=1e-9)
    # the same spikes give the same activity counts (static synapses: spikes x out-degree)
    assert {k: stats["pynn"][k] for k in stats["reference"]} == stats["reference"] and stats["pynn"]["synaptic_events"] > 0


def test_nest_static_connections_made_from_arrays_are_the_requested_ones() -> None:
    """Static projections on NEST are made by one nest.Connect of arrays: every pair (repeats with other
    delays included), its weight (inhibitory conductances too) and delay as requested; the same spikes
    as the reference; close() keeps the weights last set."""
    _needs(NEST)
    import nest

    reference = pytest.importorskip("neurovpr.backends.reference").BACKEND
    rng = np.random.default_rng(7)
    net = nv.Network("arrays")
    trains = [np.unique(np.round(rng.uniform(0.0, 60.0, 12), 1)) for _ in range(6)]
    net.add_population("src", 6, nv.SpikeSourceArray.from_lists(trains))
    net.add_population("cur", 4, nv.IF_curr_exp(tau_refrac=1.0))
    net.add_population("cond", 3, nv.IF_cond_exp(tau_refrac=1.0))
    # (pre, post, weight, delay): pairs repeated with other delays, onto both receptors of both cell kinds
    rows = np.array([[0, 0, 2.0, 1.0], [0, 0, 1.5, 2.5], [1, 2, 3.0, 0.5], [5, 3, 2.2, 4.0], [2, 1, 2.6, 1.0], [2, 1, 0.4, 1.2]])
    net.connect("src", "cur", nv.FromListConnector(rows), nv.StaticSynapse(weight=1.0, delay=1.0))
    net.connect("src", "cond", nv.FromListConnector(rows[:, :4] % [6, 3, 10, 10] * [1, 1, 0.01, 1]), nv.StaticSynapse())
    net.connect("cur", "cond", nv.AllToAllConnector(), nv.StaticSynapse(weight=0.02, delay=0.7), receptor_type="inhibitory")
    net.connect("cond", "cur", nv.AllToAllConnector(), nv.StaticSynapse(weight=0.8, delay=0.3), receptor_type="inhibitory")
    spikes = {}
    for backend in (reference, NEST):
        sim = backend.compile(net, dt=0.1, seed=2)
        sim.run(80.0)
        spikes[backend.name] = {pop: sim.spike_trains(pop) for pop in ("cur", "cond")}
        if backend is not NEST:
            continue
        for name in net.projections:
            want = expand(net, name, dt=0.1, seed=2)
            pre, post = sim.connections(name)
            np.testing.assert_array_equal(pre, want.pre)
            np.testing.assert_array_equal(post, want.post)
            np.testing.assert_allclose(sim.weights(name, format="list"), want.weight, rtol=1e-12, err_msg=name)
        made = nest.GetConnections(synapse_model=sim._built.parts[0].projection.nest_synapse_model)
        assert len(made) == sum(len(expand(net, name, dt=0.1, seed=2).pre) for name in net.projections)
        delays = sorted(np.atleast_1d(nest.GetConnections(target=sim._built.populations["cur"].node_collection).get("delay")))
        assert sorted(np.round(delays, 6)) == sorted(np.round(np.concatenate([rows[:, 3], np.full(12, 0.3)]), 6))
        sim.set_weights("cond->cur", np.full(12, 0.5))
        sim.close()
        np.testing.assert_array_equal(sim.weights("cond->cur"), np.full((3, 4), 0.5))
    assert spikes["reference"]["cur"][0].size > 3
    for pop in ("cur", "cond"):
        np.testing.assert_array_equal(spikes["pynn"][pop][1], spikes["reference"][pop][1], err_msg=pop)
        np.testing.assert_allclose(spikes["pynn"][pop][0], spikes["reference"][pop][0], rtol=0, atol=1e-9)


def test_nest_threads_give_the_same_spikes_and_weights() -> None:
    """``threads=2`` runs NEST on two threads with the one-thread run's spikes and learned weights."""
    _needs(NEST)
    net = _input_network()
    net.connect("inp", "inh", nv.AllToAllConnector(), _stdp(), name="plastic")
    out = {}
    for threads in (1, 2):
        sim = NEST.compile(net, dt=0.1, seed=4, threads=threads)
        sim.run(120.0)
        out[threads] = ({p: sim.spike_trains(p) for p in ("exc", "inh")}, sim.weights("plastic", format="list"))
        sim.close()
    for pop in ("exc", "inh"):
        for k in (0, 1):
            np.testing.assert_array_equal(out[2][0][pop][k], out[1][0][pop][k], err_msg=pop)
    assert out[1][0]["inh"][0].size > 0
    np.testing.assert_array_equal(out[2][1], out[1][1])
    for bad in (0, 1.5, True):
        with pytest.raises(nv.ValidationError, match="threads"):
            NEST.compile(net, dt=0.1, seed=4, threads=bad)
    with pytest.raises(nv.ValidationError, match="needs NEST"):
        BRIAN2.compile(net, dt=0.1, seed=4, threads=2)


def test_nest_statistics_count_plastic_updates_and_survive_reset() -> None:
    """One pre and one post spike on one plastic connection: 2 plastic updates; reset() keeps the totals."""
    _needs(NEST)
    sim = NEST.compile(_pair_network([10.0], [20.0]), dt=0.1, seed=1)
    built = sim.statistics()["build_wall_ns"]
    sim.run(40.0)
    first = sim.statistics()
    timing = {key: first.pop(key) for key in ("run_wall_ns", "build_wall_ns")}
    assert first == {"steps": 400, "neuron_updates": 400, "spikes": 3, "synaptic_events": 2, "plastic_updates": 2}
    # wall time: building at compile, NEST's run; a reset rebuilds (counted as building, not running)
    assert timing["build_wall_ns"] == built > 0 and timing["run_wall_ns"] > 0
    sim.reset()
    rebuilt = sim.statistics()
    assert rebuilt["build_wall_ns"] > built and rebuilt["run_wall_ns"] == timing["run_wall_ns"]
    sim.run(40.0)
    again = sim.statistics()
    assert {key: again[key] for key in first} == {key: 2 * value for key, value in first.items()}
    assert again["run_wall_ns"] > timing["run_wall_ns"]
    sim.close()
    assert sim.statistics()["spikes"] == 6


def test_nest_stdp_pair_and_deferred_potentiation() -> None:
    """One pre-before-post pair changes the weight by A_plus w_max exp(-dt_pair / tau_plus).

    NEST pairs with the delay taken as dendritic (compensated in the amplitudes) and
    applies the potentiation only at the next presynaptic spike; the weight read after
    the run includes it. With plasticity off the weight stays.
    """
    _needs(NEST)
    sim = NEST.compile(_pair_network([10.0], [20.0]), dt=0.1, seed=1)
    sim.run(40.0)
    pre, post = sim.spike_trains("pre")[0], sim.spike_trains("post")[0]
    assert pre.tolist() == [10.0] and post.size == 1
    dt_pair = round((post[0] - (pre[0] + 1.5)) / 0.1) * 0.1
    expected = 0.5 + 0.05 * math.exp(-dt_pair / 16.8)
    assert sim.weights("plastic", format="list")[0] == pytest.approx(expected, rel=1e-12)

    frozen = NEST.compile(_pair_network([10.0, 30.0], [20.0]), dt=0.1, seed=1)
    frozen.plasticity(False)
    frozen.run(40.0)
    assert frozen.weights("plastic", format="list")[0] == 0.5


def test_nest_reset_carries_learned_and_set_weights_over() -> None:
    """reset() keeps what learning changed (read back from NEST) and what set_weights wrote (without reading back)."""
    _needs(NEST)
    sim = NEST.compile(_pair_network([10.0, 30.0], [20.0]), dt=0.1, seed=1)
    sim.run(40.0)
    learned = sim.weights("plastic", format="list")
    assert learned[0] != 0.5  # potentiated by the pair
    sim.reset()
    np.testing.assert_array_equal(sim.weights("plastic", format="list"), learned)
    sim.plasticity(False)
    sim.set_weights("plastic", [0.3])
    sim.run(40.0)
    sim.reset()
    assert sim.weights("plastic", format="list").tolist() == [0.3]
    sim.run(40.0)
    assert sim.weights("plastic", format="list").tolist() == [0.3] and sim.spike_counts("post").sum() == 1
    sim.close()


def test_one_live_pynn_simulation_per_process() -> None:
    """A second compile takes PyNN over; the first keeps its results readable and refuses to run."""
    _needs(NEST)
    first = NEST.compile(_input_network(), dt=0.1, seed=4)
    first.run(50.0)
    counts = first.spike_counts("exc")
    second = NEST.compile(_input_network(), dt=0.1, seed=4)
    with pytest.raises(SimulationError, match="PyNN runs one simulation per process"):
        first.run(10.0)
    with pytest.raises(SimulationError, match="closed"):
        first.reset()
    np.testing.assert_array_equal(first.spike_counts("exc"), counts)
    second.run(50.0)
    np.testing.assert_array_equal(second.spike_counts("exc"), counts)
    second.close()


def test_nest_reset_and_later_runs() -> None:
    """reset() rebuilds with the current weights; a later run delivers early source spikes late, counted."""
    _needs(NEST)
    net = _input_network()
    sim = NEST.compile(net, dt=0.1, seed=4)
    sim.record("inh", "v")
    sim.run(60.0)
    first = sim.spike_trains("exc")
    sim.set_weights("inh->exc", np.full((5, 10), 0.5))
    sim.reset()
    assert sim.time == 0.0 and sim.spike_counts("exc").sum() == 0 and sim.trace("inh", "v")[0].size == 0
    np.testing.assert_array_equal(sim.weights("inh->exc"), 0.5)
    sim.run(60.0)
    assert sim.trace("inh", "v")[1].shape == (600, 5)
    assert not np.array_equal(first[0], sim.spike_trains("exc")[0])  # weaker inhibition, other spikes

    late = nv.Network("late")
    late.add_population("src", 1, nv.SpikeSourceArray.from_lists([[0.0, 10.0, 10.1]]))
    sim = NEST.compile(late, dt=0.1, seed=1)
    sim.run(10.0)
    sim.run(10.0)
    assert sim.late_source_spikes == 2  # 10.0 and 10.1 leave at 10.3: NEST is ahead after the first run
    np.testing.assert_allclose(sim.spike_trains("src")[0], [0.0, 10.3, 10.3])
    sim.close()


# -- Brian2 -----------------------------------------------------------------------
def test_brian2_run_equals_reference() -> None:
    """pyNN.brian2 (numpy target) gives the reference backend's spikes, membrane and learned weights.

    The plastic projection ends on a read-out population whose spikes a strong drive
    forces, so that its learned weights are compared on identical spike trains.
    """
    _needs(BRIAN2)
    reference = pytest.importorskip("neurovpr.backends.reference").BACKEND
    net = _input_network()
    net.add_population("drive", 4, nv.SpikeSourceArray.from_lists([[20.0, 55.0], [30.0], [41.0, 80.0], [66.0]]))
    net.add_population("readout", 4, nv.IF_curr_exp(tau_syn_E=1.0, tau_refrac=5.0))
    net.connect("drive", "readout", nv.OneToOneConnector(), nv.StaticSynapse(weight=100.0), name="drive")
    net.connect("inp", "readout", nv.AllToAllConnector(), nv.STDPMechanism(
        timing_dependence=nv.SpikePairRule(tau_plus=10.0, tau_minus=12.0, A_plus=0.1, A_minus=0.12),
        weight_dependence=nv.MultiplicativeWeightDependence(w_min=0.0, w_max=0.05), weight=0.02, delay=0.3,
    ), name="plastic")
    results = {}
    for backend in (reference, BRIAN2):
        sim = backend.compile(net, dt=0.1, seed=4)
        sim.record("inh", "v", neurons=[0, 3])
        sim.run(100.0)
        results[backend.name] = (
            {pop: sim.spike_trains(pop) for pop in ("exc", "inh", "readout")},
            sim.trace("inh", "v")[1],
            sim.weights("plastic", format="list"),
        )
    (ref_spikes, ref_v, ref_w), (b2_spikes, b2_v, b2_w) = results["reference"], results["pynn:brian2"]
    assert ref_spikes["readout"][0].size == 6
    for pop in ("exc", "inh", "readout"):
        np.testing.assert_array_equal(b2_spikes[pop][1], ref_spikes[pop][1], err_msg=pop)
        np.testing.assert_allclose(b2_spikes[pop][0], ref_spikes[pop][0], atol=1e-9, err_msg=pop)
    np.testing.assert_allclose(b2_v, ref_v, rtol=0, atol=1e-9)  # conductance-based: the same step
    assert np.sum(ref_w > 0.0201) > 5 and np.sum(ref_w < 0.0199) > 5
    np.testing.assert_allclose(b2_w, ref_w, rtol=1e-9, atol=1e-15)


def test_brian2_refuses_two_spikes_of_one_source_in_one_step() -> None:
    _needs(BRIAN2)
    net = nv.Network("doubled")
    net.add_population("src", 1, nv.SpikeSourceArray.from_lists([[1.0, 1.04]]))
    sim = BRIAN2.compile(net, dt=0.1, seed=1)
    with pytest.raises(SimulationError, match=r"neuron 0 of 'src' has several spikes at 1 ms"):
        sim.run(5.0)
    sim.close()
