"""PyNN's idioms, as a PyNN user writes them: positional first parameters and ``SpikeSourceArray(spike_times=...)``.

PyNN passes the first parameter of a connector (``FixedProbabilityConnector(p_connect, ...)``),
of a timing or weight dependence and of ``STDPMechanism`` by position; its standard synapse
and cell types take keywords only (``StandardModelType.__init__(self, **parameters)``).
``spike_times`` is one sequence (a homogeneous parameter: every neuron fires it) or one
sequence per neuron. The IR stays frozen dataclasses validated on construction, and a file
saved from these forms is the file saved from the keyword forms.
"""

from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np
import pytest

import neurovpr as nv
from neurovpr.errors import ValidationError

#: (positional form, keyword form) of every type whose first parameter PyNN takes by position.
POSITIONAL = [
    (lambda: nv.AllToAllConnector(False), lambda: nv.AllToAllConnector(allow_self_connections=False)),
    (lambda: nv.FixedProbabilityConnector(0.1), lambda: nv.FixedProbabilityConnector(p_connect=0.1)),
    (lambda: nv.FixedNumberPreConnector(5), lambda: nv.FixedNumberPreConnector(n=5)),
    (lambda: nv.FromListConnector([[0, 1], [1, 0]]), lambda: nv.FromListConnector(conn_list=[[0, 1], [1, 0]])),
    (lambda: nv.Normal(0.3, sigma=0.1), lambda: nv.Normal(mu=0.3, sigma=0.1)),
    (lambda: nv.Uniform(0.2, high=0.4), lambda: nv.Uniform(low=0.2, high=0.4)),
    (lambda: nv.SpikePairRule(16.8, tau_minus=33.7), lambda: nv.SpikePairRule(tau_plus=16.8, tau_minus=33.7)),
    (lambda: nv.AdditiveWeightDependence(0.1), lambda: nv.AdditiveWeightDependence(w_min=0.1)),
    (lambda: nv.MultiplicativeWeightDependence(0.1), lambda: nv.MultiplicativeWeightDependence(w_min=0.1)),
    (
        lambda: nv.STDPMechanism(nv.SpikePairRule(10.0), weight=0.2),
        lambda: nv.STDPMechanism(timing_dependence=nv.SpikePairRule(tau_plus=10.0), weight=0.2),
    ),
]


@pytest.mark.parametrize(("positional", "keyword"), POSITIONAL, ids=lambda f: type(f()).__name__)
def test_first_parameter_by_position_equals_the_keyword_form(positional, keyword):
    assert positional() == keyword()


def test_the_rest_stays_keyword_only():
    with pytest.raises(TypeError, match="positional argument"):
        nv.FixedProbabilityConnector(0.1, False)
    with pytest.raises(TypeError, match="positional argument"):
        nv.Normal(0.3, 0.1)
    with pytest.raises(TypeError, match="positional argument"):
        nv.StaticSynapse(0.5)  # PyNN's standard synapse types take keywords only
    with pytest.raises(TypeError, match="positional argument"):
        nv.IF_curr_exp(10.0)
    with pytest.raises(ValidationError, match=r"FixedProbabilityConnector\.p_connect must be <= 1\.0"):
        nv.FixedProbabilityConnector(1.5)  # still validated on construction


def test_one_spike_train_is_shared_by_every_neuron():
    src = nv.SpikeSourceArray(spike_times=[10.0, 20.0])
    assert src.shared and src.n_neurons == 1
    net = nv.Network("shared")
    pop = net.add_population("s", 3, src)
    placed = pop.cell_type
    assert not placed.shared and placed.n_neurons == 3
    assert placed == nv.SpikeSourceArray.from_lists([[10.0, 20.0]] * 3)
    assert net.add_population("t", 1, nv.SpikeSourceArray(spike_times=[])).cell_type.n_neurons == 1
    assert nv.SpikeSourceArray(spike_times=np.array([1.0, 2.0])).shared


def test_one_spike_train_per_neuron():
    per = nv.SpikeSourceArray(spike_times=[[1.0, 2.0], [], [0.5]])
    assert not per.shared and per == nv.SpikeSourceArray.from_lists([[1.0, 2.0], [], [0.5]])
    assert nv.SpikeSourceArray(spike_times=np.array([[1.0, 2.0], [3.0, 4.0]])).n_neurons == 2
    net = nv.Network("per")
    with pytest.raises(ValidationError, match=r"SpikeSourceArray\.spike_times has 3 values for 2 neurons"):
        net.add_population("s", 2, per)


@pytest.mark.parametrize(
    ("spike_times", "message"),
    [
        ([[1.0], 2.0], "mixes numbers and sequences"),
        ([2.0, 1.0], "spike times of neuron 0 are not sorted"),
        ([[1.0], [3.0, -1.0]], r"times must be finite and >= 0 ms, got -1\.0"),
        ("10 20", "must be a sequence of times"),
        ([[1.0, "x"]], "must be a flat sequence of numbers"),
    ],
)
def test_bad_spike_times_are_refused_by_name(spike_times, message):
    with pytest.raises(ValidationError, match=message):
        nv.SpikeSourceArray(spike_times=spike_times)


def test_spike_times_or_arrays_not_both():
    with pytest.raises(ValidationError, match="give spike_times, or times and offsets, not both"):
        nv.SpikeSourceArray(spike_times=[1.0], times=np.array([1.0]), offsets=np.array([0, 1]))


def _idiomatic(keyword: bool) -> nv.Network:
    net = nv.Network("idioms")
    if keyword:
        net.add_population("src", 4, nv.SpikeSourceArray.from_lists([[1.0, 4.0]] * 4))
        conn = nv.FixedProbabilityConnector(p_connect=0.5, seed=3)
        rule = nv.STDPMechanism(timing_dependence=nv.SpikePairRule(tau_plus=16.8), weight=nv.Uniform(low=0.1, high=0.3))
        inh = nv.FixedNumberPreConnector(n=2, seed=4)
    else:
        net.add_population("src", 4, nv.SpikeSourceArray(spike_times=[1.0, 4.0]))
        conn = nv.FixedProbabilityConnector(0.5, seed=3)
        rule = nv.STDPMechanism(nv.SpikePairRule(16.8), weight=nv.Uniform(0.1, high=0.3))
        inh = nv.FixedNumberPreConnector(2, seed=4)
    net.add_population("n", 3, nv.IF_curr_exp())
    net.connect("src", "n", conn, rule)
    net.connect("src", "n", inh, nv.StaticSynapse(weight=0.5), receptor_type="inhibitory", name="inh")
    return net


def test_idiomatic_network_round_trips_to_the_keyword_networks_file(tmp_path: Path):
    idiomatic, keyword = _idiomatic(keyword=False), _idiomatic(keyword=True)
    assert idiomatic == keyword
    nv.save(idiomatic, tmp_path / "idioms.h5")
    nv.save(keyword, tmp_path / "keyword.h5")
    loaded = nv.load(tmp_path / "idioms.h5")
    assert loaded == idiomatic and loaded == keyword
    with h5py.File(tmp_path / "idioms.h5") as a, h5py.File(tmp_path / "keyword.h5") as b:
        assert a.attrs["graph"] == b.attrs["graph"] and a.attrs["content_sha256"] == b.attrs["content_sha256"]


def test_inputs_take_spike_times_as_pynn_does():
    """``inputs=`` takes one train for every neuron or one per neuron, as the constructor does."""
    net = nv.Network("inputs")
    net.add_population("src", 2, nv.SpikeSourceArray(spike_times=[]))
    net.add_population("n", 2, nv.IF_curr_exp(tau_refrac=0.1))
    net.connect("src", "n", nv.OneToOneConnector(), nv.StaticSynapse(weight=20.0))
    sim = nv.compile(net, backend="reference", dt=0.1, seed=0)
    sim.run(30.0, inputs={"src": [5.0, 15.0]})
    np.testing.assert_array_equal(sim.spike_counts("src"), [2, 2])
    sim.reset()
    sim.run(30.0, inputs={"src": [[5.0], [5.0, 10.0, 15.0]]})
    np.testing.assert_array_equal(sim.spike_counts("src"), [1, 3])
    assert sim.spike_counts("n")[1] > sim.spike_counts("n")[0]
