"""The graph IR: validation messages, immutability, equality and connection expansion."""

from __future__ import annotations

import dataclasses
import re

import numpy as np
import pytest
from scipy.signal import correlate2d

import neurovpr as nv
from neurovpr.errors import ValidationError
from neurovpr.ir.connectivity import projection_rng


def _raises(message: str) -> pytest.RaisesContext:
    """Expect a ValidationError whose message is exactly ``message``."""
    return pytest.raises(ValidationError, match="^" + re.escape(message) + "$")


@pytest.fixture
def net() -> nv.Network:
    net = nv.Network("n")
    net.add_population("src", 2, nv.SpikeSourcePoisson(rate=10.0))
    net.add_population("curr", 3, nv.IF_curr_exp())
    net.add_population("cond", 3, nv.IF_cond_exp())
    return net


# -- construction-time validation ------------------------------------------------------------
def test_negative_time_constant() -> None:
    with _raises("IF_curr_exp.tau_m must be > 0.0 ms, got -1.0."):
        nv.IF_curr_exp(tau_m=-1.0)
    with _raises("IF_cond_exp_adaptive.tau_theta must be > 0.0 ms, got 0.0."):
        nv.IF_cond_exp_adaptive(tau_theta=0.0)
    with _raises("IF_cond_exp_adaptive.tau_lockout must be >= 0.0 ms, got -1.0 (element 1)."):
        nv.IF_cond_exp_adaptive(tau_lockout=np.array([50.0, -1.0]))
    assert nv.IF_cond_exp_adaptive().tau_lockout == 0.0  # default: the clamp alone, as before the lockout existed
    with _raises("DiehlCookSTDP.pre_term must be one of 'depress', 'potentiate', got 'both'."):
        nv.DiehlCookSTDP(weight=0.1, pre_term="both")
    with _raises("IF_curr_exp.tau_syn_E must be > 0.0 ms, got -2.0 (element 1)."):
        nv.IF_curr_exp(tau_syn_E=np.array([1.0, -2.0]))
    with _raises("SpikeSourcePoisson.rate must be >= 0.0 Hz, got -5.0."):
        nv.SpikeSourcePoisson(rate=-5.0)
    with _raises("IF_curr_exp.cm must be a finite number, got nan."):
        nv.IF_curr_exp(cm=float("nan"))


def test_reset_must_lie_below_threshold() -> None:
    with _raises("IF_cond_exp.v_reset (-50.0 mV) must be below v_thresh (-50.0 mV)."):
        nv.IF_cond_exp(v_reset=-50.0, v_thresh=-50.0)
    with _raises("IF_curr_exp.v_reset (-40.0 mV) must be below v_thresh (-50.0 mV)."):
        nv.IF_curr_exp(v_reset=-40.0)
    with pytest.raises(ValidationError, match=r"^IF_curr_exp\.v_reset .* must be below v_thresh \(-50\.0 mV\)\.$"):
        nv.IF_curr_exp(v_reset=np.array([-60.0, -45.0]))
    nv.IF_curr_exp(v_reset=np.array([-60.0, -55.0]))  # every neuron below threshold is fine


def test_per_neuron_array_length_must_match_population(net: nv.Network) -> None:
    with _raises("Population 'p': IF_curr_exp.tau_m has 2 values for 3 neurons."):
        net.add_population("p", 3, nv.IF_curr_exp(tau_m=np.array([10.0, 20.0])))
    with _raises("Population 'q': SpikeSourceArray.spike_times has 1 values for 2 neurons."):
        net.add_population("q", 2, nv.SpikeSourceArray.from_lists([[1.0]]))
    with _raises("Population 'r': v_init must be a finite number or 3 finite values."):
        net.add_population("r", 3, nv.IF_curr_exp(), v_init=np.zeros(4))
    with _raises("Population 's': v_init applies to neurons only, not to sources."):
        net.add_population("s", 3, nv.SpikeSourcePoisson(), v_init=-60.0)
    with _raises("Population 'x': size must be an integer >= 1, got 0."):
        net.add_population("x", 0, nv.IF_curr_exp())
    assert list(net.populations) == ["src", "curr", "cond"]


def test_connect_to_unknown_population(net: nv.Network) -> None:
    with _raises("Projection 'curr->zz': post population 'zz' does not exist (known: src, curr, cond)."):
        net.connect("curr", "zz", nv.AllToAllConnector())
    with _raises("Projection 'nope->curr': pre population 'nope' does not exist (known: src, curr, cond)."):
        net.connect("nope", "curr", nv.AllToAllConnector())
    with _raises("Projection 'curr->src': post population 'src' is a spike source and cannot receive input."):
        net.connect("curr", "src", nv.AllToAllConnector())
    assert len(net.projections) == 0


def test_one_to_one_needs_equal_sizes(net: nv.Network) -> None:
    with _raises("Projection 'src->curr': OneToOneConnector needs equal sizes, got 2 and 3."):
        net.connect("src", "curr", nv.OneToOneConnector())
    net.connect("curr", "cond", nv.OneToOneConnector())


def test_negative_weights_only_onto_excitatory_current_receptors(net: nv.Network) -> None:
    with _raises(
        "Projection 'src->cond': weights onto a conductance-based receptor must be >= 0 "
        "(the receptor type gives the sign), got -0.1."
    ):
        net.connect("src", "cond", nv.AllToAllConnector(), nv.StaticSynapse(weight=-0.1))
    with _raises(
        "Projection 'src->curr': weights onto an inhibitory receptor must be >= 0 (the receptor type gives the sign), got -2.0."
    ):
        net.connect(
            "src",
            "curr",
            nv.AllToAllConnector(),
            nv.StaticSynapse(weight=np.array([[1.0, -2.0, 0.0]] * 2)),
            receptor_type="inhibitory",
        )
    with _raises(
        "Projection 'src->cond': weights onto a conductance-based receptor must be >= 0 "
        "(the receptor type gives the sign), got Normal with low=-inf."
    ):
        net.connect("src", "cond", nv.AllToAllConnector(), nv.StaticSynapse(weight=nv.Normal(mu=1.0, sigma=0.1)))
    with _raises(
        "Projection 'src->cond': weights onto a conductance-based receptor must be >= 0 "
        "(the receptor type gives the sign), got -1.0."
    ):
        net.connect("src", "cond", nv.FromListConnector(conn_list=[[0, 0, -1.0]]))
    # a signed current onto an excitatory receptor is allowed (converted ANNs)
    net.connect("src", "curr", nv.AllToAllConnector(), nv.StaticSynapse(weight=-0.1))
    net.connect("src", "cond", nv.AllToAllConnector(), nv.StaticSynapse(weight=nv.Normal(mu=1.0, sigma=0.1, low=0.0)))


def test_convolution_shapes_must_match(net: nv.Network) -> None:
    net.add_population("img", 2 * 4 * 4, nv.SpikeSourcePoisson())
    net.add_population("fm", 3 * 2 * 2, nv.IF_curr_exp())
    conv = nv.ConvolutionConnector(input_shape=(2, 4, 4), kernel_shape=(3, 3), out_channels=3)
    assert conv.output_shape == (3, 2, 2) and conv.weight_shape == (3, 2, 3, 3)
    with _raises("Projection 'img->fm': a ConvolutionConnector needs a kernel weight of shape (3, 2, 3, 3), got (3, 2, 2, 2)."):
        net.connect("img", "fm", conv, nv.StaticSynapse(weight=np.ones((3, 2, 2, 2))))
    with _raises("Projection 'img->fm': a ConvolutionConnector needs a kernel weight of shape (3, 2, 3, 3), got float."):
        net.connect("img", "fm", conv, nv.StaticSynapse(weight=1.0))
    with _raises(
        "Projection 'img->curr': ConvolutionConnector output (3, 2, 2) has 12 neurons but the postsynaptic population has 3."
    ):
        net.connect("img", "curr", conv, nv.StaticSynapse(weight=np.ones((3, 2, 3, 3))))
    with _raises(
        "Projection 'src->fm': ConvolutionConnector input_shape (2, 4, 4) has 32 neurons but the presynaptic population has 2."
    ):
        net.connect("src", "fm", conv, nv.StaticSynapse(weight=np.ones((3, 2, 3, 3))))
    with _raises("ConvolutionConnector: kernel (3, 3) with padding (0, 0) does not fit the input (2, 2)."):
        nv.ConvolutionConnector(input_shape=(1, 2, 2), kernel_shape=(3, 3))
    with _raises("ConvolutionConnector.stride must be 2 integers >= 1, got (0, 1)."):
        nv.ConvolutionConnector(stride=(0, 1))
    with _raises("Projection 'src->curr': a 4-D weight array needs a ConvolutionConnector."):
        net.connect("src", "curr", nv.AllToAllConnector(), nv.StaticSynapse(weight=np.ones((1, 1, 2, 3))))
    net.connect("img", "fm", conv, nv.StaticSynapse(weight=np.ones((3, 2, 3, 3))))


def test_weight_array_shapes(net: nv.Network) -> None:
    with _raises("Projection 'src->curr': 2-D weight array must be (2, 3), got (3, 2)."):
        net.connect("src", "curr", nv.AllToAllConnector(), nv.StaticSynapse(weight=np.ones((3, 2))))
    with _raises("Projection 'src->curr': 1-D weight array has 5 values for 6 connections."):
        net.connect("src", "curr", nv.AllToAllConnector(), nv.StaticSynapse(weight=np.ones(5)))
    with _raises("Projection 'curr->cond': 1-D delay array has 9 values for 6 connections."):
        net.connect("curr", "cond", nv.AllToAllConnector(allow_self_connections=False), nv.StaticSynapse(delay=np.ones(9)))
    with _raises("DiehlCookSTDP.weight must lie in [0.0, 1.0], got values in [2.0, 2.0]."):
        nv.DiehlCookSTDP(weight=2.0)


def test_names(net: nv.Network) -> None:
    rule = "use letters, digits, '_', '.', ':', '-', '>' (starting with a letter or '_', at most 128 characters)."
    with _raises(f"Network name 'bad name' is invalid: {rule}"):
        nv.Network("bad name")
    with _raises(f"Population name '1x' is invalid: {rule}"):
        net.add_population("1x", 3, nv.IF_curr_exp())
    with _raises(f"Population name {'a' * 129!r} is invalid: {rule}"):
        net.add_population("a" * 129, 3, nv.IF_curr_exp())
    with _raises(f"Projection name 'a/b' is invalid: {rule}"):
        net.connect("src", "curr", nv.AllToAllConnector(), name="a/b")
    with _raises(f"Population name 3 is invalid: {rule}"):
        nv.Population(name=3, size=1, cell_type=nv.IF_curr_exp())


def test_duplicate_names(net: nv.Network) -> None:
    with _raises("Network 'n' already has a population named 'curr'."):
        net.add_population("curr", 3, nv.IF_curr_exp())
    net.connect("src", "curr", nv.AllToAllConnector())
    with _raises("Network 'n' already has a projection named 'src->curr'."):
        net.connect("src", "curr", nv.AllToAllConnector())
    net.connect("src", "curr", nv.AllToAllConnector(), name="second")
    assert list(net.projections) == ["src->curr", "second"]


def test_delays_must_not_be_negative() -> None:
    with _raises("StaticSynapse.delay must be >= 0 ms, got -0.5."):
        nv.StaticSynapse(delay=-0.5)
    with _raises("STDPMechanism.delay must be >= 0 ms, got -1.0."):
        nv.STDPMechanism(delay=-1.0)
    with _raises("StaticSynapse.delay array must be 1-D or 2-D with every delay >= 0 ms."):
        nv.StaticSynapse(delay=np.array([1.0, -0.1]))
    with _raises("FromListConnector.conn_list delays (column 4) must be >= 0 ms."):
        nv.FromListConnector(conn_list=[[0, 0, 1.0, -1.0]])
    # exactly 0 is a zero-delay synapse (docs/semantics.md)
    assert nv.StaticSynapse(delay=0.0).delay == 0.0
    assert nv.FromListConnector(conn_list=[[0, 0, 1.0, 0.0]]).conn_list[0, 3] == 0.0


def test_delay_shorter_than_dt_fails_at_expand(net: nv.Network) -> None:
    net.connect("src", "curr", nv.AllToAllConnector(), nv.StaticSynapse(weight=1.0, delay=0.05), name="short")
    with _raises("Projection 'short': delay 0.05 ms is shorter than the time step 0.1 ms (and not 0)."):
        nv.expand(net, "short", dt=0.1, seed=1)
    assert np.all(nv.expand(net, "short", dt=0.05, seed=1).delay == 0.05)
    net.connect("src", "cond", nv.AllToAllConnector(), nv.StaticSynapse(delay=nv.Uniform(low=0.2, high=0.3)), name="rand")
    short = r"^Projection 'rand': delay 0\.2\d* ms is shorter than the time step 0\.5 ms \(and not 0\)\.$"
    with pytest.raises(ValidationError, match=short):
        nv.expand(net, "rand", dt=0.5, seed=1)
    net.connect("curr", "cond", nv.OneToOneConnector(), name="default")
    np.testing.assert_array_equal(nv.expand(net, "default", dt=0.25, seed=1).delay, [0.25, 0.25, 0.25])


# -- immutability and equality ---------------------------------------------------------------
def test_nodes_are_frozen(net: nv.Network) -> None:
    pop = net.populations["curr"]
    with pytest.raises(dataclasses.FrozenInstanceError):
        pop.size = 5  # type: ignore[misc]
    with pytest.raises(dataclasses.FrozenInstanceError):
        pop.cell_type.tau_m = 5.0  # type: ignore[misc]
    with pytest.raises((AttributeError, TypeError)):
        pop.extra = 1  # type: ignore[attr-defined]
    cell = nv.IF_curr_exp(tau_m=np.array([1.0, 2.0]))
    with pytest.raises(ValueError, match="read-only"):
        cell.tau_m[0] = 3.0
    with pytest.raises(TypeError):
        net.populations["new"] = pop  # type: ignore[index]
    with pytest.raises(TypeError):
        hash(cell)


def test_arrays_are_copied_on_construction() -> None:
    tau = np.array([10.0, 20.0])
    cell = nv.IF_curr_exp(tau_m=tau)
    tau[0] = 99.0
    assert cell.tau_m[0] == 10.0
    assert cell.tau_m.dtype == np.float64


def test_equality_semantics() -> None:
    assert nv.IF_curr_exp(tau_m=10) == nv.IF_curr_exp(tau_m=10.0)
    assert nv.IF_curr_exp(tau_m=np.array([1.0, 2.0])) == nv.IF_curr_exp(tau_m=[1.0, 2.0])
    assert nv.IF_curr_exp(tau_m=np.array([1.0, 2.0])) != nv.IF_curr_exp(tau_m=np.array([1.0, 3.0]))
    assert nv.IF_curr_exp(tau_m=np.array([2.0, 2.0])) != nv.IF_curr_exp(tau_m=2.0)
    assert nv.IF_curr_exp() != nv.IF_cond_exp()
    assert nv.IF_curr_exp() != "IF_curr_exp"
    assert nv.AdditiveWeightDependence() != nv.MultiplicativeWeightDependence()
    syn_a = nv.STDPMechanism(weight_dependence=nv.AdditiveWeightDependence(w_max=0.5), weight=0.1)
    syn_b = nv.STDPMechanism(weight_dependence=nv.AdditiveWeightDependence(w_max=0.5), weight=0.1)
    assert syn_a == syn_b and syn_a != syn_a.replace(weight=0.2)
    assert nv.Normal(mu=1.0) == nv.Normal(mu=1) and nv.Normal(mu=1.0) != nv.Uniform()

    def build(order: tuple[str, ...]) -> nv.Network:
        net = nv.Network("eq")
        for name in order:
            net.add_population(name, 2, nv.IF_curr_exp())
        return net

    assert build(("a", "b")) == build(("a", "b"))
    assert build(("a", "b")) != build(("b", "a"))  # insertion order is part of the graph
    other = build(("a", "b"))
    other.connect("a", "b", nv.OneToOneConnector())
    assert other != build(("a", "b"))
    assert other.copy() == other and other.copy("renamed") != other


def test_replace_validates_again() -> None:
    cell = nv.IF_curr_exp()
    with _raises("IF_curr_exp.tau_m must be > 0.0 ms, got -3.0."):
        cell.replace(tau_m=-3.0)
    assert cell.replace(tau_m=3.0).tau_m == 3.0 and cell.tau_m == 20.0


# -- connectivity.expand ---------------------------------------------------------------------
def _pair_net(n_pre: int, n_post: int, connector: object, synapse: object = None) -> nv.Network:
    net = nv.Network("pairs")
    net.add_population("pre", n_pre, nv.SpikeSourcePoisson())
    net.add_population("post", n_post, nv.IF_curr_exp())
    net.connect("pre", "post", connector, synapse)  # type: ignore[arg-type]
    return net


def _same(a: nv.Connections, b: nv.Connections) -> bool:
    return all(np.array_equal(getattr(a, f), getattr(b, f)) for f in ("pre", "post", "weight", "delay"))


@pytest.mark.parametrize(
    "connector",
    [
        nv.AllToAllConnector(),
        nv.AllToAllConnector(allow_self_connections=False),
        nv.OneToOneConnector(),
        nv.FixedProbabilityConnector(p_connect=0.3),
        nv.FixedNumberPreConnector(n=3),
        nv.FixedNumberPreConnector(n=4, with_replacement=True),
    ],
)
def test_canonical_order_is_pre_then_post(connector: object) -> None:
    net = _pair_net(12, 12, connector, nv.StaticSynapse(weight=nv.Uniform(low=0.0, high=1.0)))
    c = nv.expand(net, "pre->post", dt=0.1, seed=4)
    assert len(c) > 0 and c.pre.dtype == c.post.dtype == np.int64
    key = c.pre * 12 + c.post
    strict = not getattr(connector, "with_replacement", False)
    assert np.all(np.diff(key) > 0) if strict else np.all(np.diff(key) >= 0)
    if isinstance(connector, nv.AllToAllConnector):
        assert len(c) == (144 if connector.allow_self_connections else 132)
        assert connector.allow_self_connections or not np.any(c.pre == c.post)


def test_from_list_keeps_row_order() -> None:
    rows = np.array([[3, 0, 0.5, 1.0], [0, 2, 0.25, 2.0], [1, 1, 0.75, 0.5]])
    net = _pair_net(4, 3, nv.FromListConnector(conn_list=rows))
    c = nv.expand(net, "pre->post", dt=0.5, seed=0)
    np.testing.assert_array_equal(c.pre, [3, 0, 1])
    np.testing.assert_array_equal(c.post, [0, 2, 1])
    np.testing.assert_array_equal(c.weight, [0.5, 0.25, 0.75])
    np.testing.assert_array_equal(c.delay, [1.0, 2.0, 0.5])
    two_col = _pair_net(4, 3, nv.FromListConnector(conn_list=rows[:, :2]), nv.StaticSynapse(weight=np.array([1.0, 2.0, 3.0])))
    np.testing.assert_array_equal(nv.expand(two_col, "pre->post", dt=0.1, seed=0).weight, [1.0, 2.0, 3.0])


@pytest.mark.parametrize(
    "connector",
    [nv.FixedProbabilityConnector(p_connect=0.2), nv.FixedNumberPreConnector(n=nv.Normal(mu=5.0, sigma=1.0))],
)
def test_random_connectors_are_deterministic_per_seed(connector: object) -> None:
    net = _pair_net(40, 30, connector, nv.StaticSynapse(weight=nv.Normal(mu=1.0, sigma=0.5), delay=nv.Uniform(low=1.0, high=3.0)))
    first = nv.expand(net, "pre->post", dt=0.1, seed=7)
    assert _same(first, nv.expand(net, "pre->post", dt=0.1, seed=7))
    assert _same(first, nv.expand(net, net.projections["pre->post"], dt=0.1, seed=7))
    other = nv.expand(net, "pre->post", dt=0.1, seed=8)
    assert not _same(first, other)
    assert len(first) != len(other) or not np.array_equal(first.pre, other.pre)
    assert not np.array_equal(first.weight[:5], other.weight[:5])


def test_connector_seed_overrides_compile_seed() -> None:
    net = _pair_net(30, 30, nv.FixedProbabilityConnector(p_connect=0.2, seed=123), nv.StaticSynapse(weight=nv.Uniform()))
    a = nv.expand(net, "pre->post", dt=0.1, seed=1)
    b = nv.expand(net, "pre->post", dt=0.1, seed=2)
    np.testing.assert_array_equal(a.pre, b.pre)
    np.testing.assert_array_equal(a.post, b.post)
    np.testing.assert_array_equal(a.weight, b.weight)
    free = _pair_net(30, 30, nv.FixedProbabilityConnector(p_connect=0.2), nv.StaticSynapse(weight=nv.Uniform()))
    assert _same(a, nv.expand(free, "pre->post", dt=0.1, seed=123))


def test_streams_differ_between_projections() -> None:
    net = nv.Network("two")
    net.add_population("pre", 50, nv.SpikeSourcePoisson())
    net.add_population("post", 50, nv.IF_curr_exp())
    for name in ("one", "two"):
        net.connect("pre", "post", nv.FixedProbabilityConnector(p_connect=0.1), name=name)
    a, b = nv.expand(net, "one", dt=0.1, seed=3), nv.expand(net, "two", dt=0.1, seed=3)
    assert not (len(a) == len(b) and np.array_equal(a.pre, b.pre) and np.array_equal(a.post, b.post))


def test_fixed_number_pre_exact_in_degree() -> None:
    net = _pair_net(10, 200, nv.FixedNumberPreConnector(n=4))
    c = nv.expand(net, "pre->post", dt=0.1, seed=5)
    np.testing.assert_array_equal(np.bincount(c.post, minlength=200), np.full(200, 4))
    assert np.unique(c.pre * 200 + c.post).size == len(c)  # no pair twice without replacement
    assert np.bincount(c.pre, minlength=10).min() > 0
    no_self = _pair_net(5, 5, nv.FixedNumberPreConnector(n=4, allow_self_connections=False))
    d = nv.expand(no_self, "pre->post", dt=0.1, seed=5)
    np.testing.assert_array_equal(np.bincount(d.post, minlength=5), np.full(5, 4))
    assert not np.any(d.pre == d.post)
    with _raises(
        "Projection 'pre->post': FixedNumberPreConnector.n=11 exceeds the 10 presynaptic neurons (use with_replacement=True)."
    ):
        _pair_net(10, 3, nv.FixedNumberPreConnector(n=11))


def test_fixed_number_pre_with_normal_in_degree() -> None:
    n_pre, n_post = 40, 3000
    dist = nv.Normal(mu=5.0, sigma=1.0)
    net = _pair_net(n_pre, n_post, nv.FixedNumberPreConnector(n=dist))
    c = nv.expand(net, "pre->post", dt=0.1, seed=9)
    degree = np.bincount(c.post, minlength=n_post)
    expected = np.clip(np.rint(dist.sample(projection_rng(net.projections["pre->post"], 9, 0), n_post)), 0, n_pre)
    np.testing.assert_array_equal(degree, expected)
    assert abs(degree.mean() - 5.0) < 0.1
    assert 0.8 < degree.std() < 1.2
    assert np.all(degree == np.rint(degree))
    # clipping: a wide distribution is clipped to [0, n_pre]
    wide = _pair_net(6, 2000, nv.FixedNumberPreConnector(n=nv.Normal(mu=3.0, sigma=4.0)))
    degree = np.bincount(nv.expand(wide, "pre->post", dt=0.1, seed=1).post, minlength=2000)
    assert degree.min() == 0 and degree.max() == 6
    assert (degree == 0).sum() > 100 and (degree == 6).sum() > 100


def test_fixed_probability_statistics() -> None:
    n_pre, n_post, p = 200, 150, 0.1
    counts = []
    for seed in range(3):
        c = nv.expand(_pair_net(n_pre, n_post, nv.FixedProbabilityConnector(p_connect=p)), "pre->post", dt=0.1, seed=seed)
        counts.append(len(c))
        mean, sigma = n_pre * n_post * p, np.sqrt(n_pre * n_post * p * (1 - p))
        assert abs(len(c) - mean) < 5 * sigma
        assert np.unique(c.pre * n_post + c.post).size == len(c)
        # each row is its own binomial draw: row counts ~ Binomial(n_post, p)
        rows = np.bincount(c.pre, minlength=n_pre)
        assert abs(rows.mean() - n_post * p) < 5 * np.sqrt(n_post * p * (1 - p) / n_pre)
    assert len(set(counts)) > 1
    full = nv.expand(_pair_net(5, 7, nv.FixedProbabilityConnector(p_connect=1.0)), "pre->post", dt=0.1, seed=0)
    assert len(full) == 35
    empty = nv.expand(_pair_net(5, 7, nv.FixedProbabilityConnector(p_connect=0.0)), "pre->post", dt=0.1, seed=0)
    assert len(empty) == 0 and empty.weight.shape == (0,)
    no_self = _pair_net(30, 30, nv.FixedProbabilityConnector(p_connect=1.0, allow_self_connections=False))
    c = nv.expand(no_self, "pre->post", dt=0.1, seed=0)
    assert len(c) == 870 and not np.any(c.pre == c.post)


@pytest.mark.parametrize(
    ("input_shape", "kernel", "out_channels", "stride", "padding"),
    [((1, 5, 5), (3, 3), 1, (1, 1), (0, 0)), ((2, 7, 6), (3, 2), 3, (2, 1), (1, 0)), ((3, 6, 6), (3, 3), 2, (2, 2), (1, 1))],
)
def test_convolution_matches_direct_correlation(
    input_shape: tuple[int, int, int],
    kernel: tuple[int, int],
    out_channels: int,
    stride: tuple[int, int],
    padding: tuple[int, int],
) -> None:
    rng = np.random.default_rng(2)
    conv = nv.ConvolutionConnector(
        input_shape=input_shape, kernel_shape=kernel, out_channels=out_channels, stride=stride, padding=padding
    )
    weights = rng.normal(size=conv.weight_shape)
    net = nv.Network("conv")
    net.add_population("img", int(np.prod(input_shape)), nv.SpikeSourcePoisson())
    net.add_population("fm", int(np.prod(conv.output_shape)), nv.IF_curr_exp())
    net.connect("img", "fm", conv, nv.StaticSynapse(weight=weights))
    c = nv.expand(net, "img->fm", dt=0.1, seed=0)
    assert np.unique(c.pre * 10_000 + c.post).size == len(c)
    dense = np.zeros((net.populations["img"].size, net.populations["fm"].size))
    dense[c.pre, c.post] = c.weight
    x = rng.normal(size=input_shape)
    got = (x.reshape(-1) @ dense).reshape(conv.output_shape)
    (ph, pw), (sh, sw) = padding, stride
    padded = np.pad(x, ((0, 0), (ph, ph), (pw, pw)))
    oh, ow = conv.output_hw
    for o in range(out_channels):
        want = sum(correlate2d(padded[ci], weights[o, ci], mode="valid") for ci in range(input_shape[0]))
        np.testing.assert_allclose(got[o], want[::sh, ::sw][:oh, :ow], rtol=1e-12, atol=1e-12)


def test_weight_arrays_are_indexed_pre_post() -> None:
    n_pre, n_post = 6, 5
    matrix = np.arange(n_pre * n_post, dtype=float).reshape(n_pre, n_post)
    delays = 1.0 + matrix / 10.0
    for connector in (nv.AllToAllConnector(), nv.FixedProbabilityConnector(p_connect=0.5), nv.FixedNumberPreConnector(n=2)):
        net = _pair_net(n_pre, n_post, connector, nv.StaticSynapse(weight=matrix, delay=delays))
        c = nv.expand(net, "pre->post", dt=0.1, seed=3)
        np.testing.assert_array_equal(c.weight, matrix[c.pre, c.post])
        np.testing.assert_array_equal(c.delay, delays[c.pre, c.post])
    flat = np.arange(n_pre * n_post, dtype=float)
    c = nv.expand(_pair_net(n_pre, n_post, nv.AllToAllConnector(), nv.StaticSynapse(weight=flat)), "pre->post", dt=0.1, seed=0)
    np.testing.assert_array_equal(c.weight, flat)  # 1-D arrays follow the canonical order
    np.testing.assert_array_equal(c.pre * n_post + c.post, np.arange(n_pre * n_post))


def test_plastic_weights_are_clipped_to_the_rule_bounds() -> None:
    syn = nv.STDPMechanism(
        weight_dependence=nv.AdditiveWeightDependence(w_min=0.0, w_max=0.5), weight=nv.Normal(mu=0.5, sigma=0.5)
    )
    c = nv.expand(_pair_net(20, 20, nv.AllToAllConnector(), syn), "pre->post", dt=0.1, seed=0)
    assert c.weight.min() == 0.0 and c.weight.max() == 0.5
    static = nv.expand(
        _pair_net(20, 20, nv.AllToAllConnector(), nv.StaticSynapse(weight=nv.Normal(mu=0.5, sigma=0.5))),
        "pre->post",
        dt=0.1,
        seed=0,
    )
    assert static.weight.min() < 0.0 and static.weight.max() > 0.5
