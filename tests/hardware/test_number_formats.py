"""Number-format emulation (``nv.compile(..., backend="reference", hardware=NAME)``) against the vendors' own models.

* ``kapoho-bay`` against NengoLoihi's Loihi emulator (``nengo_loihi.Simulator(target="sim")``,
  through the ``nengo-loihi`` backend): the same integers per core block and the same spikes.
* ``loihi2`` against Lava's bit-accurate ``fixed_pt`` process models (``LIF``, ``Dense``,
  ``DelayDense`` on ``Loihi2SimCfg``) loaded with the emulation's integers: the same spikes.
* ``spinn5``: in test_number_formats_spinnaker.py.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

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
def _nengo_loihi():
    pytest.importorskip("nengo_loihi")
    from neurovpr.runtime.registry import get_backend

    try:
        return get_backend("nengo-loihi")
    except nv.NeurovprError:
        nengo_backends = pytest.importorskip("neurovpr.backends.nengo")
        return nengo_backends.NENGO_LOIHI


def _nengo_blocks(sim, population: str) -> list:
    """NengoLoihi's discretised blocks of ``population`` (the emulator's model)."""
    model = sim._sim.model  # the nengo_loihi.Simulator the backend runs
    return [b for b in model.blocks if f"'{population}'" in str(b.label)]


def _compare_kapoho(net: nv.Network, populations: dict[str, float], duration: float = T):
    """Run ``net`` on NengoLoihi and in the kapoho-bay formats; check integers and spikes.

    ``populations`` maps each population to compare to the shift (ms) NengoLoihi's spikes
    need to line up (one step per neuron-to-neuron layer: NengoLoihi delivers on-chip spikes
    one step earlier than docs/semantics.md, the emulation keeps the semantics).
    """
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        oracle = _nengo_loihi().compile(net, dt=1.0, seed=3, hardware=None)
        oracle.run(duration)
    mine = nv.compile(net, backend="reference", dt=1.0, seed=3, hardware="kapoho-bay")
    mine.run(duration)
    q = mine.quantised
    for name, shift in populations.items():
        blocks = [b for b in q.blocks if b["population"] == name]
        theirs = _nengo_blocks(oracle, name)
        assert len(blocks) == len(theirs), name
        for b, nb in zip(blocks, theirs, strict=True):
            c = nb.compartment
            np.testing.assert_array_equal(b["vth"], c.vth, err_msg=f"{name} vth")
            np.testing.assert_array_equal(b["bias"], c.bias, err_msg=f"{name} bias")
            np.testing.assert_array_equal(b["du"], c.decay_u, err_msg=f"{name} decay_u")
            np.testing.assert_array_equal(b["dv"], c.decay_v, err_msg=f"{name} decay_v")
            np.testing.assert_array_equal(b["ref"], c.refract_delay, err_msg=f"{name} refract_delay")
            lo, hi = mine._lay.offsets[name][0] + b["lo"], mine._lay.offsets[name][0] + b["hi"]
            ours = np.sort(q.s_val[(mine._lay.s_post >= lo) & (mine._lay.s_post < hi)])
            theirs_w = np.sort(np.concatenate([np.zeros(0)] + [w.ravel() for s in nb.synapses for w in s.weights]))
            if any(s.pop_type for s in nb.synapses):  # shared (convolutional) weights: each kernel value once
                ours, theirs_w = np.unique(ours), np.unique(theirs_w)
            np.testing.assert_array_equal(ours[ours != 0], theirs_w[theirs_w != 0], err_msg=f"{name} weights")
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


def test_spike_driven_layer_with_a_range_of_weights_matches_nengo_loihi():
    """Excitatory and inhibitory projections, weights over two decades, delays of 1-3 steps."""
    rng = np.random.default_rng(1)
    net = nv.Network("layer")
    net.add_population("src", 30, _arrays(rng, 30, 40, T - 5))
    net.add_population("out", 16, nv.IF_curr_exp(tau_m=20.0, tau_syn_E=5.0, tau_syn_I=5.0, tau_refrac=2.0,
                                                 i_offset=0.2))  # fmt: skip
    exc = [(i, j, 10 ** rng.uniform(-2, 0), float(rng.integers(1, 4))) for i in range(30) for j in range(16)]
    net.connect("src", "out", nv.FromListConnector(conn_list=exc), nv.StaticSynapse(), name="exc")
    inh = [(i, j, rng.uniform(0.1, 0.8)) for i in range(0, 30, 4) for j in range(16) if rng.random() < 0.5]
    net.connect("src", "out", nv.FromListConnector(conn_list=inh), nv.StaticSynapse(delay=2.0),
                receptor_type="inhibitory", name="inh")  # fmt: skip
    _compare_kapoho(net, {"out": 0.0})


def test_convolution_matches_nengo_loihi():
    """A 3x3, 2-filter, mixed-sign convolution of an 8x8 spike map (NengoLoihi's population-weight synapses)."""
    rng = np.random.default_rng(2)
    net = nv.Network("conv")
    net.add_population("img", 64, _arrays(rng, 64, 30, T - 5))
    conv = nv.ConvolutionConnector(input_shape=(1, 8, 8), kernel_shape=(3, 3), out_channels=2)
    net.add_population("fmap", 72, nv.IF_curr_exp(tau_m=10.0, tau_syn_E=2.0, tau_refrac=1.0))
    net.connect("img", "fmap", conv, nv.StaticSynapse(weight=rng.uniform(-1.0, 2.0, (2, 1, 3, 3))))
    _compare_kapoho(net, {"fmap": 0.0})


def test_two_layers_match_nengo_loihi_one_step_apart():
    """Source -> hidden -> output: the hidden layer is identical, the output one step later here.

    NengoLoihi delivers a spike between on-chip populations in the next step (no axonal
    delay); docs/semantics.md (and this emulation, with the chip's synaptic delay) adds the
    projection's one-step delay. With no offset current the output layer is time-invariant,
    so its spikes are NengoLoihi's shifted by exactly one step.
    """
    rng = np.random.default_rng(4)
    net = nv.Network("two")
    net.add_population("src", 20, _arrays(rng, 20, 50, T - 5))
    net.add_population("hid", 10, nv.IF_curr_exp(tau_m=20.0, tau_syn_E=4.0, tau_refrac=2.0, i_offset=0.1))
    net.add_population("out", 3, nv.IF_curr_exp(tau_m=10.0, tau_syn_E=3.0, tau_refrac=1.0))
    net.connect("src", "hid", nv.AllToAllConnector(), nv.StaticSynapse(weight=rng.uniform(0.1, 1.0, (20, 10))))
    net.connect("hid", "out", nv.AllToAllConnector(), nv.StaticSynapse(weight=rng.uniform(0.5, 2.0, (10, 3))))
    _compare_kapoho(net, {"hid": 0.0, "out": 1.0})


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
        oracle = _nengo_loihi().compile(net, dt=1.0, seed=3, hardware=None)
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
        oracle = _nengo_loihi().compile(net, dt=1.0, seed=3, hardware=None)
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
def _lava():
    compat = pytest.importorskip("neurovpr.backends.lava.compat")
    try:
        return compat.import_lava()
    except nv.NeurovprError as exc:
        pytest.skip(f"Lava is not importable: {exc}")


def _run_lava(sim, duration: int) -> dict[str, np.ndarray]:
    """Build the loihi2 emulation's integers as Lava processes, run ``fixed_pt``, return ``(T, n)`` spikes."""
    _lava()
    from lava.magma.core.run_conditions import RunSteps
    from lava.magma.core.run_configs import Loihi2SimCfg
    from lava.proc.dense.process import DelayDense, Dense
    from lava.proc.io.source import RingBuffer
    from lava.proc.lif.process import LIF, LIFRefractory
    from lava.proc.monitor.process import Monitor

    net, lay, q = sim.network, sim._lay, sim.quantised
    models = {}
    lifs, sources = {}, {}
    for b in q.blocks:
        name = b["population"]
        lo = lay.offsets[name][0]
        row = q.params[lo]
        kw = dict(shape=(b["hi"] - b["lo"],), du=int(b["du"][0]), dv=int(b["dv"][0]), bias_mant=b["bias_man"],
                  bias_exp=b["bias_exp"], vth=int(b["vth_man"][0]))  # fmt: skip
        if row[kf.L_REF] > 1:
            from neurovpr.backends.lava.models import PyLifRefractoryModelFixed

            models[LIFRefractory] = PyLifRefractoryModelFixed
            lifs[name] = LIFRefractory(refractory_period=int(row[kf.L_REF]) - 1, **kw)
        else:
            lifs[name] = LIF(**kw)
    for name, pop in net.populations.items():
        if pop.is_source:
            src = pop.cell_type
            data = np.zeros((pop.size, duration), dtype=np.int32)
            data[np.repeat(np.arange(pop.size), np.diff(src.offsets)), np.rint(src.times).astype(int)] = 1
            sources[name] = RingBuffer(data=data)
    for pname, proj in net.projections.items():
        pos = lay.proj_static[pname]
        pre, post, d = lay.proj_pre[pname], lay.proj_post[pname], lay.s_delay[pos]
        for dd in np.unique(d):
            sel = d == dd
            w = np.zeros((net.populations[proj.post].size, net.populations[proj.pre].size), dtype=np.int32)
            w[post[sel], pre[sel]] = q.weights[pname]["value"][sel]
            exp = int(q.weights[pname]["exponent"][sel][0])
            source = proj.pre in sources
            k = int(dd) - 1 if source else int(dd)  # Dense adds one step; a source's spike is sent at its stamp
            conn = DelayDense(weights=w, delays=k, weight_exp=exp) if k else Dense(weights=w, weight_exp=exp)
            (sources[proj.pre] if source else lifs[proj.pre]).s_out.connect(conn.s_in)
            conn.a_out.connect(lifs[proj.post].a_in)
    monitors = {}
    for name, lif in lifs.items():
        monitors[name] = Monitor()
        monitors[name].probe(target=lif.s_out, num_steps=duration)
    anchor = next(iter(lifs.values()))
    anchor.run(
        condition=RunSteps(num_steps=duration), run_cfg=Loihi2SimCfg(select_tag="fixed_pt", exception_proc_model_map=models)
    )
    try:
        out = {}
        for name, mon in monitors.items():
            data = mon.get_data()
            out[name] = np.asarray(next(iter(next(iter(data.values())).values())))
    finally:
        anchor.stop()
    return out


def test_loihi2_two_layers_match_lava_fixed_point():
    """Mixed-sign input with a refractory period and a two-step hidden->output delay, spike for spike."""
    rng = np.random.default_rng(6)
    duration = 200
    net = nv.Network("lava")
    net.add_population("src", 24, _arrays(rng, 24, 40, duration - 5))
    net.add_population("hid", 10, nv.IF_curr_exp(tau_m=20.0, tau_syn_E=5.0, tau_syn_I=5.0, tau_refrac=2.0,
                                                 i_offset=0.15))  # fmt: skip
    net.add_population("out", 4, nv.IF_curr_exp(tau_m=10.0, tau_syn_E=3.0, tau_refrac=0.0))
    net.connect("src", "hid", nv.AllToAllConnector(), nv.StaticSynapse(weight=rng.uniform(0.02, 1.0, (24, 10))))
    net.connect("src", "hid", nv.FixedProbabilityConnector(p_connect=0.3, seed=1), nv.StaticSynapse(weight=0.4, delay=3.0),
                receptor_type="inhibitory", name="inh")  # fmt: skip
    net.connect("hid", "out", nv.AllToAllConnector(), nv.StaticSynapse(weight=rng.uniform(0.3, 1.5, (10, 4)),
                                                                       delay=2.0))  # fmt: skip
    sim = nv.compile(net, backend="reference", dt=1.0, seed=2, hardware="loihi2")
    sim.run(float(duration))
    lava = _run_lava(sim, duration)
    for name in ("hid", "out"):
        steps, idx = np.nonzero(lava[name])
        order = np.lexsort((idx, steps))
        _assert_same(_trains(sim, name), ((steps[order] + 1).astype(float), idx[order]), what=name)


def test_loihi2_winner_take_all_matches_lava_fixed_point():
    """The ``winner_take_all`` conformance network (one synaptic time constant, inputs drawn once): recurrent
    inhibition through one-step delays, spike for spike."""
    duration, rates = 300, np.array([500.0, 1000.0, 1500.0, 2000.0, 4000.0])
    rng = np.random.default_rng(8)
    draws = rng.random((duration - 1, rates.size)) < rates / 4000.0  # at most one spike per 1 ms step: 4x weight
    net = nv.Network("wta")
    net.add_population("input", rates.size, nv.SpikeSourceArray.from_lists(
        [np.flatnonzero(draws[:, k]).astype(float) for k in range(rates.size)]))  # fmt: skip
    net.add_population("exc", rates.size, nv.IF_curr_exp(tau_m=20.0, tau_syn_E=5.0, tau_syn_I=5.0, tau_refrac=2.0))
    net.add_population("inh", rates.size, nv.IF_curr_exp(tau_m=10.0, tau_syn_E=1.0, tau_refrac=2.0))
    net.connect("input", "exc", nv.OneToOneConnector(), nv.StaticSynapse(weight=0.4))
    net.connect("exc", "inh", nv.OneToOneConnector(), nv.StaticSynapse(weight=50.0))
    net.connect("inh", "exc", nv.AllToAllConnector(allow_self_connections=False), nv.StaticSynapse(weight=2.0),
                receptor_type="inhibitory", name="lateral")  # fmt: skip
    sim = nv.compile(net, backend="reference", dt=1.0, seed=2, hardware="loihi2")
    sim.run(float(duration))
    counts = sim.spike_counts("exc")
    assert int(np.argmax(counts)) == rates.size - 1 and counts[:-1].sum() < counts[-1]
    lava = _run_lava(sim, duration)
    for name in ("exc", "inh"):
        steps, idx = np.nonzero(lava[name])
        order = np.lexsort((idx, steps))
        _assert_same(_trains(sim, name), ((steps[order] + 1).astype(float), idx[order]), what=name)


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
