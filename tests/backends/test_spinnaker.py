"""The spinnaker backend: sPyNNaker's real mapping on a virtual SpiNN-5 board, and its refusals."""

from __future__ import annotations

import os

import numpy as np
import pytest

import neurovpr as nv
from neurovpr.backends import spinnaker
from neurovpr.backends.spinnaker.capabilities import RUN_REFUSAL
from neurovpr.errors import SimulationError, UnsupportedFeatureError, ValidationError
from neurovpr.hardware import check_network
from neurovpr.ir.connectivity import expand

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


def _signed_convolution() -> nv.Network:
    """A small LoCS-Net: a signed 3x3 convolution and a signed dense layer of current-based LIF."""
    rng = np.random.default_rng(5)
    net = nv.Network("conv_small")
    net.add_population("input", 12 * 12, nv.SpikeSourcePoisson(rate=20.0))
    conv = nv.ConvolutionConnector(input_shape=(1, 12, 12), kernel_shape=(3, 3), out_channels=4, stride=(2, 2))
    net.add_population("conv", int(np.prod(conv.output_shape)), nv.IF_curr_exp())
    net.connect("input", "conv", conv, nv.StaticSynapse(weight=rng.normal(0.2, 0.3, size=conv.weight_shape)))
    net.add_population("places", 300, nv.IF_curr_exp())
    net.connect(
        "conv",
        "places",
        nv.AllToAllConnector(),
        nv.StaticSynapse(weight=rng.normal(0.0, 0.1, size=(net.populations["conv"].size, 300))),
    )
    return net


def _delayed() -> nv.Network:
    """Long delays (delay-extension cores), random and scalar, onto a population of two cores."""
    net = nv.Network("delayed")
    net.add_population("src", 600, nv.SpikeSourcePoisson(rate=5.0))
    net.add_population("a", 300, nv.IF_cond_exp())
    net.add_population("b", 40, nv.IF_curr_exp())
    net.connect(
        "src",
        "a",
        nv.FixedProbabilityConnector(p_connect=0.05),
        nv.StaticSynapse(weight=0.01, delay=nv.Uniform(low=1.0, high=60.0)),
    )
    net.connect("a", "b", nv.AllToAllConnector(), nv.StaticSynapse(weight=0.2, delay=40.0))
    net.connect(
        "b", "b", nv.AllToAllConnector(allow_self_connections=False), nv.StaticSynapse(weight=0.1), receptor_type="inhibitory"
    )
    return net


@pytest.mark.parametrize("build", [_mushroom_body, _signed_convolution, _delayed], ids=["mb", "conv", "delayed"])
def test_fit_check_counts_equal_spynnaker_mapping(spynnaker_available, build) -> None:
    """``check_network(net, "spinn5")`` and sPyNNaker's mapping agree core by core."""
    net = build()
    mapped = spinnaker.mapping.map_network(net, dt=1.0, seed=3)
    report = check_network(net, "spinn5", seed=3)
    assert report.fits
    out = report.as_dict()
    assert (out["chips"], out["cores"]) == (mapped["chips"], mapped["cores"])
    theirs = [
        (
            f"{r['population']}:delays" if r["kind"] == "delays" else r["population"],
            r["lo_atom"],
            r["hi_atom"],
            r["x"],
            r["y"],
            r["p"],
            r["synaptic_matrix_bytes"],
        )
        for r in mapped["placements"]
    ]
    mine = [(c.population, c.lo, c.hi - 1, *c.location, c.usage.get("synaptic_matrix_bytes")) for c in report.partition.cores]
    assert mine == theirs
    kinds = {r["kind"] for r in mapped["placements"]}
    assert ("delays" in kinds) == (build is _delayed)


def _played(times: list[list[float]]) -> nv.Network:
    """An MBSNN-shaped network whose input is a SpikeSourceArray playing ``times``."""
    net = nv.Network("played")
    net.add_population("input", len(times), nv.SpikeSourceArray.from_lists(times))
    net.add_population("pn", len(times), nv.IF_curr_exp_ca2_adaptive(i_alpha=0.2, i_offset=0.02))
    net.add_population("kc", 300, nv.IF_curr_exp())
    net.connect("input", "pn", nv.OneToOneConnector(), nv.StaticSynapse(weight=2.5))
    net.connect("pn", "kc", nv.FixedNumberPreConnector(n=5), nv.StaticSynapse(weight=0.3))
    return net


def test_spike_source_array_without_spikes_maps_like_one_with_spikes(spynnaker_available) -> None:
    """An input without any spike (MBSNN's ``input`` before a recording is given) maps on the same cores.

    sPyNNaker fails on one empty list per neuron (IndexError in its spike-density check),
    so the backend passes sPyNNaker's empty ``spike_times``; the SpikeSourceArray's cores
    do not depend on its spikes, only its buffer SDRAM does.
    """
    from neurovpr.backends.spinnaker.translation import spike_times

    n = 84
    empty = _played([[] for _ in range(n)])
    assert spike_times(empty.populations["input"].cell_type) == []
    played = _played([[1.0 + i % 7, 20.0] for i in range(n)])
    assert spike_times(played.populations["input"].cell_type)[3] == [4.0, 20.0]
    mapped = {name: spinnaker.mapping.map_network(net, dt=0.1, seed=4) for name, net in (("empty", empty), ("played", played))}

    def cores(mapping: dict) -> list[tuple]:
        return [(r["population"], r["lo_atom"], r["hi_atom"], r["x"], r["y"], r["p"], r["kind"]) for r in mapping["placements"]]

    assert cores(mapped["empty"]) == cores(mapped["played"])
    assert (mapped["empty"]["chips"], mapped["empty"]["cores"]) == (mapped["played"]["chips"], mapped["played"]["cores"])
    source = [r for r in mapped["empty"]["placements"] if r["population"] == "input"]
    assert [(r["kind"], r["lo_atom"], r["hi_atom"]) for r in source] == [("source", 0, n - 1)]
    assert any(r["kind"] == "synapses" for r in mapped["empty"]["placements"])  # sub-ms: separate synapse cores
    out = check_network(empty, "spinn5", seed=4, dt=0.1).as_dict()
    assert (out["chips"], out["cores"]) == (mapped["empty"]["chips"], mapped["empty"]["cores"])


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


def test_connector_rule_is_the_fit_checkers() -> None:
    """sPyNNaker's own connectors exactly where they make the canonical synapses, as the checker assumes."""
    from neurovpr.backends.spinnaker.translation import signed_parts, uses_native_connector
    from neurovpr.hardware.spinnaker_rows import native_connector as _native

    net = nv.Network("rule")
    net.add_population("s", 4, nv.SpikeSourcePoisson(rate=1.0))
    net.add_population("a", 4, nv.IF_curr_exp())
    net.add_population("g", 4, nv.IF_cond_exp())
    cases = {
        "all": (nv.AllToAllConnector(), nv.StaticSynapse(weight=0.1, delay=2.0), "s", "a", True),
        "one": (nv.OneToOneConnector(), nv.STDPMechanism(weight=0.1), "s", "a", True),
        "self": (nv.AllToAllConnector(allow_self_connections=False), nv.StaticSynapse(weight=0.1), "a", "a", True),
        "cross": (nv.AllToAllConnector(allow_self_connections=False), nv.StaticSynapse(weight=0.1), "a", "g", False),
        "array": (nv.AllToAllConnector(), nv.StaticSynapse(weight=np.full((4, 4), 0.1)), "s", "a", False),
        "random_weight": (nv.OneToOneConnector(), nv.StaticSynapse(weight=nv.Uniform(low=0.0, high=1.0)), "s", "a", False),
        "delays": (nv.OneToOneConnector(), nv.StaticSynapse(weight=0.1, delay=np.arange(1.0, 5.0)), "s", "a", False),
        "fixed_p": (nv.FixedProbabilityConnector(p_connect=1.0), nv.StaticSynapse(weight=0.1), "s", "a", False),
        "fixed_n": (nv.FixedNumberPreConnector(n=4), nv.StaticSynapse(weight=0.1), "s", "a", False),
    }
    for name, (conn, syn, pre, post, native) in cases.items():
        proj = net.connect(pre, post, conn, syn, name=name)
        assert uses_native_connector(proj) is native, name
        assert _native(proj) is native, name
    plain = net.projections["all"]
    assert [(m.tolist(), r) for m, r, _ in signed_parts(net, plain, np.array([0.1, -0.2]))] == [
        ([True, False], "excitatory"),
        ([False, True], "inhibitory"),
    ]
    assert [r for _, r, _ in signed_parts(net, plain, np.array([-0.1, -0.2]))] == ["inhibitory"]
    assert [r for _, r, _ in signed_parts(net, plain, np.array([0.0, 0.2]))] == ["excitatory"]
