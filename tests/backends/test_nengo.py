"""The ``nengo`` and ``nengo-loihi`` backends: translation, timing, convolution, refusals, core usage."""

from __future__ import annotations

import math
import subprocess
import sys

import numpy as np
import pytest

pytest.importorskip("nengo")
pytest.importorskip("nengo_loihi")

import neurovpr as nv
from neurovpr.backends.nengo import NENGO, NENGO_LOIHI

#: NengoLoihi rounds decays to 12 bits and weights to Loihi's 8-bit mantissas: its
#: membrane deviates from exact integration by up to about 1 % of the PSP peak.
LOIHI_TRACE_REL = 0.02

PSP = {"cm": 0.5, "tau_m": 10.0, "tau_syn_E": 2.0, "tau_syn_I": 2.0, "v_rest": -65.0}


def _closed_form_rate(i_offset: float, *, tau_m: float, cm: float, tau_refrac: float, v_span: float) -> float:
    """PyNN's continuous-time LIF rate (Hz) under a constant current, reset = rest."""
    drive = tau_m / cm * i_offset
    return 1000.0 / (tau_refrac + tau_m * math.log(drive / (drive - v_span)))


def _psp_network(delay: float) -> nv.Network:
    net = nv.Network("psp")
    net.add_population("src", 1, nv.SpikeSourceArray.from_lists([[5.0]]))
    net.add_population("post", 1, nv.IF_curr_exp(**PSP))
    net.connect("src", "post", nv.AllToAllConnector(), nv.StaticSynapse(weight=1.0, delay=delay))
    return net


def _exact_psp(t: np.ndarray, arrival: float) -> np.ndarray:
    s = np.clip(t - arrival, 0.0, None)
    tau_m, tau_s, cm = PSP["tau_m"], PSP["tau_syn_E"], PSP["cm"]
    return PSP["v_rest"] + 1.0 / cm * tau_m * tau_s / (tau_m - tau_s) * (np.exp(-s / tau_m) - np.exp(-s / tau_s))


def test_constant_current_rates():
    """Nengo fires at PyNN's closed-form rate (it places spikes between steps); NengoLoihi at the step-grid rate."""
    currents = np.array([0.8, 1.2, 2.0])
    params = {"tau_m": 20.0, "cm": 1.0, "tau_refrac": 2.0}
    net = nv.Network("rates")
    net.add_population("lif", currents.size, nv.IF_curr_exp(i_offset=currents, v_thresh=-50.0, **params))
    dt, t_stop = 0.1, 1000.0
    counts = {}
    for backend in (NENGO, NENGO_LOIHI):
        sim = backend.compile(net, dt=dt, seed=1)
        sim.run(t_stop)
        counts[backend.name] = sim.spike_counts("lif")
    for i, current in enumerate(currents):
        rate = _closed_form_rate(current, v_span=15.0, **params)
        assert abs(counts["nengo"][i] - rate * t_stop / 1000.0) <= 1.0
        drive = params["tau_m"] / params["cm"] * current
        k = math.ceil(params["tau_m"] / dt * math.log(drive / (drive - 15.0)))
        grid_rate = 1000.0 / (dt * (round(params["tau_refrac"] / dt) + k))
        assert abs(counts["nengo-loihi"][i] - grid_rate * t_stop / 1000.0) <= 0.02 * grid_rate + 1.0


@pytest.mark.parametrize("delay", [0.1, 1.0])
def test_psp_is_exact_on_nengo_and_close_on_loihi(delay):
    """One input spike: Nengo reproduces exact integration to round-off (delay included); NengoLoihi within its tolerance."""
    dt, t_stop = 0.1, 40.0
    t = np.arange(1, round(t_stop / dt) + 1) * dt
    expected = _exact_psp(t, 5.0 + delay)
    peak = np.max(np.abs(expected - PSP["v_rest"]))
    for backend, rel in ((NENGO, 1e-9), (NENGO_LOIHI, LOIHI_TRACE_REL)):
        sim = backend.compile(_psp_network(delay), dt=dt, seed=1)
        sim.record("post", "v")
        sim.run(t_stop)
        times, v = sim.trace("post", "v")
        np.testing.assert_allclose(times, t, atol=1e-9)
        np.testing.assert_allclose(v[:, 0], expected, rtol=0, atol=rel * peak, err_msg=backend.name)
        assert np.all(v[t <= 5.0 + delay + 1e-9, 0] == PSP["v_rest"])


def test_spike_latency_between_neurons():
    """A neuron spike acts on its target one step after arrival on Nengo; NengoLoihi delivers it one step earlier."""
    dt = 0.1
    net = nv.Network("chain")
    net.add_population("src", 1, nv.SpikeSourceArray.from_lists([[1.0]]))
    net.add_population("a", 1, nv.IF_curr_exp(tau_m=20.0, tau_syn_E=5.0, tau_refrac=5.0))
    net.add_population("b", 1, nv.IF_curr_exp(tau_m=20.0, tau_syn_E=5.0))
    net.connect("src", "a", nv.OneToOneConnector(), nv.StaticSynapse(weight=50.0))
    net.connect("a", "b", nv.OneToOneConnector(), nv.StaticSynapse(weight=1.0))
    onset = {}
    for backend in (NENGO, NENGO_LOIHI):
        sim = backend.compile(net, dt=dt, seed=1)
        sim.record("b", "v")
        sim.run(4.0)
        spikes, _ = sim.spike_trains("a")
        assert spikes.size == 1
        t, v = sim.trace("b", "v")
        onset[backend.name] = (spikes[0], t[np.flatnonzero(v[:, 0] > -65.0 + 1e-9)[0]])
    spike, first = onset["nengo"]
    # spike at t_s (end of its step) arrives at t_s + dt and acts in the step ending at t_s + 2 dt
    assert first == pytest.approx(spike + 2 * dt)
    spike, first = onset["nengo-loihi"]
    assert first == pytest.approx(spike + dt)


@pytest.mark.parametrize(("padding", "stride"), [((0, 0), (1, 1)), ((1, 1), (1, 1)), ((0, 0), (2, 2))])
def test_convolution_equals_its_expanded_connections(padding, stride):
    """A ConvolutionConnector (nengo.Convolution) gives the same membrane as its connections listed one by one."""
    conv = nv.ConvolutionConnector(input_shape=(2, 6, 6), kernel_shape=(3, 3), out_channels=3, stride=stride, padding=padding)
    kernel = np.random.default_rng(0).normal(0.5, 0.5, conv.weight_shape)
    n_out = int(np.prod(conv.output_shape))

    def network(expanded: bool) -> nv.Network:
        net = nv.Network("conv")
        net.add_population("src", 72, nv.SpikeSourcePoisson(rate=200.0))
        net.add_population("out", n_out, nv.IF_curr_exp(tau_m=10.0, tau_refrac=1.0))
        if not expanded:
            net.connect("src", "out", conv, nv.StaticSynapse(weight=kernel))
            return net
        c = nv.expand(convolved, "src->out", dt=0.5, seed=1)
        listed = nv.FromListConnector(conn_list=np.column_stack([c.pre, c.post, c.weight]))
        net.connect("src", "out", listed, nv.StaticSynapse())
        return net

    convolved = network(False)
    for backend in (NENGO, NENGO_LOIHI):
        traces = []
        for net in (convolved, network(True)):
            sim = backend.compile(net, dt=0.5, seed=3)
            sim.record("out", "v")
            sim.run(30.0)
            traces.append(sim.trace("out", "v")[1])
        assert traces[0].std() > 1.0
        np.testing.assert_allclose(traces[0], traces[1], rtol=0, atol=1e-9, err_msg=backend.name)


def _refusal(backend, net: nv.Network, dt: float = 0.1) -> str:
    with pytest.raises(nv.UnsupportedFeatureError) as info:
        backend.compile(net, dt=dt, seed=1)
    return str(info.value)


def test_refusals_name_the_feature():
    """What Nengo or NengoLoihi cannot run is refused at compile, naming the feature and where."""
    net = nv.Network("cond")
    net.add_population("src", 2, nv.SpikeSourcePoisson(rate=10.0))
    net.add_population("c", 2, nv.IF_cond_exp())
    net.connect("src", "c", nv.AllToAllConnector(), nv.StaticSynapse(weight=0.01))
    assert "IF_cond_exp" in _refusal(NENGO, net) and "'c'" in _refusal(NENGO, net)

    net = nv.Network("stdp")
    net.add_population("src", 2, nv.SpikeSourcePoisson(rate=10.0))
    net.add_population("n", 2, nv.IF_curr_exp())
    net.connect("src", "n", nv.AllToAllConnector(), nv.STDPMechanism(weight=0.1), name="plastic")
    assert "STDPMechanism" in _refusal(NENGO_LOIHI, net) and "'plastic'" in _refusal(NENGO_LOIHI, net)

    net = nv.Network("taus")
    net.add_population("src", 2, nv.SpikeSourcePoisson(rate=10.0))
    net.add_population("n", 2, nv.IF_curr_exp(tau_syn_E=5.0, tau_syn_I=10.0))
    net.connect("src", "n", nv.AllToAllConnector(), nv.StaticSynapse(weight=0.1), name="e")
    net.connect("src", "n", nv.AllToAllConnector(), nv.StaticSynapse(weight=0.1), receptor_type="inhibitory", name="i")
    message = _refusal(NENGO_LOIHI, net)
    assert "tau_syn_E 5 ms != tau_syn_I 10 ms" in message and "'n'" in message
    NENGO.compile(net, dt=0.1, seed=1).close()  # Nengo filters each connection separately

    net = nv.Network("delay")
    net.add_population("src", 1, nv.SpikeSourcePoisson(rate=10.0))
    net.add_population("a", 1, nv.IF_curr_exp())
    net.add_population("b", 1, nv.IF_curr_exp())
    net.connect("src", "a", nv.OneToOneConnector(), nv.StaticSynapse(weight=1.0, delay=2.0))
    net.connect("a", "b", nv.OneToOneConnector(), nv.StaticSynapse(weight=1.0, delay=0.5))
    message = _refusal(NENGO_LOIHI, net)
    assert "delay 0.5 ms" in message and "'a->b'" in message

    net = nv.Network("pad")
    conv = nv.ConvolutionConnector(input_shape=(1, 6, 6), kernel_shape=(3, 3), stride=(2, 2), padding=(1, 1))
    net.add_population("src", 36, nv.SpikeSourcePoisson(rate=10.0))
    net.add_population("out", 9, nv.IF_curr_exp())
    net.connect("src", "out", conv, nv.StaticSynapse(weight=np.ones((1, 1, 3, 3))))
    assert "padding (1, 1)" in _refusal(NENGO, net)

    net = nv.Network("init")
    net.add_population("n", 2, nv.IF_curr_exp(), v_init=-60.0)
    assert "initial voltage -60 mV != v_reset -65 mV" in _refusal(NENGO_LOIHI, net)


def test_broken_import_names_the_reason_and_the_extra():
    """A Nengo that does not import is reported with the import error and the extra that installs it."""
    code = (
        "import sys; sys.modules['nengo'] = None\n"
        "import neurovpr as nv\n"
        "from neurovpr.backends.nengo import NENGO\n"
        "print(NENGO.unavailable_reason())\n"
        "try:\n"
        "    NENGO.compile(nv.Network('x'), dt=0.1, seed=1)\n"
        "except nv.BackendUnavailableError as exc:\n"
        "    print(exc)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert "cannot import nengo (ModuleNotFoundError: import of nengo halted" in out
    assert "pip install 'neurovpr[nengo]'" in out
    assert "Backend 'nengo' is not available" in out


def test_nengo_loihi_reports_its_blocks_and_cores():
    """NengoLoihi's own splitting is reported per block; a 1500-neuron population takes two cores."""
    net = nv.Network("blocks")
    net.add_population("src", 100, nv.SpikeSourcePoisson(rate=20.0))
    net.add_population("exc", 1500, nv.IF_curr_exp())
    net.add_population("inh", 50, nv.IF_curr_exp(tau_m=10.0))
    net.connect("src", "exc", nv.FixedProbabilityConnector(p_connect=0.1), nv.StaticSynapse(weight=1.0))
    net.connect("exc", "inh", nv.FixedProbabilityConnector(p_connect=0.05), nv.StaticSynapse(weight=0.5))
    net.connect("inh", "exc", nv.AllToAllConnector(), nv.StaticSynapse(weight=0.2), receptor_type="inhibitory")
    sim = NENGO_LOIHI.compile(net, dt=1.0, seed=5)
    usage = sim.loihi_usage()
    assert usage["cores"] == 3 and usage["chips"] == 1
    blocks = sim.loihi_blocks()
    assert [b["population"] for b in blocks] == ["exc", "exc", "inh"]
    assert [b["compartments"] for b in blocks] == [750, 750, 50]
    assert blocks[2]["in_axons"] == 1500  # one axon per excitatory neuron
    for block in blocks:
        assert 0 < block["synapse_bits"] <= block["limits"]["synapse_bits"]
        assert block["compartments"] <= block["limits"]["compartments"]
    assert usage["inputs"] and usage["inputs"][0]["axons"] > 0
    shaped = NENGO_LOIHI.compile(net, dt=1.0, seed=5, block_shapes={"inh": ((25,), (50,))})
    assert shaped.loihi_usage()["cores"] == 4
    with pytest.raises(nv.SimulationError, match="does not map onto Loihi cores"):
        NENGO.compile(net, dt=1.0, seed=5).loihi_blocks()


@pytest.mark.parametrize("backend", [NENGO, NENGO_LOIHI], ids=["nengo", "nengo-loihi"])
def test_reset_replays_and_activity_is_counted(backend):
    """After reset() the same input gives the same spikes; statistics count steps, spikes and synaptic events."""
    rng = np.random.default_rng(2)
    trains = [np.sort(rng.uniform(0.0, 50.0, 8)).round(1) for _ in range(20)]
    net = nv.Network("replay")
    net.add_population("src", 20, nv.SpikeSourceArray.from_lists(trains))
    net.add_population("n", 10, nv.IF_curr_exp(tau_m=10.0, tau_refrac=1.0))
    net.connect("src", "n", nv.FixedProbabilityConnector(p_connect=0.5), nv.StaticSynapse(weight=nv.Uniform(low=0.0, high=4.0)))
    sim = backend.compile(net, dt=0.5, seed=4)
    sim.run(30.0)
    sim.run(30.0)  # across runs, spikes in flight carry over
    first = sim.spike_trains("n")
    assert first[0].size > 5
    sim.reset()
    assert sim.time == 0.0
    sim.run(60.0)
    second = sim.spike_trains("n")
    np.testing.assert_array_equal(first[0], second[0])
    np.testing.assert_array_equal(first[1], second[1])
    stats = sim.statistics()
    assert stats["steps"] == 240 and stats["neuron_updates"] == 2400
    src_counts = sim.spike_counts("src")
    pre, _ = sim.connections("src->n")
    out_degree = np.bincount(pre, minlength=20)
    assert stats["synaptic_events"] == 2 * int(src_counts @ out_degree)
    assert stats["spikes"] == 2 * int(src_counts.sum() + second[0].size)


def test_weights_and_recording_change_only_at_time_zero():
    """set_weights and record rebuild the Nengo model: allowed at time 0 (and after reset), refused mid-run."""
    net = nv.Network("w")
    net.add_population("src", 1, nv.SpikeSourceArray.from_lists([[1.0]]))
    net.add_population("n", 1, nv.IF_curr_exp(**PSP))
    net.connect("src", "n", nv.OneToOneConnector(), nv.StaticSynapse(weight=1.0))
    sim = NENGO.compile(net, dt=0.1, seed=1)
    sim.set_weights("src->n", [2.0])
    sim.record("n", "v")
    sim.run(10.0)
    doubled = sim.trace("n", "v")[1][:, 0] - PSP["v_rest"]
    t = np.arange(1, 101) * 0.1
    np.testing.assert_allclose(doubled, 2.0 * (_exact_psp(t, 1.1) - PSP["v_rest"]), rtol=0, atol=1e-9)
    np.testing.assert_array_equal(sim.weights("src->n", format="list"), [2.0])
    with pytest.raises(nv.SimulationError, match="call reset"):
        sim.set_weights("src->n", [1.0])
    sim.reset()
    sim.set_weights("src->n", [1.0])
    sim.run(10.0)
    np.testing.assert_allclose(sim.trace("n", "v")[1][:, 0], _exact_psp(t, 1.1), rtol=0, atol=1e-9)

    other = nv.Network("late")
    other.add_population("a", 1, nv.IF_curr_exp(i_offset=1.0))
    other.add_population("b", 1, nv.IF_curr_exp())
    late = NENGO.compile(other, dt=0.1, seed=1)
    late.run(1.0)
    with pytest.raises(nv.SimulationError, match="call reset"):
        late.record("b", "v")
