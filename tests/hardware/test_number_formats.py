"""Number-format emulation (``nv.compile(..., backend="reference", hardware=NAME)``) against the vendors' own models.

The bulk of the equivalence is in test_random_equivalence.py (seeded random networks, both
Loihi modes). This file covers what random networks do not reach:

* ``kapoho-bay`` against NengoLoihi's emulator: the arithmetic helpers against NengoLoihi's
  own functions, bias-only blocks (NengoLoihi's bias scaling branch), a convolution
  (population weights), a population split over two core blocks, membranes step by step,
  the conformance delay network, and the one known difference (the voltage floor);
* ``loihi2`` against Lava's ``fixed_pt`` models (the ``lava-fixed`` backend): the issue-22
  network (one source projected through both receptors) membrane by membrane, and the
  refusal of a weight exponent the chip cannot hold, and the backend kit's mapping taking every
  limit from the hwspec's ``[formats]``;
* ``spinn5``: in test_number_formats_spinnaker.py.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from chip_oracles import lava_integer_difference, nengo_integer_difference, oracle_backend, run_both

import neurovpr as nv
from neurovpr.errors import SimulationError, UnsupportedFeatureError, ValidationError
from neurovpr.hardware import load_hwspec

kf = pytest.importorskip("neurovpr.backends.reference.kernels_fixed")

T = 300.0  # ms of each comparison run


def _arrays(rng: np.random.Generator, n: int, per: int, t_max: float) -> nv.SpikeSourceArray:
    return nv.SpikeSourceArray.from_lists(
        [np.sort(rng.choice(np.arange(1, int(t_max)), per, replace=False)).astype(float) for _ in range(n)]
    )


def _trains(sim, pop: str) -> tuple[np.ndarray, np.ndarray]:
    t, i = sim.spike_trains(pop)
    order = np.lexsort((i, t))
    return np.asarray(t)[order], np.asarray(i)[order]


def _assert_same(mine, theirs, *, shift: float = 0.0, what: str = "") -> None:
    assert mine[0].size > 0, f"{what}: no spikes to compare"
    assert mine[0].size == theirs[0].size, f"{what}: {mine[0].size} vs {theirs[0].size} spikes"
    np.testing.assert_array_equal(mine[1], theirs[1], err_msg=what)
    np.testing.assert_allclose(mine[0], theirs[0] + shift, atol=1e-9, err_msg=what)


# -- NengoLoihi (kapoho-bay) ---------------------------------------------------------------
def _compare_kapoho(net: nv.Network, populations: dict[str, float], duration: float = T):
    """Run ``net`` on NengoLoihi and in the kapoho-bay formats; check integers and spikes.

    ``populations`` maps each population to compare to the shift (ms) NengoLoihi's spikes
    need to line up (one step per neuron-to-neuron layer: NengoLoihi delivers on-chip spikes
    one step earlier than docs/semantics.md, the emulation keeps the semantics).
    """
    mine, oracle = run_both(net, "nengo-loihi", duration)
    problem = nengo_integer_difference(mine, oracle, list(populations))
    assert problem is None, problem
    for name, shift in populations.items():
        t, i = _trains(oracle, name)
        keep = t + shift <= duration + 1e-9  # a shifted spike past the end of the run is not in ours
        _assert_same(_trains(mine, name), (t[keep], i[keep]), shift=shift, what=name)
    return mine, oracle


def test_loihi_arithmetic_equals_nengo_loihi_functions():
    discretize = pytest.importorskip("nengo_loihi.builder.discretize")
    rng = np.random.default_rng(0)
    x = rng.integers(-(2**30), 2**30, 2000)
    decay = rng.integers(0, 4096, 2000)
    ours = np.array([kf.decay_toward_zero(int(a), 4095 - int(d), 12) for a, d in zip(x, decay, strict=True)])
    np.testing.assert_array_equal(ours, discretize.decay_int(x, decay, offset=1))
    for bits in (21, 23):
        wrapped, _ = discretize.overflow_signed(x.copy(), bits=bits)
        np.testing.assert_array_equal([kf.wrap_signed(int(a), bits) for a in x], wrapped)


def test_bias_driven_neurons_match_nengo_loihi():
    """LIF neurons under constant offset currents only (NengoLoihi's bias-only scaling branch)."""
    net = nv.Network("bias")
    net.add_population("a", 12, nv.IF_curr_exp(tau_m=20.0, tau_refrac=3.0, i_offset=np.linspace(0.7, 3.0, 12)))
    net.add_population(
        "b",
        4,
        nv.IF_curr_exp(tau_m=15.0, cm=0.5, v_rest=-60.0, v_reset=-70.0, i_offset=[0.0, 0.1, 0.2, 0.4]),
        v_init=-70.0,
    )
    _compare_kapoho(net, {"a": 0.0, "b": 0.0})


def test_convolution_matches_nengo_loihi():
    """A 3x3, 2-filter, mixed-sign convolution of an 8x8 spike map (NengoLoihi's population-weight synapses)."""
    rng = np.random.default_rng(2)
    net = nv.Network("conv")
    net.add_population("img", 64, _arrays(rng, 64, 30, T - 5))
    conv = nv.ConvolutionConnector(input_shape=(1, 8, 8), kernel_shape=(3, 3), out_channels=2)
    net.add_population("fmap", 72, nv.IF_curr_exp(tau_m=10.0, tau_syn_E=2.0, tau_refrac=1.0))
    net.connect("img", "fmap", conv, nv.StaticSynapse(weight=rng.uniform(-1.0, 2.0, (2, 1, 3, 3))))
    _compare_kapoho(net, {"fmap": 0.0})


def test_population_split_over_two_cores_matches_nengo_loihi():
    """1100 neurons: two core blocks, each discretised with its own scales."""
    rng = np.random.default_rng(5)
    net = nv.Network("split")
    net.add_population("src", 16, _arrays(rng, 16, 40, 200.0))
    weights = rng.uniform(0.05, 1.0, (16, 1100)) * np.where(np.arange(1100) < 1024, 1.0, 0.2)
    net.add_population("big", 1100, nv.IF_curr_exp(tau_m=20.0, tau_syn_E=5.0, tau_refrac=2.0))
    net.connect("src", "big", nv.AllToAllConnector(), nv.StaticSynapse(weight=weights))
    mine, _ = _compare_kapoho(net, {"big": 0.0}, duration=200.0)
    assert len({b["v_scale"] for b in mine.quantised.blocks}) == 2


@pytest.mark.parametrize(("tau_m", "tau_syn", "receptor"), [(10.0, 2.0, "excitatory"), (5.0, 8.0, "inhibitory"),
                                                      (10.0, 10.0, "excitatory")])  # fmt: skip
def test_conformance_psp_membrane_matches_nengo_loihi_step_by_step(tau_m, tau_syn, receptor):
    """The ``psp_curr`` conformance network at 1 ms: the integer membrane of both, every step."""
    net = nv.Network("psp")
    net.add_population("src", 1, nv.SpikeSourceArray.from_lists([[5.0]]))
    cell = nv.IF_curr_exp(tau_m=tau_m, tau_syn_E=tau_syn, tau_syn_I=tau_syn, v_thresh=-50.0, v_reset=-65.0)
    net.add_population("post", 1, cell)
    net.add_population("probe", 1, nv.IF_curr_exp(i_offset=2.0))  # a spiking neighbour: spikes to compare
    net.connect("src", "post", nv.AllToAllConnector(), nv.StaticSynapse(weight=4.0, delay=1.0),
                receptor_type=receptor)  # fmt: skip
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        oracle = oracle_backend("nengo-loihi").compile(net, dt=1.0, seed=3, hardware=None)
        oracle.record("post", "v")
        oracle.run(60.0)
    mine = nv.compile(net, backend="reference", dt=1.0, seed=3, hardware="kapoho-bay")
    mine.record("post", "v")
    mine.run(60.0)
    block = next(b for b in mine.quantised.blocks if b["population"] == "post")
    v_mine = np.rint((mine.trace("post", "v")[1][:, 0] + 65.0) / mine.quantised.v_unit[mine._lay.offsets["post"][0]])
    v_theirs = np.rint((oracle.trace("post", "v")[1][:, 0] + 65.0) / 15.0 * block["vth"][0])
    assert np.abs(v_mine).max() > 0.05 * block["vth"][0]
    np.testing.assert_array_equal(v_mine, v_theirs)
    # arrives at 6 ms and acts in the step [6, 7) ms: the first sample it changes is the one at 7 ms (index 6)
    np.testing.assert_array_equal(np.flatnonzero(v_mine), np.arange(6, 60))
    _assert_same(_trains(mine, "probe"), _trains(oracle, "probe"), what="probe")


def test_conformance_delay_network_matches_nengo_loihi():
    """The ``delay_heterogeneous`` conformance network at 1 ms: one source, per-connection delays."""
    net = nv.Network("delays")
    net.add_population("src", 1, nv.SpikeSourceArray.from_lists([[10.0, 60.0, 61.0, 62.0]]))
    net.add_population("post", 5, nv.IF_curr_exp(tau_m=10.0, tau_syn_E=2.0, tau_refrac=2.0))
    net.connect("src", "post", nv.AllToAllConnector(), nv.StaticSynapse(weight=12.0,
                                                                       delay=np.array([1.0, 2.0, 3.0, 5.0, 8.0])))  # fmt: skip
    mine, _ = _compare_kapoho(net, {"post": 0.0}, duration=100.0)
    first = [_trains(mine, "post")[0][_trains(mine, "post")[1] == k][0] for k in range(5)]
    np.testing.assert_array_equal(np.diff(first), [1.0, 1.0, 2.0, 3.0])


def test_voltage_floor_is_the_24_bit_register_where_nengo_loihi_goes_lower():
    """The one known difference: strong inhibition drives v below the 24-bit register.

    The ``nengo-loihi`` backend builds its LIF with ``min_voltage=-inf``, for which
    NengoLoihi's emulator sets ``vmin = -(2**31 - 1)`` (a 5-bit exponent of 31), outside
    Loihi's 24-bit voltage (hwspec ``[formats].voltage_bits``); the emulation saturates at
    ``-(2**23 - 1)``. The traces are identical until NengoLoihi's first goes lower.
    """
    n = 100
    net = nv.Network("vmin")
    net.add_population("src", n, nv.SpikeSourceArray.from_lists([[5.0, 6.0, 7.0]] * n))
    net.add_population("post", 1, nv.IF_curr_exp(tau_m=20.0, tau_syn_I=5.0, i_offset=1.0))
    net.connect("src", "post", nv.AllToAllConnector(), nv.StaticSynapse(weight=1.0), receptor_type="inhibitory")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        oracle = oracle_backend("nengo-loihi").compile(net, dt=1.0, seed=3, hardware=None)
        oracle.record("post", "v")
        oracle.run(60.0)
    mine = nv.compile(net, backend="reference", dt=1.0, seed=3, hardware="kapoho-bay")
    mine.record("post", "v")
    mine.run(60.0)
    vth = mine.quantised.blocks[0]["vth"][0]
    v_mine = np.rint((mine.trace("post", "v")[1][:, 0] + 65.0) / mine.quantised.v_unit[mine._lay.offsets["post"][0]])
    v_theirs = np.rint((oracle.trace("post", "v")[1][:, 0] + 65.0) / 15.0 * vth)
    floor = -(2 ** (load_hwspec("kapoho-bay").formats.voltage_bits - 1)) + 1
    k = int(np.flatnonzero(v_theirs < floor)[0])
    np.testing.assert_array_equal(v_mine[:k], v_theirs[:k])
    assert v_mine[k] == floor and v_mine.min() == floor


# -- Lava (loihi2) ----------------------------------------------------------------------
def test_loihi2_one_source_through_both_receptors_matches_lava_membrane_by_membrane():
    """Issue 22: one source projected twice onto one population, ``max(w, 0)`` excitatory and ``max(-w, 0)``
    inhibitory. The emulation's integers are the ``lava-fixed`` backend's, and every membrane equals Lava's
    integer ``v`` at every step (before the fix a neuron fired one step apart and its train diverged)."""
    rng = np.random.default_rng(3)
    net = nv.Network("issue22")
    net.add_population("src", 25, _arrays(rng, 25, 20, 200.0))
    net.add_population("out", 12, nv.IF_curr_exp(tau_m=20.0, tau_syn_E=5.0, tau_syn_I=5.0, tau_refrac=0.0))
    w = rng.uniform(-0.4, 1.2, (25, 12))
    net.connect("src", "out", nv.AllToAllConnector(), nv.StaticSynapse(weight=np.maximum(w, 0.0)), name="exc")
    net.connect("src", "out", nv.AllToAllConnector(), nv.StaticSynapse(weight=np.maximum(-w, 0.0)),
                receptor_type="inhibitory", name="inh")  # fmt: skip
    mine = nv.compile(net, backend="reference", dt=1.0, seed=3, hardware="loihi2")
    lava = oracle_backend("lava-fixed").compile(net, dt=1.0, seed=3, hardware=None)
    try:
        for sim in (mine, lava):
            sim.record("out", "v")
            sim.run(250.0)
        assert lava_integer_difference(mine, lava) is None
        block = mine.quantised.blocks[0]
        unit = 64.0 * block["vth_man"][0] / 15.0  # integer voltage units per mV (v_thresh - v_reset = 15 mV)
        v_mine = np.rint((mine.trace("out", "v")[1] + 65.0) * unit)
        v_lava = np.rint((lava.trace("out", "v")[1] + 65.0) * unit)
        assert np.abs(v_mine).max() > 0.5 * block["vth"][0]
        np.testing.assert_array_equal(v_mine, v_lava)
        _assert_same(_trains(mine, "out"), _trains(lava, "out"), what="out")
    finally:
        lava.close()


def test_loihi2_refuses_a_weight_exponent_the_chip_cannot_hold():
    fmt = load_hwspec("loihi2").formats
    net = nv.Network("huge")
    net.add_population("src", 2, nv.SpikeSourceArray.from_lists([[5.0], [6.0]]))
    net.add_population("n", 2, nv.IF_curr_exp(tau_m=100.0, cm=0.25, tau_syn_E=20.0))
    net.connect("src", "n", nv.AllToAllConnector(), nv.StaticSynapse(weight=50.0, delay=3.0), name="big")
    with pytest.raises(ValidationError, match=rf"Projection 'big' \(delay 3 ms\).*exponent of \d+, outside Loihi's "
                                              rf"{fmt.weight_exponent_min}..{fmt.weight_exponent_max}"):  # fmt: skip
        nv.compile(net, backend="reference", dt=1.0, seed=0, hardware="loihi2")
    sim = nv.compile(net, backend="reference", dt=1.0, seed=0, hardware="kapoho-bay")  # NengoLoihi rescales instead
    assert sim.quantised.blocks[0]["w_exp"] <= 0


# -- behaviour shared by the modes ------------------------------------------------------
def test_poisson_input_is_the_float_modes_input():
    net = nv.Network("poisson")
    net.add_population("p", 50, nv.SpikeSourcePoisson(rate=40.0))
    net.add_population("n", 5, nv.IF_curr_exp())
    net.connect("p", "n", nv.AllToAllConnector(), nv.StaticSynapse(weight=0.2))
    ref = nv.compile(net, backend="reference", dt=1.0, seed=11)
    ref.run(300.0)
    for hw in ("kapoho-bay", "loihi2", "spinn5"):
        sim = nv.compile(net, backend="reference", dt=1.0, seed=11, hardware=hw)
        sim.run(300.0)
        _assert_same(_trains(sim, "p"), _trains(ref, "p"), what=hw)
        again = nv.compile(net, backend="reference", dt=1.0, seed=11, hardware=hw)
        again.run(300.0)
        _assert_same(_trains(again, "n"), _trains(sim, "n"), what=f"{hw} determinism")
        sim.reset()
        sim.run(300.0)
        again.reset()
        again.run(300.0)
        _assert_same(_trains(sim, "n"), _trains(again, "n"), what=f"{hw} after reset")
    ref.reset()
    ref.run(300.0)
    _assert_same(_trains(sim, "p"), _trains(ref, "p"), what="after reset")


def test_refusals_name_the_feature():
    net = nv.Network("refuse")
    net.add_population("s", 2, nv.SpikeSourcePoisson(rate=10.0))
    net.add_population("n", 2, nv.IF_curr_exp(tau_syn_E=5.0, tau_syn_I=10.0))
    net.connect("s", "n", nv.AllToAllConnector(), nv.StaticSynapse(weight=0.5))
    with pytest.raises(ValidationError, match="steps of 1 ms"):
        nv.compile(net, backend="reference", dt=0.1, seed=0, hardware="kapoho-bay")
    net.connect("s", "n", nv.AllToAllConnector(), nv.StaticSynapse(weight=0.5), receptor_type="inhibitory", name="inh")
    with pytest.raises(UnsupportedFeatureError, match="tau_syn_E 5 != tau_syn_I 10"):
        nv.compile(net, backend="reference", dt=1.0, seed=0, hardware="loihi2")
    plastic = nv.Network("plastic")
    plastic.add_population("s", 2, nv.SpikeSourcePoisson(rate=10.0))
    plastic.add_population("n", 2, nv.IF_curr_exp())
    rule = nv.STDPMechanism(timing_dependence=nv.SpikePairRule(), weight_dependence=nv.AdditiveWeightDependence())
    plastic.connect("s", "n", nv.AllToAllConnector(), rule, name="learn")
    for hw in ("kapoho-bay", "spinn5"):
        with pytest.raises(UnsupportedFeatureError, match="inference only: projection 'learn' is plastic"):
            nv.compile(plastic, backend="reference", dt=1.0, seed=0, hardware=hw)
    cond = nv.Network("cond")
    cond.add_population("n", 2, nv.IF_cond_exp())
    with pytest.raises(ValidationError, match="does not fit"):
        nv.compile(cond, backend="reference", dt=1.0, seed=0, hardware="kapoho-bay")
    signed = nv.Network("signed")
    signed.add_population("s", 2, nv.SpikeSourcePoisson(rate=10.0))
    signed.add_population("n", 2, nv.IF_curr_exp())
    signed.connect("s", "n", nv.AllToAllConnector(), nv.StaticSynapse(weight=np.array([[0.5, -0.5], [0.2, 0.1]])))
    with pytest.raises(UnsupportedFeatureError, match="negative weights"):
        nv.compile(signed, backend="reference", dt=1.0, seed=0, hardware="spinn5")
    nv.compile(signed, backend="reference", dt=1.0, seed=0, hardware="kapoho-bay")  # mixed signs: one Loihi format
    lif = nv.Network("lif")
    lif.add_population("n", 2, nv.IF_curr_exp())
    loihi = nv.compile(lif, backend="reference", dt=1.0, seed=0, hardware="kapoho-bay")
    with pytest.raises(SimulationError, match="not recorded in the kapoho-bay formats"):
        loihi.record("n", "isyn_exc")


def test_loihi2_mapping_takes_every_limit_from_the_hwspec():
    """Check that the backend kit's Loihi 2 mapping (both backends' integers) follows ``[formats]``, not constants."""
    import dataclasses

    from neurovpr.backendkit import loihi2

    fmt = load_hwspec("loihi2").formats
    net = nv.Network("limits")
    net.add_population("quiet", 3, nv.IF_curr_exp(v_rest=-65.0, v_reset=-65.0, i_offset=0.0))
    pop = net.populations["quiet"]
    ints = loihi2.lif_integers(pop, 1.0, fmt, inhibitory_only=False)
    assert ints.vth_man == 2**14 and ints.vth == 2**20 and ints.du + 1 + ints.ru == 4096
    roomier = dataclasses.replace(fmt, voltage_headroom_bits=5, threshold_exponent=4, decay_bits=10)
    ints = loihi2.lif_integers(pop, 1.0, roomier, inhibitory_only=False)
    assert ints.vth_man == 2 ** (24 - 1 - 4 - 5) and ints.vth == 2**18 and ints.du + 1 + ints.ru == 1024
    with pytest.raises(ValidationError, match="voltage_headroom_bits"):
        loihi2.lif_integers(pop, 1.0, load_hwspec("kapoho-bay").formats, inhibitory_only=False)
    values = np.array([-3.0, 1.0, 200.0])
    wide = loihi2.weight_integers(values, fmt)
    assert (wide.exp, wide.sign_mode, wide.mantissa.tolist()) == (0, "mixed", [-4, 0, 200])
    narrow = loihi2.weight_integers(values, dataclasses.replace(fmt, weight_bits=6, weight_mantissa_bits=4))
    assert (narrow.exp, narrow.mantissa.tolist()) == (2, [0, 0, 48])  # 2 sign bits: 200 / 2**4 = 12.5 -> 12
    with pytest.raises(ValidationError, match="weight exponent of 2"):
        loihi2.weight_integers(values, dataclasses.replace(fmt, weight_bits=6, weight_mantissa_bits=4,
                                                           weight_exponent_max=1), where="group")  # fmt: skip
