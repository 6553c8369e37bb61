"""The spinnaker backend: sPyNNaker's real mapping on a virtual SpiNN-5 board, and its refusals."""

from __future__ import annotations

import os

import numpy as np
import pytest

import neurovpr as nv
from neurovpr.backends import spinnaker
from neurovpr.backends.spinnaker.capabilities import RUN_REFUSAL
from neurovpr.connectivity import expand
from neurovpr.errors import SimulationError, UnsupportedFeatureError, ValidationError

BACKEND = spinnaker.BACKEND


@pytest.fixture(scope="module")
def spynnaker_available() -> None:
    reason = BACKEND.unavailable_reason()
    if reason is not None:
        pytest.skip(reason)


@pytest.fixture
def private_home(tmp_path, monkeypatch):
    """A home folder sPyNNaker must leave untouched."""
    home = tmp_path / "home"
    home.mkdir()
    monkeypatch.setenv("HOME", str(home))
    monkeypatch.delenv("XDG_CONFIG_HOME", raising=False)
    return home


def _mushroom_body(n_kc: int = 400) -> nv.Network:
    """A small MBSNN-like network: Poisson -> Ca2-adaptive PNs -> KCs (plastic inhibition) -> MBON."""
    net = nv.Network("mb_small")
    net.add_population("events", 84, nv.SpikeSourcePoisson(rate=10.0))
    net.add_population("pn", 84, nv.IF_curr_exp_ca2_adaptive(i_alpha=0.2, i_offset=0.02))
    net.add_population("kc", n_kc, nv.IF_curr_exp())
    net.add_population("mbon", 1, nv.IF_cond_exp())
    net.connect("events", "pn", nv.OneToOneConnector(), nv.StaticSynapse(weight=1.0))
    net.connect("pn", "kc", nv.FixedNumberPreConnector(n=5), nv.StaticSynapse(weight=nv.Normal(mu=0.3, sigma=0.1)))
    stdp = nv.STDPMechanism(
        timing_dependence=nv.SpikePairRule(tau_plus=1.25, tau_minus=0.1, A_plus=0.3, A_minus=0.15),
        weight_dependence=nv.AdditiveWeightDependence(w_min=0.0, w_max=0.5),
        weight=0.0,
    )
    net.connect("kc", "kc", nv.FixedProbabilityConnector(p_connect=0.1), stdp, receptor_type="inhibitory", name="kc_kc")
    net.connect("kc", "mbon", nv.AllToAllConnector(), nv.StaticSynapse(weight=0.01))
    return net


def test_mapping_of_a_small_network(spynnaker_available, private_home) -> None:
    """sPyNNaker's placements cover every neuron once; chips, cores and SDRAM add up; home untouched."""
    net = _mushroom_body()
    saved = {key: os.environ.get(key) for key in ("HOME", "XDG_CONFIG_HOME")}
    sim = BACKEND.compile(net, dt=1.0, seed=1)
    mapping = sim.mapping()
    assert {key: os.environ.get(key) for key in ("HOME", "XDG_CONFIG_HOME")} == saved
    assert list(private_home.iterdir()) == []  # no .spynnaker.cfg, nothing else
    assert not (private_home / ".spynnaker.cfg").exists()

    rows = mapping["placements"]
    assert mapping["cores"] == len(rows) >= 5
    assert mapping["chips"] == len({(r["x"], r["y"]) for r in rows}) >= 1
    assert mapping["sdram_bytes"] == sum(r["sdram_bytes"] for r in rows) > 0
    assert mapping["machine_chips"] == 48  # one SpiNN-5 board
    assert len({(r["x"], r["y"], r["p"]) for r in rows}) == len(rows)
    for pop in net.populations.values():
        atoms = np.zeros(pop.size, dtype=np.int64)
        for r in rows:
            if r["population"] == pop.name and r["kind"] in ("neurons", "source"):
                atoms[r["lo_atom"] : r["hi_atom"] + 1] += 1
        np.testing.assert_array_equal(atoms, 1, err_msg=pop.name)
    kc_cores = [r for r in rows if r["population"] == "kc" and r["kind"] == "neurons"]
    assert len(kc_cores) == 2  # sPyNNaker's 256 neurons per core for IF_curr_exp
    assert all(r["sdram_bytes"] > 0 and 1 <= r["p"] <= 17 for r in rows)


def test_run_is_refused_but_connections_and_weights_are_there(spynnaker_available) -> None:
    net = _mushroom_body(n_kc=100)
    sim = BACKEND.compile(net, dt=1.0, seed=2)
    with pytest.raises(SimulationError) as err:
        sim.run(100.0)
    assert str(err.value) == RUN_REFUSAL
    assert sim.time == 0.0 and sim.spike_counts("kc").sum() == 0
    canon = expand(net, "pn->kc", dt=1.0, seed=2)
    np.testing.assert_array_equal(sim.connections("pn->kc")[0], canon.pre)
    np.testing.assert_array_equal(sim.weights("pn->kc", format="list"), canon.weight)
    caps = BACKEND.capabilities.as_dict()
    assert caps["runs"] is False and caps["run_refusal"] == RUN_REFUSAL
    assert "IF_curr_exp_ca2_adaptive" in caps["cell_types"]


def test_network_too_big_for_one_board_gets_spynnaker_reason(spynnaker_available, private_home) -> None:
    """256 x 900 neurons need 900 cores; one SpiNN-5 board has fewer, and sPyNNaker's placer says so."""
    net = nv.Network("too_big")
    net.add_population("exc", 256 * 900, nv.IF_curr_exp())
    with pytest.raises(ValidationError) as err:
        spinnaker.mapping.map_network(net, dt=1.0, seed=1)
    message = str(err.value)
    assert message.startswith("sPyNNaker cannot map network 'too_big' onto one SpiNN-5 board: PacmanPlaceException:")
    assert "No more chips" in message and "\n" not in message and "Report written" not in message
    assert list(private_home.iterdir()) == []


@pytest.mark.parametrize(
    ("build", "words"),
    [
        (lambda n: n.add_population("exc", 4, nv.IF_cond_exp_adaptive()), ["IF_cond_exp_adaptive", "theta"]),
        (
            lambda n: (
                n.add_population("a", 2, nv.SpikeSourcePoisson(rate=1.0)),
                n.add_population("b", 2, nv.IF_curr_exp()),
                n.connect("a", "b", nv.AllToAllConnector(), nv.DiehlCookSTDP(weight=0.1), name="dc"),
            ),
            ["DiehlCookSTDP", "'dc'", "Diehl & Cook"],
        ),
    ],
)
def test_unmappable_features_are_refused_by_name(build, words) -> None:
    net = nv.Network("refused")
    build(net)
    for call in (
        lambda: BACKEND.compile(net, dt=1.0, seed=1),
        lambda: spinnaker.mapping.map_network(net, dt=1.0, seed=1),
    ):
        with pytest.raises(UnsupportedFeatureError) as err:
            call()
        for word in words:
            assert word in str(err.value)
