"""The ``lava`` and ``lava-fixed`` backends: the Python 3.11 fix, translation, convolution, refusals."""

from __future__ import annotations

import ast
import importlib.util
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import neurovpr as nv
from neurovpr.backends.lava import LAVA, LAVA_FIXED
from neurovpr.backends.lava.compat import START_METHOD_MODULE, TARGET_MODULE, rewrite_mutable_defaults, rewrite_start_method

_REASON = LAVA.unavailable_reason()
needs_lava = pytest.mark.skipif(_REASON is not None, reason=f"Lava is not available: {_REASON}")

#: lava-fixed rounds decays to 12 bits (Loihi adds 1 to du), weights to 8-bit
#: mantissas with one exponent per projection and truncates u and v every step: its
#: membrane deviates from exact integration by up to about 1.6 % of a PSP's peak.
FIXED_TRACE_REL = 0.03

PSP = {"cm": 0.5, "tau_m": 10.0, "tau_syn_E": 2.0, "tau_syn_I": 2.0, "v_rest": -65.0}


def test_rewrite_turns_instance_defaults_into_factories():
    """The source transform rewrites exactly the defaults that are instances of the module's own dataclasses."""
    source = (
        "from __future__ import annotations\n"
        "from dataclasses import dataclass\n"
        "@dataclass\n"
        "class Inner:\n"
        "    a: int = 0\n"
        "@dataclass\n"
        "class Outer:\n"
        "    x: Inner = Inner()\n"
        "    y: Inner = Inner()\n"
        "    n: int = int()\n"
    )
    tree, count = rewrite_mutable_defaults(source, "<test>")
    assert count == 2  # int() is not one of the module's dataclasses
    namespace: dict = {}
    exec(compile(tree, "<test>", "exec"), namespace)
    first, second = namespace["Outer"](), namespace["Outer"]()
    assert first.x == namespace["Inner"]() and first.x is not second.x


@needs_lava
def test_rewrites_find_their_patterns_in_lava_0_10():
    """The installed var_model.py has the 8 ``= ByteEncoder()`` defaults, and Lava's multiprocessing
    module the one ``set_start_method('fork')`` call."""
    for module, rewrite, expected in (
        (TARGET_MODULE, rewrite_mutable_defaults, 8),
        (START_METHOD_MODULE, rewrite_start_method, 1),
    ):
        spec = importlib.util.find_spec(module)
        assert spec is not None and spec.origin is not None
        tree, count = rewrite(Path(spec.origin).read_text(), spec.origin)
        assert count == expected, module
        assert isinstance(tree, ast.Module)


@needs_lava
def test_lava_imports_after_multiprocessing_was_used():
    """Lava sets the 'fork' start method at import; the fix lets it import after another library set it."""
    used = _run_python(
        "import multiprocessing\n"
        "multiprocessing.get_context().Lock()\n"
        "from neurovpr.backends.lava import LAVA\n"
        "print(LAVA.unavailable_reason())\n"
    )
    assert used.stdout.strip() == "None", used.stdout + used.stderr
    spawned = _run_python(
        "import multiprocessing\n"
        "multiprocessing.set_start_method('spawn')\n"
        "from neurovpr.backends.lava import LAVA\n"
        "print(LAVA.unavailable_reason())\n"
    )
    assert "needs the multiprocessing start method 'fork'" in spawned.stdout and "'spawn'" in spawned.stdout


def _run_python(code: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)


@needs_lava
def test_missing_fix_is_reported_clearly():
    """Without the fix Lava does not import on 3.11, and the backend says which fix is missing and how to install."""
    plain = _run_python(f"import {TARGET_MODULE}")
    if plain.returncode == 0:
        pytest.skip("this Lava imports without the fix (Python 3.10 or a patched install)")
    assert "mutable default" in plain.stderr
    unfixed = _run_python(
        "from neurovpr.backends.lava.compat import import_lava\n"
        "try:\n"
        "    import_lava(apply_fix=False)\n"
        "except Exception as exc:\n"
        "    print(type(exc).__name__, exc)\n"
    )
    assert "BackendUnavailableError" in unfixed.stdout
    assert "fix for lava/magma/compiler/var_model.py is not applied" in unfixed.stdout
    assert "scripts/install_lava.sh" in unfixed.stdout and "--ignore-requires-python" in unfixed.stdout
    # a finder that never sees the module stands for a fix whose pattern no longer matches
    stale = _run_python(
        "import neurovpr as nv\n"
        "from neurovpr.backends.lava import LAVA, compat\n"
        "compat.install_fix = compat.LavaFix\n"
        "print(LAVA.unavailable_reason())\n"
        "try:\n"
        "    LAVA.compile(nv.Network('x'), dt=0.1, seed=1)\n"
        "except nv.BackendUnavailableError as exc:\n"
        "    print(exc)\n"
    )
    assert "found none of the expected `= ByteEncoder()` field defaults" in stale.stdout
    assert "Backend 'lava' is not available" in stale.stdout


def _psp_network(tau_m: float, tau_syn: float, receptor: str) -> nv.Network:
    params = dict(PSP, tau_m=tau_m, tau_syn_E=tau_syn, tau_syn_I=tau_syn)
    net = nv.Network("psp")
    net.add_population("src", 1, nv.SpikeSourceArray.from_lists([[5.0]]))
    net.add_population("post", 1, nv.IF_curr_exp(**params))
    net.connect("src", "post", nv.AllToAllConnector(), nv.StaticSynapse(weight=1.0, delay=1.0), receptor_type=receptor)
    return net


def _exact_psp(t: np.ndarray, *, arrival: float, tau_m: float, tau_syn: float, sign: float) -> np.ndarray:
    s = np.clip(t - arrival, 0.0, None)
    cm = PSP["cm"]
    if math.isclose(tau_m, tau_syn):
        shape = s / cm * np.exp(-s / tau_m)
    else:
        shape = 1.0 / cm * tau_m * tau_syn / (tau_m - tau_syn) * (np.exp(-s / tau_m) - np.exp(-s / tau_syn))
    return PSP["v_rest"] + sign * shape


@needs_lava
@pytest.mark.parametrize(
    ("tau_m", "tau_syn", "receptor"), [(10.0, 2.0, "excitatory"), (7.0, 7.0, "inhibitory")], ids=["exc", "inh-equal-tau"]
)
def test_psp_float_exact_and_fixed_within_tolerance(tau_m, tau_syn, receptor):
    """One spike through a 1 ms delay: floating_pt is exact integration, fixed_pt within its quantisation."""
    dt, t_stop = 0.1, 30.0
    t = np.arange(1, round(t_stop / dt) + 1) * dt
    sign = 1.0 if receptor == "excitatory" else -1.0
    expected = _exact_psp(t, arrival=6.0, tau_m=tau_m, tau_syn=tau_syn, sign=sign)
    peak = np.max(np.abs(expected - PSP["v_rest"]))
    for backend, rel in ((LAVA, 1e-9), (LAVA_FIXED, FIXED_TRACE_REL)):
        sim = backend.compile(_psp_network(tau_m, tau_syn, receptor), dt=dt, seed=1)
        try:
            sim.record("post", "v")
            sim.run(t_stop)
            times, v = sim.trace("post", "v")
        finally:
            sim.close()
        np.testing.assert_allclose(times, t, atol=1e-9)
        np.testing.assert_allclose(v[:, 0], expected, rtol=0, atol=rel * peak, err_msg=backend.name)


@needs_lava
def test_refractory_lif_fires_on_the_step_grid():
    """Under constant current (reset below rest, 2 ms refractory) floating_pt spikes exactly on the grid
    times of the semantics and fixed_pt (Lava's bit-accurate arithmetic with refractoriness) within two steps."""
    dt, t_stop = 0.1, 60.0
    params = {"cm": 0.25, "tau_m": 10.0, "tau_refrac": 2.0, "v_rest": -65.0, "v_reset": -70.0, "v_thresh": -55.0}
    currents = np.array([0.5, 1.0, 2.0])
    net = nv.Network("rate")
    net.add_population("lif", currents.size, nv.IF_curr_exp(i_offset=currents, **params))
    trains = {}
    for backend in (LAVA, LAVA_FIXED):
        sim = backend.compile(net, dt=dt, seed=1)
        try:
            sim.run(t_stop)
            trains[backend.name] = sim.spike_trains("lif")
        finally:
            sim.close()
    r = params["tau_m"] / params["cm"]
    n_ref = round(params["tau_refrac"] / dt)
    for i, current in enumerate(currents):
        v_inf = params["v_rest"] + r * current
        first = math.ceil(params["tau_m"] / dt * math.log((v_inf - params["v_rest"]) / (v_inf - params["v_thresh"])))
        k = math.ceil(params["tau_m"] / dt * math.log((v_inf - params["v_reset"]) / (v_inf - params["v_thresh"])))
        expected = np.arange(first * dt, t_stop + 1e-9, (n_ref + k) * dt)
        for name, tol in (("lava", 1e-9), ("lava-fixed", 2 * dt + 1e-9)):
            times, idx = trains[name]
            got = times[idx == i]
            assert got.size == expected.size, f"{name}, {current} nA"
            np.testing.assert_allclose(got, expected, rtol=0, atol=tol, err_msg=f"{name}, {current} nA")


def _mixed_network() -> nv.Network:
    """Array input; dense, sparse and inhibitory projections; delays of 1 and 3 steps; a recurrent loop."""
    rng = np.random.default_rng(7)
    trains = [np.unique(rng.uniform(0.0, 40.0, 6).round(1)) for _ in range(12)]
    net = nv.Network("mixed")
    net.add_population("src", 12, nv.SpikeSourceArray.from_lists(trains))
    net.add_population("exc", 8, nv.IF_curr_exp(tau_m=15.0, tau_syn_E=4.0, tau_syn_I=4.0, tau_refrac=1.0))
    net.add_population("inh", 3, nv.IF_curr_exp(tau_m=8.0, tau_syn_E=2.0, tau_refrac=0.5, v_reset=-68.0))
    net.connect("src", "exc", nv.AllToAllConnector(), nv.StaticSynapse(weight=nv.Uniform(low=0.0, high=1.5), delay=0.3))
    net.connect("exc", "inh", nv.FixedProbabilityConnector(p_connect=0.3), nv.StaticSynapse(weight=4.0))
    net.connect("inh", "exc", nv.AllToAllConnector(), nv.StaticSynapse(weight=1.0, delay=0.2), receptor_type="inhibitory")
    return net


@needs_lava
def test_lava_float_matches_the_reference_backend_and_fixed_stays_close():
    """A small recurrent network: floating_pt spikes exactly as the exact-integration reference;
    fixed_pt keeps the spike count within 15 % of it. reset() replays the same spikes."""
    net = _mixed_network()
    ref = nv.compile(net, backend="reference", dt=0.1, seed=3)
    ref.run(50.0)
    expected = {pop: ref.spike_trains(pop) for pop in ("exc", "inh")}
    assert expected["exc"][0].size > 10 and expected["inh"][0].size > 0
    sim = LAVA.compile(net, dt=0.1, seed=3, buffer_steps=200)  # 500 steps: three Lava calls
    try:
        sim.run(20.0)
        sim.run(30.0)
        for pop in ("exc", "inh"):
            np.testing.assert_allclose(sim.spike_trains(pop)[0], expected[pop][0], atol=1e-9)
            np.testing.assert_array_equal(sim.spike_trains(pop)[1], expected[pop][1])
        stats = sim.statistics()
        assert stats["steps"] == 500 and stats["neuron_updates"] == 500 * 11
        sim.reset()
        sim.run(50.0)
        np.testing.assert_array_equal(sim.spike_trains("exc")[1], expected["exc"][1])
    finally:
        sim.close()
    with pytest.raises(nv.SimulationError, match="closed"):
        sim.run(1.0)
    fixed = LAVA_FIXED.compile(net, dt=0.1, seed=3)
    try:
        fixed.run(50.0)
        got = fixed.spike_counts("exc").sum()
    finally:
        fixed.close()
    assert abs(got - expected["exc"][0].size) <= 0.15 * expected["exc"][0].size


@needs_lava
def test_convolution_from_a_source_runs_as_lava_conv():
    """A convolution fed by a spike source becomes Lava's Conv process and gives the membrane of its
    connections listed one by one (a Sparse process: one step, the source's natural delay), in
    floating and in fixed point."""
    conv = nv.ConvolutionConnector(input_shape=(2, 5, 6), kernel_shape=(3, 3), out_channels=2, padding=(1, 1))
    kernel = np.random.default_rng(1).normal(6.0, 3.0, conv.weight_shape)
    n_out = int(np.prod(conv.output_shape))
    rng = np.random.default_rng(5)
    trains = [np.unique(rng.uniform(0.0, 15.0, 3).round(1)) for _ in range(60)]

    def network(expanded: bool) -> nv.Network:
        net = nv.Network("conv")
        net.add_population("src", 60, nv.SpikeSourceArray.from_lists(trains))
        net.add_population("out", n_out, nv.IF_curr_exp(tau_m=10.0, v_thresh=-40.0))
        if expanded:
            c = nv.expand(convolved, "src->out", dt=0.5, seed=1)
            listed = nv.FromListConnector(conn_list=np.column_stack([c.pre, c.post, c.weight]))
            net.connect("src", "out", listed, nv.StaticSynapse())
        else:
            net.connect("src", "out", conv, nv.StaticSynapse(weight=kernel))
        return net

    convolved = network(False)
    for backend in (LAVA, LAVA_FIXED):
        traces, kinds = [], []
        for net in (convolved, network(True)):
            sim = backend.compile(net, dt=0.5, seed=1)
            try:
                sim.record("out", "v")
                sim.run(15.0)
                traces.append(sim.trace("out", "v")[1])
                kinds.append(sim.process_kinds()["src->out"])
            finally:
                sim.close()
        assert kinds == ["Conv", "Sparse"]
        assert traces[0].std() > 0.5
        np.testing.assert_allclose(traces[0], traces[1], rtol=0, atol=1e-9, err_msg=backend.name)


def _refusal(backend, net: nv.Network, dt: float = 0.1) -> str:
    with pytest.raises(nv.UnsupportedFeatureError) as info:
        backend.compile(net, dt=dt, seed=1)
    return str(info.value)


@needs_lava
def test_refusals_name_the_feature():
    """What Lava's LIF or Loihi 2 cannot run is refused at compile, naming it."""
    net = nv.Network("taus")
    net.add_population("src", 2, nv.SpikeSourcePoisson(rate=10.0))
    net.add_population("n", 2, nv.IF_curr_exp(tau_syn_E=5.0, tau_syn_I=10.0))
    net.connect("src", "n", nv.AllToAllConnector(), nv.StaticSynapse(weight=0.1))
    net.connect("src", "n", nv.AllToAllConnector(), nv.StaticSynapse(weight=0.1), receptor_type="inhibitory", name="i")
    message = _refusal(LAVA, net)
    assert "tau_syn_E 5 ms != tau_syn_I 10 ms" in message and "'n'" in message

    net = nv.Network("cond")
    net.add_population("c", 2, nv.IF_cond_exp())
    assert "IF_cond_exp" in _refusal(LAVA_FIXED, net)

    net = nv.Network("stdp")
    net.add_population("src", 2, nv.SpikeSourcePoisson(rate=10.0))
    net.add_population("n", 2, nv.IF_curr_exp())
    net.connect("src", "n", nv.AllToAllConnector(), nv.DiehlCookSTDP(weight=0.1), name="learn")
    assert "DiehlCookSTDP" in _refusal(LAVA, net) and "'learn'" in _refusal(LAVA, net)

    net = nv.Network("taum")
    net.add_population("n", 2, nv.IF_curr_exp(tau_m=np.array([10.0, 20.0])))
    assert "per-neuron tau_m" in _refusal(LAVA, net)

    net = nv.Network("delay")
    net.add_population("src", 1, nv.SpikeSourceArray.from_lists([[1.0]]))
    net.add_population("n", 1, nv.IF_curr_exp())
    net.connect("src", "n", nv.OneToOneConnector(), nv.StaticSynapse(weight=1.0, delay=6.4))
    assert "delay 6.4 ms = 64 steps" in _refusal(LAVA_FIXED, net)


def _conv_chain(expanded: bool) -> nv.Network:
    """Spike input -> convolution -> LIF map -> convolution (1 ms, or 2 ms) -> LIF map: neuron-to-neuron convolutions."""
    rng = np.random.default_rng(11)
    first = nv.ConvolutionConnector(input_shape=(1, 10, 10), kernel_shape=(3, 3), out_channels=3, stride=(1, 1))
    second = nv.ConvolutionConnector(input_shape=(3, 8, 8), kernel_shape=(3, 3), out_channels=4, stride=(2, 2), padding=(1, 1))
    third = nv.ConvolutionConnector(input_shape=(4, 4, 4), kernel_shape=(2, 2), out_channels=2)
    cell = {"tau_m": 10.0, "tau_syn_E": 2.0, "tau_syn_I": 2.0, "tau_refrac": 1.0}
    net = nv.Network("conv-chain")
    trains = [np.flatnonzero(rng.random(40) < p).astype(np.float64) for p in rng.uniform(0.05, 0.25, 100)]
    net.add_population("src", 100, nv.SpikeSourceArray.from_lists(trains))
    net.add_population("a", 192, nv.IF_curr_exp(**cell))
    net.add_population("b", 64, nv.IF_curr_exp(**cell))
    net.add_population("c", 18, nv.IF_curr_exp(**cell))
    layers = (("src", "a", first, 3.0, 1.0), ("a", "b", second, 1.5, 1.0), ("b", "c", third, 1.5, 2.0))
    for pre, post, conn, mean, delay in layers:
        kernel = rng.normal(mean, 2.0, conn.weight_shape)
        name = f"{pre}->{post}"
        if expanded:
            probe = nv.Network("probe")
            probe.add_population(pre, net.populations[pre].size, nv.IF_curr_exp())
            probe.add_population(post, net.populations[post].size, nv.IF_curr_exp())
            probe.connect(pre, post, conn, nv.StaticSynapse(weight=kernel, delay=delay), name=name)
            c = nv.expand(probe, name, dt=1.0, seed=1)
            listed = nv.FromListConnector(conn_list=np.column_stack([c.pre, c.post, c.weight, c.delay]))
            net.connect(pre, post, listed, nv.StaticSynapse(), name=name)
        else:
            net.connect(pre, post, conn, nv.StaticSynapse(weight=kernel, delay=delay), name=name)
    return net


@needs_lava
def test_neuron_to_neuron_convolution_runs_as_conv_with_the_same_spikes():
    """Convolutions between neuron populations run as Lava Conv processes (with the one- and two-step
    axonal delays of the semantics) and give, spike for spike, what their connections listed one by
    one give (DelaySparse), in floating and in fixed point; floating point also equals the reference."""
    trains = {}
    for backend in (LAVA, LAVA_FIXED):
        for expanded in (False, True):
            sim = backend.compile(_conv_chain(expanded), dt=1.0, seed=4)
            try:
                sim.run(40.0)
                sim.reset()
                sim.run(40.0)  # after reset(): nothing of the first run is left in the delay buffers
                kinds = sim.process_kinds()
                trains[backend.name, expanded] = {pop: sim.spike_trains(pop) for pop in ("a", "b", "c")}
            finally:
                sim.close()
            if expanded:
                assert kinds == {"src->a": "Sparse", "a->b": "DelaySparse", "b->c": "DelaySparse"}
            else:
                assert kinds == {"src->a": "Conv", "a->b": "Conv", "b->c": "Conv"}
        for pop in ("a", "b", "c"):
            conv, listed = trains[backend.name, False][pop], trains[backend.name, True][pop]
            assert conv[0].size > 5, (backend.name, pop)
            np.testing.assert_array_equal(conv[0], listed[0], err_msg=f"{backend.name} {pop}")
            np.testing.assert_array_equal(conv[1], listed[1], err_msg=f"{backend.name} {pop}")
    ref = nv.compile(_conv_chain(False), backend="reference", dt=1.0, seed=4)
    ref.run(40.0)
    for pop in ("a", "b", "c"):
        times, idx = ref.spike_trains(pop)
        np.testing.assert_allclose(trains["lava", False][pop][0], times, atol=1e-9, err_msg=pop)
        np.testing.assert_array_equal(trains["lava", False][pop][1], idx, err_msg=pop)


@needs_lava
def test_fast_models_compute_what_lavas_models_compute():
    """The backend's DelayDense/DelaySparse models (weights split by delay once) give Lava's own
    activations bit for bit in fixed point and to rounding in float; DelayConv's correlation is
    Lava's convolution (flipped kernel, (x, y, channel) layout)."""
    import scipy.sparse
    from lava.proc.conv import utils as conv_utils
    from lava.proc.dense.models import AbstractPyDelayDenseModel
    from lava.proc.sparse.models import AbstractPyDelaySparseModel

    from neurovpr.backends.lava import connections

    rng = np.random.default_rng(2)
    weights = rng.integers(-128, 128, (30, 40)) * (rng.random((30, 40)) < 0.3)
    delays = rng.integers(0, 4, (30, 40))
    spikes = [rng.random(40) < p for p in (0.0, 0.1, 0.5)]
    cases = [
        (connections.PyDelayDenseModelFixedCached, AbstractPyDelayDenseModel, weights.astype(np.int32), delays, True),
        (connections.PyDelayDenseModelFloatCached, AbstractPyDelayDenseModel, weights * 0.37, delays, False),
        (
            connections.PyDelaySparseModelFixedCached,
            AbstractPyDelaySparseModel,
            scipy.sparse.csr_matrix(weights.astype(np.int32)),
            scipy.sparse.csr_matrix(delays * (weights != 0)),
            True,
        ),
        (
            connections.PyDelaySparseModelFloatCached,
            AbstractPyDelaySparseModel,
            scipy.sparse.csr_matrix(weights * 0.37),
            scipy.sparse.csr_matrix(delays * (weights != 0)),
            False,
        ),
    ]
    for fast_cls, lava_cls, w, d, exact in cases:
        model = fast_cls({})
        model.weights, model.delays = w, d
        model.a_buff = np.zeros((30, int(delays.max()) + 1))
        for s in spikes:
            got, want = model.calc_act(s), lava_cls.calc_act(model, s)
            assert got.shape == want.shape
            if exact:
                np.testing.assert_array_equal(got, want, err_msg=fast_cls.__name__)
            else:
                np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-12, err_msg=fast_cls.__name__)
    kernel = rng.normal(size=(4, 3, 2, 5))  # (C_out, KX, KY, C_in)
    image = (rng.random((9, 7, 5)) < 0.4).astype(np.float64)
    for stride, padding in (((1, 1), (0, 0)), ((2, 3), (1, 2))):
        want = conv_utils.conv_scipy(image, kernel, (3, 2), stride, padding, (1, 1), 1)
        got = connections._correlate(image, kernel[:, ::-1, ::-1, :], stride, padding)
        np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-12)


@needs_lava
def test_runtime_stops_at_interpreter_exit():
    """A simulation that is run and never closed does not keep the interpreter from exiting."""
    done = _run_python(
        "import neurovpr as nv\n"
        "net = nv.Network('exit')\n"
        "net.add_population('src', 4, nv.SpikeSourcePoisson(rate=100.0))\n"
        "net.add_population('n', 4, nv.IF_curr_exp())\n"
        "net.connect('src', 'n', nv.OneToOneConnector(), nv.StaticSynapse(weight=2.0))\n"
        "sim = nv.compile(net, backend='lava', dt=1.0, seed=1)\n"
        "sim.run(5.0)\n"
        "print('ran', sim.time)\n"
    )
    assert done.returncode == 0, done.stderr[-2000:]
    assert "ran 5.0" in done.stdout


def test_fixed_delay_limit_is_the_hwspecs_delay_field():
    """lava-fixed's delay limit is the loihi2 hwspec's 6-bit delay field (63 steps, Lava's DelayDense range).

    It differs on purpose from ``[timing] max_delay_steps`` (62, Loihi 1's chip figure that
    ``neurovpr check`` uses): see ``max_fixed_delay_steps``.
    """
    from neurovpr.backends.lava.capabilities import compile_problems, max_fixed_delay_steps
    from neurovpr.hardware.hwspec import load_hwspec

    spec = load_hwspec("loihi2")
    assert max_fixed_delay_steps() == 2**spec.rules.delay_bits - 1 == 63
    assert spec.timing.max_delay_steps == 62
    for steps, refused in ((63, False), (64, True)):
        net = nv.Network("delay")
        net.add_population("a", 1, nv.IF_curr_exp())
        net.add_population("b", 1, nv.IF_curr_exp())
        net.connect("a", "b", nv.OneToOneConnector(), nv.StaticSynapse(weight=1.0, delay=steps * 0.1), name="ab")
        problems = compile_problems(net, {"ab": nv.expand(net, "ab", dt=0.1, seed=0)}, 0.1, fixed=True)
        assert problems == ([f"delay {steps * 0.1:g} ms = {steps} steps (projection 'ab'; Loihi 2 delays are at most 63 steps)"]
                            if refused else [])  # fmt: skip
