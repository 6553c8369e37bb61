"""The brian2 backend: declaration, errors, every IR type, and agreement with the reference backend.

The agreement tests drive both backends with explicit spike times (``SpikeSourceArray``),
so there is no randomness after connectivity, and compare spike trains, traces, weights,
adaptive thresholds and activity counts. The brian2 backend integrates as
docs/semantics.md prescribes, so they agree to floating-point round-off.
"""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

import neurovpr as nv
from neurovpr.errors import BackendUnavailableError, UnsupportedFeatureError, ValidationError
from neurovpr.paths import cache_dir

pytest.importorskip("brian2")

from neurovpr.backends.brian2 import BACKEND
from neurovpr.backends.brian2.translation import TAU_SEPARATION
from neurovpr.backends.reference import BACKEND as REFERENCE

DT = 0.5


def _trains(rng: np.random.Generator, n: int, t_max: float, dt: float = DT) -> nv.SpikeSourceArray:
    """``n`` sorted spike trains on the grid, at most one spike per neuron and step."""
    steps = int(t_max / dt)
    return nv.SpikeSourceArray.from_lists(
        [np.sort(rng.choice(np.arange(1, steps), size=rng.integers(2, 10), replace=False)) * dt for _ in range(n)]
    )


def _both(net: nv.Network, drive, *, dt: float = DT, seed: int = 3, **options) -> dict:
    """Compile ``net`` on brian2 and the reference backend and apply ``drive`` to each."""
    sims = {
        "brian2": BACKEND.compile(net, dt=dt, seed=seed, **options),
        "reference": REFERENCE.compile(net, dt=dt, seed=seed),
    }
    for sim in sims.values():
        drive(sim)
    return sims


def _assert_same_trains(a: nv.Simulation, b: nv.Simulation, populations) -> None:
    for pop in populations:
        (ta, ia), (tb, ib) = a.spike_trains(pop), b.spike_trains(pop)
        assert ta.size == tb.size, f"{pop}: {ta.size} spikes on brian2, {tb.size} on reference"
        np.testing.assert_array_equal(ia, ib, err_msg=pop)
        np.testing.assert_allclose(ta, tb, rtol=0, atol=1e-9, err_msg=pop)
        np.testing.assert_array_equal(a.spike_counts(pop), b.spike_counts(pop), err_msg=pop)


# -- declaration and errors --------------------------------------------------------------------
def test_importing_the_backend_does_not_import_brian2() -> None:
    code = "import sys, neurovpr.backends.brian2 as b; assert 'brian2' not in sys.modules; print(b.BACKEND.name)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "brian2"


def test_declaration() -> None:
    import brian2

    assert (BACKEND.name, BACKEND.requires, BACKEND.extra) == ("brian2", ("brian2",), "brian2")
    assert BACKEND.unavailable_reason() is None
    assert BACKEND.version() == brian2.__version__
    caps = BACKEND.capabilities
    assert caps.learns and caps.runs and caps.heterogeneous_delays
    assert caps.cell_types == frozenset(nv.ir.cells.CELL_TYPES) - {"SoftLIF"}
    assert caps.connectors == frozenset(nv.ir.connectors.CONNECTORS)
    assert caps.synapses == {"StaticSynapse", "STDPMechanism", "DiehlCookSTDP"}
    assert dict(caps.unsupported) == {}


def test_missing_simulator_names_the_extra() -> None:
    missing = type(BACKEND)()
    missing.requires = ("neurovpr_no_such_simulator",)
    net = nv.Network("n")
    net.add_population("a", 1, nv.IF_curr_exp())
    with pytest.raises(BackendUnavailableError, match=r"pip install 'neurovpr\[brian2\]'"):
        missing.compile(net, dt=0.1, seed=1)


def test_bad_options_and_features_are_named() -> None:
    net = nv.Network("n")
    net.add_population("a", 1, nv.IF_curr_exp())
    with pytest.raises(ValidationError, match=r"^Backend 'brian2' has no option 'device' \(options: target\)\.$"):
        BACKEND.compile(net, dt=0.1, seed=1, device="cuda")
    with pytest.raises(ValidationError, match=r"target must be one of 'numpy', 'cython', got 'cpp_standalone'"):
        BACKEND.compile(net, dt=0.1, seed=1, target="cpp_standalone")
    soft = nv.Network("s")
    soft.add_population("rate", 3, nv.SoftLIF())
    with pytest.raises(UnsupportedFeatureError, match=r"^Backend 'brian2' cannot run cell type SoftLIF"):
        BACKEND.compile(soft, dt=0.1, seed=1)


def test_two_spikes_of_one_neuron_in_a_step_are_refused() -> None:
    net = nv.Network("n")
    net.add_population("src", 2, nv.SpikeSourceArray.from_lists([[1.0], [2.0, 2.1]]))
    with pytest.raises(UnsupportedFeatureError, match=r"neuron 1 has two spikes in the step at 2 ms"):
        BACKEND.compile(net, dt=0.5, seed=1)
    sim = BACKEND.compile(net, dt=0.1, seed=1)
    with pytest.raises(UnsupportedFeatureError, match=r"neuron 0 has two spikes"):
        sim.run(5.0, inputs={"src": [[3.0, 3.04], [4.0]]})
    sim.run(5.0)  # the previous spike times are kept
    assert sim.spike_counts("src").tolist() == [1, 2]


# -- agreement with the reference backend ----------------------------------------------------------
def _static_network(rng: np.random.Generator, integration: str = "exact") -> nv.Network:
    net = nv.Network("static")
    net.add_population("src", 30, _trains(rng, 30, 100.0))
    net.add_population("cur", 16, nv.IF_curr_exp(tau_syn_E=3.0, tau_refrac=1.0), v_init=-60.0)
    net.add_population("ca", 5, nv.IF_curr_exp_ca2_adaptive(tau_ca2=30.0, i_alpha=0.2, i_offset=0.1))
    exc = nv.IF_cond_exp_adaptive(theta_plus=0.5, tau_theta=200.0, tau_refrac=2.0, v_thresh=-55.0, integration=integration)
    net.add_population("exc", 8, exc)
    tau_m = np.linspace(8.0, 12.0, 8)
    net.add_population("inh", 8, nv.IF_cond_exp(tau_m=tau_m, v_rest=-60.0, e_rev_I=-85.0, integration=integration))
    net.add_population("conv", 2 * 3 * 4, nv.IF_curr_exp(tau_syn_E=2.0))
    net.connect("src", "cur", nv.FixedNumberPreConnector(n=nv.Normal(mu=5, sigma=1)), nv.StaticSynapse(weight=2.0))
    net.connect(
        "cur",
        "cur",
        nv.FixedProbabilityConnector(p_connect=0.3),
        nv.StaticSynapse(weight=0.5, delay=nv.Uniform(low=0.5, high=2.0)),
    )
    net.connect("src", "cur", nv.AllToAllConnector(), nv.StaticSynapse(weight=-0.2), name="signed")
    rows = np.array([[15, 4, 3.0, 1.0], [0, 0, 1.0, 1.0], [0, 0, 2.0, 2.0], [3, 1, 0.5, 0.5]])
    net.connect("cur", "ca", nv.FromListConnector(conn_list=rows), nv.StaticSynapse())
    net.connect("src", "ca", nv.AllToAllConnector(), nv.StaticSynapse(weight=0.05), receptor_type="inhibitory")
    net.connect("src", "exc", nv.AllToAllConnector(), nv.StaticSynapse(weight=nv.Uniform(low=0.0, high=0.3), delay=1.5))
    net.connect("exc", "inh", nv.OneToOneConnector(), nv.StaticSynapse(weight=10.4))
    net.connect(
        "inh", "exc", nv.AllToAllConnector(allow_self_connections=False), nv.StaticSynapse(weight=1.0), receptor_type="inhibitory"
    )
    kernel = rng.uniform(0.0, 3.0, size=(2, 1, 3, 3))
    conv = nv.ConvolutionConnector(input_shape=(1, 5, 6), kernel_shape=(3, 3), out_channels=2, stride=(1, 1))
    net.connect("src", "conv", conv, nv.StaticSynapse(weight=kernel, delay=1.0))
    return net


RECORDED = [
    ("cur", "v"),
    ("cur", "isyn_exc"),
    ("cur", "isyn_inh"),
    ("ca", "v"),
    ("ca", "i_ca2"),
    ("exc", "v"),
    ("exc", "gsyn_exc"),
    ("exc", "gsyn_inh"),
    ("exc", "theta"),
    ("inh", "gsyn_exc"),
]


@pytest.mark.parametrize("integration", ["exact", "euler"])
def test_static_network_matches_reference(integration: str) -> None:
    """Every neuron model and connector, signed and inhibitory weights, run in pieces; the conductance-based
    populations with exact or forward-Euler steps (Brian2's ``euler``)."""
    net = _static_network(np.random.default_rng(0), integration)

    def drive(sim: nv.Simulation) -> None:
        for pop, var in RECORDED:
            sim.record(pop, var)
        sim.run(40.0)
        sim.run(60.0)

    sims = _both(net, drive)
    a, b = sims["brian2"], sims["reference"]
    _assert_same_trains(a, b, net.populations)
    for pop, var in RECORDED:
        (ta, va), (tb, vb) = a.trace(pop, var), b.trace(pop, var)
        np.testing.assert_allclose(ta, tb, rtol=0, atol=1e-9)
        np.testing.assert_allclose(va, vb, rtol=0, atol=1e-9 * max(1.0, np.abs(vb).max()), err_msg=f"{pop}.{var}")
    assert a.trace("cur", "v")[0][:3].tolist() == [0.5, 1.0, 1.5]
    for name in net.projections:
        np.testing.assert_array_equal(a.connections(name)[0], b.connections(name)[0])
        np.testing.assert_array_equal(a.weights(name, format="list"), b.weights(name, format="list"))
    np.testing.assert_allclose(a.learned_state("exc")["theta"], b.learned_state("exc")["theta"], atol=1e-12)
    assert a.statistics() == b.statistics()
    assert a.spike_counts("conv").sum() > 0 and a.spike_counts("exc").sum() > 0 and a.spike_counts("ca").sum() > 0


def _plastic_network(rng: np.random.Generator) -> nv.Network:
    net = nv.Network("plastic")
    net.add_population("src", 30, _trains(rng, 30, 100.0))
    net.add_population("exc", 10, nv.IF_cond_exp_adaptive(theta_plus=0.5, tau_theta=200.0, tau_refrac=2.0, v_thresh=-55.0))
    net.add_population("cur", 16, nv.IF_curr_exp(tau_syn_E=3.0, tau_refrac=1.0))
    dc = nv.DiehlCookSTDP(weight=nv.Uniform(low=0.0, high=0.3), eta_pre=1e-3, eta_post=5e-2, delay=nv.Uniform(low=0.5, high=3.0))
    net.connect("src", "exc", nv.AllToAllConnector(), dc, name="dc")
    triplet = dc.replace(tau_post2=30.0, mu=0.0, weight=0.1, delay=1.0)
    net.connect("src", "exc", nv.FixedProbabilityConnector(p_connect=0.2), triplet, name="triplet")
    mult = nv.STDPMechanism(
        timing_dependence=nv.SpikePairRule(tau_plus=10.0, tau_minus=5.0, A_plus=0.05, A_minus=0.06),
        weight_dependence=nv.MultiplicativeWeightDependence(w_min=0.0, w_max=3.0),
        weight=2.0,
        delay=1.5,
    )
    net.connect("src", "cur", nv.FixedNumberPreConnector(n=5), mult, name="mult")
    add = nv.STDPMechanism(
        timing_dependence=nv.SpikePairRule(),
        weight_dependence=nv.AdditiveWeightDependence(w_min=0.0, w_max=1.0),
        weight=0.5,
        delay=nv.Uniform(low=0.5, high=2.0),
    )
    net.connect("cur", "cur", nv.FixedProbabilityConnector(p_connect=0.3), add, name="add")
    return net


def test_plasticity_matches_reference_through_pieces_switches_and_reset() -> None:
    """All four rules, heterogeneous delays, split runs, plasticity off and reset()."""
    net = _plastic_network(np.random.default_rng(1))

    def drive(sim: nv.Simulation) -> None:
        sim.run(30.0)
        sim.run(30.0)
        sim.plasticity(False)
        sim.run(20.0)
        sim.plasticity(True)
        sim.reset()
        sim.run(100.0)

    sims = _both(net, drive)
    a, b = sims["brian2"], sims["reference"]
    _assert_same_trains(a, b, net.populations)
    for name in net.projections:
        wa, wb = a.weights(name, format="list"), b.weights(name, format="list")
        np.testing.assert_allclose(wa, wb, rtol=0, atol=1e-12, err_msg=name)
        assert not np.array_equal(wa, nv.expand(net, name, dt=DT, seed=3).weight), f"{name} did not learn"
    np.testing.assert_allclose(a.learned_state("exc")["theta"], b.learned_state("exc")["theta"], atol=1e-12)
    assert a.statistics() == b.statistics()
    assert a.statistics()["plastic_updates"] > 0


def test_split_run_equals_one_run_with_spikes_at_the_boundary() -> None:
    """Spikes found in a run's last step are delivered in the next run (Brian2 clears them)."""
    net = nv.Network("b")
    net.add_population("src", 1, nv.SpikeSourceArray.from_lists([[9.0]]))
    net.add_population("a", 1, nv.IF_curr_exp(tau_refrac=5.0))
    net.add_population("b", 3, nv.IF_curr_exp(tau_refrac=5.0))
    net.connect("src", "a", nv.AllToAllConnector(), nv.StaticSynapse(weight=50.0, delay=0.5))
    net.connect("a", "b", nv.AllToAllConnector(), nv.StaticSynapse(weight=50.0, delay=np.array([0.5, 1.5, 3.0])))
    whole = BACKEND.compile(net, dt=DT, seed=1)
    whole.run(20.0)
    split = BACKEND.compile(net, dt=DT, seed=1)
    split.run(10.0)
    assert split.spike_trains("a")[0].tolist() == [10.0]  # found in the last step of the first run
    split.run(10.0)
    for name in ("a", "b"):
        np.testing.assert_array_equal(split.spike_trains(name)[0], whole.spike_trains(name)[0])
        np.testing.assert_array_equal(split.spike_trains(name)[1], whole.spike_trains(name)[1])
    t, i = whole.spike_trains("b")
    assert [t[i == k][0] for k in range(3)] == [11.0, 12.0, 13.5]


def test_degenerate_time_constants() -> None:
    """tau_syn == tau_m for a whole population is exact; for some neurons it is within TAU_SEPARATION."""
    net = nv.Network("eq")
    net.add_population("src", 1, nv.SpikeSourceArray.from_lists([[1.0]]))
    net.add_population("same", 1, nv.IF_curr_exp(tau_m=10.0, tau_syn_E=10.0, tau_syn_I=10.0))
    net.add_population("some", 3, nv.IF_curr_exp(tau_m=10.0, tau_syn_E=np.array([10.0, 5.0, 10.0 + 1e-9])))
    net.add_population("ca", 1, nv.IF_curr_exp_ca2_adaptive(tau_m=10.0, tau_ca2=10.0, i_ca2=1.0))
    for post in ("same", "some"):
        net.connect("src", post, nv.AllToAllConnector(), nv.StaticSynapse(weight=1.0), name=f"e_{post}")
    net.connect("src", "same", nv.AllToAllConnector(), nv.StaticSynapse(weight=0.5), receptor_type="inhibitory")

    def drive(sim: nv.Simulation) -> None:
        for pop in ("same", "some", "ca"):
            sim.record(pop, "v")
        sim.run(30.0)

    with pytest.warns(UserWarning, match=r"Population 'some': tau_syn_E equals tau_m for some neurons only"):
        sims = _both(net, drive, dt=0.1)
    for pop, tol in (("same", 1e-12), ("some", 10 * TAU_SEPARATION), ("ca", 1e-12)):
        va, vb = sims["brian2"].trace(pop, "v")[1], sims["reference"].trace(pop, "v")[1]
        psp = np.abs(vb - vb[0]).max()
        assert psp > 0.1
        np.testing.assert_allclose(va, vb, rtol=0, atol=tol * psp, err_msg=pop)


# -- behaviour on its own ------------------------------------------------------------------------
def test_connections_weights_and_set_weights() -> None:
    net = nv.Network("w")
    net.add_population("a", 4, nv.SpikeSourcePoisson(rate=0.0))
    net.add_population("b", 3, nv.IF_cond_exp())
    rows = np.array([[3, 2, 0.3], [0, 1, 0.1], [3, 2, 0.2], [1, 0, 0.4]])  # not sorted, one pair twice
    net.connect("a", "b", nv.FromListConnector(conn_list=rows), nv.StaticSynapse(), name="list")
    net.connect("a", "b", nv.AllToAllConnector(), nv.DiehlCookSTDP(weight=0.5), name="dc")
    sim = BACKEND.compile(net, dt=0.1, seed=2)
    pre, post = sim.connections("list")
    assert pre.tolist() == [3, 0, 3, 1] and post.tolist() == [2, 1, 2, 0]
    assert sim.weights("list", format="list").tolist() == [0.3, 0.1, 0.2, 0.4]
    sim.set_weights("list", np.array([1.0, 2.0, 3.0, 4.0]))
    assert sim.weights("list", format="list").tolist() == [1.0, 2.0, 3.0, 4.0]
    dense = np.arange(12.0).reshape(4, 3) / 12.0
    sim.set_weights("dc", dense)
    np.testing.assert_array_equal(sim.weights("dc"), dense)
    with pytest.raises(ValidationError, match="must lie in"):
        sim.set_weights("dc", dense * 2.0)
    saved = sim.to_network()
    np.testing.assert_array_equal(saved.projections["dc"].synapse.weight, dense.ravel())


def test_poisson_rates_window_and_determinism() -> None:
    n = 200
    net = nv.Network("p")
    net.add_population("always", n, nv.SpikeSourcePoisson(rate=50.0))
    net.add_population("window", n, nv.SpikeSourcePoisson(rate=400.0, start=20.0, duration=30.0))
    net.add_population("out", 1, nv.IF_curr_exp())
    net.connect("always", "out", nv.AllToAllConnector(), nv.StaticSynapse(weight=0.01))

    def trains(seed: int) -> list[np.ndarray]:
        sim = BACKEND.compile(net, dt=1.0, seed=seed)
        sim.run(60.0)
        sim.run(40.0, inputs={"always": np.linspace(0.0, 100.0, n)})
        t, i = sim.spike_trains("window")
        assert t.size and t.min() >= 20.0 and t.max() < 50.0 and np.all(t == np.round(t))
        t2, i2 = sim.spike_trains("always")
        first = np.bincount(i2[t2 < 60.0], minlength=n)
        assert abs(first.sum() - n * 50.0 * 0.06) < 5 * np.sqrt(n * 3.0)  # mean within 5 sigma
        late = np.bincount(i2[t2 >= 60.0], minlength=n)
        assert late[0] == 0 and late[n // 2 :].sum() > late[: n // 2].sum()
        return [t, i, t2, i2]

    one, same, other = trains(5), trains(5), trains(6)
    for x, y in zip(one, same, strict=True):
        np.testing.assert_array_equal(x, y)
    assert not np.array_equal(one[2], other[2])


def test_reset_keeps_weights_and_theta_and_clears_the_rest() -> None:
    net = nv.Network("r")
    net.add_population("src", 5, nv.SpikeSourceArray.from_lists([[1.0, 4.0], [2.0], [3.0], [5.0], [6.0]]))
    net.add_population("exc", 2, nv.IF_cond_exp_adaptive(i_offset=0.3, theta_plus=1.0, tau_theta=100.0))
    net.connect("src", "exc", nv.AllToAllConnector(), nv.DiehlCookSTDP(weight=0.5, eta_pre=0.01, eta_post=0.1), name="p")
    sim = BACKEND.compile(net, dt=0.1, seed=1)
    sim.record("exc", "v")
    sim.run(40.0)
    w, theta = sim.weights("p"), sim.learned_state("exc")["theta"]
    assert theta.min() > 0 and sim.spike_counts("exc").sum() > 0
    sim.reset()
    assert sim.time == 0.0 and sim.spike_counts("exc").sum() == 0 and sim.spike_counts("src").sum() == 0
    assert sim.trace("exc", "v")[1].shape == (0, 2)
    np.testing.assert_array_equal(sim.weights("p"), w)
    np.testing.assert_array_equal(sim.learned_state("exc")["theta"], theta)
    sim.run(10.0)
    assert sim.spike_trains("src")[0].tolist() == [1.0, 2.0, 3.0, 4.0, 5.0, 6.0]
    times, v = sim.trace("exc", "v")
    assert times[0] == 0.1 and v.shape == (100, 2) and abs(v[0, 0] - (-65.0)) < 0.1


def test_cython_target_equals_numpy() -> None:
    """One small network on the cython target (compiled once into the project cache, then reused)."""
    net = nv.Network("cy")
    net.add_population("src", 20, nv.SpikeSourcePoisson(rate=80.0))
    net.add_population("n", 3, nv.IF_curr_exp())
    net.connect("src", "n", nv.AllToAllConnector(), nv.StaticSynapse(weight=1.0))
    runs = {}
    for target in ("numpy", "cython"):
        sim = BACKEND.compile(net, dt=0.1, seed=4, target=target)
        sim.record("n", "v")
        sim.run(20.0)
        runs[target] = (*sim.spike_trains("src"), *sim.spike_trains("n"), sim.trace("n", "v")[1])
    assert runs["cython"][0].size > 0
    for x, y in zip(runs["numpy"], runs["cython"], strict=True):
        np.testing.assert_allclose(x, y, rtol=0, atol=1e-9)
    assert any(cache_dir("brian2").glob("_cython_magic_*"))


@pytest.mark.slow
def test_cython_target_matches_reference() -> None:
    """The static and plastic agreement networks on the cython target."""
    rng = np.random.default_rng(0)
    net = _static_network(rng)

    def drive(sim: nv.Simulation) -> None:
        sim.run(40.0)
        sim.run(60.0)

    sims = _both(net, drive, target="cython")
    _assert_same_trains(sims["brian2"], sims["reference"], net.populations)
    plastic = _plastic_network(np.random.default_rng(1))
    sims = _both(plastic, drive, target="cython")
    _assert_same_trains(sims["brian2"], sims["reference"], plastic.populations)
    for name in plastic.projections:
        np.testing.assert_allclose(
            sims["brian2"].weights(name, format="list"), sims["reference"].weights(name, format="list"), atol=1e-12
        )
