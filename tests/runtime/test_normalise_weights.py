"""Simulation.normalise_weights: Diehl & Cook's per-neuron normalisation, the same numbers on every path.

The reference backend computes it in its own storage; the generic path (any other backend)
goes through weights() and set_weights(). Both must equal the numpy computation
(neurovpr.runtime.weights.normalised) bit for bit, refuse what set_weights refuses without
writing anything, and leave neurons without input and neurons whose weights sum to 0 alone.
"""

from __future__ import annotations

import numpy as np
import pytest

import neurovpr as nv
from neurovpr.runtime.simulation import Simulation
from neurovpr.runtime.weights import normalised

pytest.importorskip("numba")


def _network(w_max: float = 1.0) -> nv.Network:
    rng = np.random.default_rng(5)
    net = nv.Network("norm")
    net.add_population("in", 30, nv.SpikeSourcePoisson(rate=20.0))
    net.add_population("out", 7, nv.IF_cond_exp())
    # repeated pairs (0 -> 1 twice at one delay), out[6] has no input, out[5] only zero weights
    rows = [(i, j, rng.uniform(0.0, 0.4), rng.choice([0.5, 1.0, 2.0])) for i in range(30) for j in range(5)]
    rows += [(0, 1, 0.2, 1.0), (0, 1, 0.3, 1.0), (3, 5, 0.0, 1.0), (4, 5, 0.0, 0.5)]
    stdp = nv.STDPMechanism(weight_dependence=nv.AdditiveWeightDependence(w_min=0.0, w_max=w_max))
    net.connect("in", "out", nv.FromListConnector(conn_list=np.array(rows)), stdp, name="plastic")
    static = np.array([(i, j, rng.uniform(0.0, 0.2), 1.0) for i in range(30) for j in range(7) if (i + j) % 3])
    net.connect("in", "out", nv.FromListConnector(conn_list=static), nv.StaticSynapse(), name="static")
    return net


def _expected(sim: nv.Simulation, projection: str, total: float, w_max: float | None) -> np.ndarray:
    _, post = sim.connections(projection)
    return normalised(sim.weights(projection, format="list"), post, 7, total, w_max)


@pytest.mark.parametrize("projection", ["plastic", "static"])
@pytest.mark.parametrize("w_max", [None, 0.05])
def test_reference_normalisation_equals_the_numpy_computation(projection: str, w_max: float | None) -> None:
    sim = nv.compile(_network(w_max=2.0), backend="reference", dt=0.1, seed=1)  # no weight can pass the sum
    sim.run(20.0)  # weights moved by learning first
    expected = _expected(sim, projection, 1.7, w_max)
    sim.normalise_weights(projection, 1.7, w_max=w_max)
    got = sim.weights(projection, format="list")
    assert np.array_equal(got.view(np.int64), expected.view(np.int64))
    _, post = sim.connections(projection)
    sums = np.bincount(post, weights=got, minlength=7)
    if w_max is None:
        fed = np.bincount(post, weights=expected > 0, minlength=7) > 0
        assert np.allclose(sums[fed], 1.7)
    assert np.all(got <= (np.inf if w_max is None else w_max))


def test_reference_storage_path_equals_the_generic_path() -> None:
    """The backend's own computation and the base class's weights()/set_weights() path give the same bits."""
    own, generic = (nv.compile(_network(), backend="reference", dt=0.1, seed=1) for _ in range(2))
    for sim in (own, generic):
        sim.run(30.0)
    own.normalise_weights("plastic", 2.5, w_max=0.3)
    Simulation._normalise_weights(generic, "plastic", 2.5, 0.3)
    a, b = own.weights("plastic", format="list"), generic.weights("plastic", format="list")
    assert np.array_equal(a.view(np.int64), b.view(np.int64))
    # and the learning that follows is the same
    for sim in (own, generic):
        sim.run(30.0)
    assert np.array_equal(own.weights("plastic", format="list"), generic.weights("plastic", format="list"))
    assert np.array_equal(own.spike_counts("out"), generic.spike_counts("out"))


def test_neurons_without_input_or_with_zero_sum_keep_their_weights() -> None:
    sim = nv.compile(_network(), backend="reference", dt=0.1, seed=1)
    _, post = sim.connections("plastic")
    sim.normalise_weights("plastic", 3.0)
    w = sim.weights("plastic", format="list")
    assert np.all(w[post == 5] == 0.0)
    assert 6 not in post


@pytest.mark.parametrize(
    ("total", "w_max", "needle"),
    [(0.0, None, "total"), (-1.0, None, "total"), (float("nan"), None, "total"), (True, None, "total"),
     ("1", None, "total"), (1.0, 0.0, "w_max"), (1.0, float("inf"), "w_max")],
)  # fmt: skip
def test_bad_arguments_are_refused_in_one_sentence(total: object, w_max: object, needle: str) -> None:
    sim = nv.compile(_network(), backend="reference", dt=0.1, seed=1)
    before = sim.weights("plastic", format="list")
    with pytest.raises(nv.ValidationError, match=needle) as err:
        sim.normalise_weights("plastic", total, w_max=w_max)  # type: ignore[arg-type]
    assert "'plastic'" in str(err.value) and str(err.value).count(". ") == 0
    assert np.array_equal(sim.weights("plastic", format="list"), before)
    with pytest.raises(nv.ValidationError, match="nope"):
        sim.normalise_weights("nope", 1.0)


@pytest.mark.parametrize("own", [True, False])
def test_weights_past_the_rule_bounds_are_refused_and_nothing_is_written(own: bool) -> None:
    """Scaling to a sum of 30 puts weights above the rule's w_max = 1; set_weights' check, on both paths."""
    sim = nv.compile(_network(w_max=1.0), backend="reference", dt=0.1, seed=1)
    before = sim.weights("plastic", format="list")
    with pytest.raises(nv.ValidationError, match=r"must lie in \[0.0, 1.0\]"):
        if own:
            sim.normalise_weights("plastic", 30.0)
        else:
            Simulation._normalise_weights(sim, "plastic", 30.0, None)
    assert np.array_equal(sim.weights("plastic", format="list"), before)
    sim.normalise_weights("plastic", 30.0, w_max=1.0)  # clipped into the bounds: accepted
    assert sim.weights("plastic", format="list").max() == 1.0
