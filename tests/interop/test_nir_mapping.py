"""The NIR parameter mapping: analytic responses (exact reading) and the Euler map (euler reading)."""

from __future__ import annotations

import numpy as np
import pytest

import neurovpr as nv

nir = pytest.importorskip("nir")

from neurovpr.interop.nir import TAU_DELTA_MS, nir_to_network  # noqa: E402
from neurovpr.interop.nir.mapping import NEURON_NODES, cell_from_node, node_fields_from_cell  # noqa: E402

H = 0.1  # ms, the NIR step (spike area)


def _node(kind: str, n: int = 3):
    rng = np.random.default_rng(7)
    tau_syn, tau_mem = rng.uniform(2e-3, 5e-3, n), rng.uniform(8e-3, 30e-3, n)
    r, w_in = rng.uniform(5.0, 50.0, n), rng.uniform(0.5, 2.0, n)
    v_leak, v_th, v_reset = rng.uniform(-1, 0, n), rng.uniform(1, 2, n), rng.uniform(-1, 0, n)
    return {
        "CubaLIF": lambda: nir.CubaLIF(
            tau_syn=tau_syn, tau_mem=tau_mem, r=r, v_leak=v_leak, v_threshold=v_th, v_reset=v_reset, w_in=w_in
        ),
        "CubaLI": lambda: nir.CubaLI(tau_syn=tau_syn, tau_mem=tau_mem, r=r, v_leak=v_leak, w_in=w_in),
        "LIF": lambda: nir.LIF(tau=tau_mem, r=r, v_leak=v_leak, v_threshold=v_th, v_reset=v_reset),
        "LI": lambda: nir.LI(tau=tau_mem, r=r, v_leak=v_leak),
        "IF": lambda: nir.IF(r=r, v_threshold=v_th, v_reset=v_reset),
        "I": lambda: nir.I(r=r),
    }[kind]()


@pytest.mark.parametrize("integration", ["exact", "euler"])
@pytest.mark.parametrize("kind", sorted(NEURON_NODES))
def test_every_neuron_node_maps_to_a_cell_and_back(kind: str, integration: str) -> None:
    node = _node(kind)
    cell, _, _ = cell_from_node(node, kind, 3, dt=H, integration=integration, where="test node")
    back_kind, fields = node_fields_from_cell(cell, 3, receptors={"excitatory"}, dt=H, integration=integration, where="pop")
    assert back_kind == kind
    for name, value in fields.items():
        if kind in ("CubaLIF", "CubaLI") and name in ("r", "w_in"):
            continue  # the gauge: only r * w_in is physical, checked below
        np.testing.assert_allclose(value, np.asarray(getattr(node, name), dtype=float), rtol=1e-10, err_msg=name)
    if kind in ("CubaLIF", "CubaLI"):
        np.testing.assert_allclose(fields["r"] * fields["w_in"], node.r * node.w_in, rtol=1e-10)


def _single_neuron_graph(neuron, weight: float) -> nir.NIRGraph:
    return nir.NIRGraph(
        nodes={"in": nir.Input(input_type={"input": np.array([1])}), "w": nir.Linear(weight=np.array([[weight]])),
               "n": neuron, "out": nir.Output(output_type={"output": np.array([1])})},
        edges=[("in", "w"), ("w", "n"), ("n", "out")],
    )  # fmt: skip


def _membrane(graph, integration: str, dt: float, steps: int, spike_step: int = 0) -> tuple[np.ndarray, np.ndarray]:
    net = nir_to_network(graph, dt=H, integration=integration).network
    sim = nv.compile(net, backend="reference", dt=dt, seed=0)
    sim.record("n", "v")
    sim.run(steps * dt, inputs={"in": [[spike_step * dt]]})
    return sim.trace("n", "v")


@pytest.mark.parametrize("dt", [0.1, 0.25])
def test_exact_cubalif_psp_matches_the_nir_ode(dt: float) -> None:
    """tau_mem dv/dt = -v + r I, tau_syn dI/dt = -I + w_in W h delta(t): the analytic PSP at every step end."""
    tau_syn, tau_mem, r, w_in, weight = 2e-3, 10e-3, 3.0, 1.5, 0.8
    neuron = nir.CubaLIF(tau_syn=np.array([tau_syn]), tau_mem=np.array([tau_mem]), r=np.array([r]), v_leak=np.zeros(1),
                         v_threshold=np.array([1e9]), v_reset=np.zeros(1), w_in=np.array([w_in]))  # fmt: skip
    t, v = _membrane(_single_neuron_graph(neuron, weight), "exact", dt, 200)
    arrival = dt  # the IR's one-step minimum delay
    s = (t - arrival) / 1000.0  # seconds since the spike arrived
    amp = w_in * weight * (H / 1000.0) / tau_syn
    expected = np.where(s >= 0, r * amp * tau_syn / (tau_syn - tau_mem) * (np.exp(-s / tau_syn) - np.exp(-s / tau_mem)), 0.0)
    np.testing.assert_allclose(v[:, 0], expected, rtol=1e-9, atol=1e-15)


def test_exact_lif_and_if_are_dirac_responses() -> None:
    """LIF: v = (r W h / tau) e^(-t/tau) after the spike; IF: v = r W h, both at every step end."""
    dt, weight, r, tau = 0.1, 0.7, 4.0, 5e-3
    lif = nir.LIF(tau=np.array([tau]), r=np.array([r]), v_leak=np.zeros(1), v_threshold=np.array([1e9]), v_reset=np.zeros(1))
    t, v = _membrane(_single_neuron_graph(lif, weight), "exact", dt, 100)
    s = (t - dt) / 1000.0
    np.testing.assert_allclose(v[:, 0], np.where(s > 0, r * weight * (H / 1000.0) / tau * np.exp(-s / tau), 0.0), rtol=1e-9)
    integ = nir.IF(r=np.array([r]), v_threshold=np.array([1e9]), v_reset=np.zeros(1))
    t, v = _membrane(_single_neuron_graph(integ, weight), "exact", dt, 50)
    np.testing.assert_allclose(v[:, 0], np.where(t > dt, r * weight * H / 1000.0, 0.0), rtol=1e-12)
    net = nir_to_network(_single_neuron_graph(lif, weight), dt=H).network
    assert net.populations["n"].cell_type.tau_syn_E == TAU_DELTA_MS


def test_exact_lif_bias_is_a_constant_current() -> None:
    """Affine bias b into a LIF: v = r b (1 - e^(-t/tau)), exactly."""
    tau, r, b = 10e-3, 2.0, 0.3
    graph = nir.NIRGraph(
        nodes={"in": nir.Input(input_type={"input": np.array([1])}), "w": nir.Affine(weight=np.zeros((1, 1)), bias=np.array([b])),
               "n": nir.LIF(tau=np.array([tau]), r=np.array([r]), v_leak=np.zeros(1), v_threshold=np.array([1e9]),
                            v_reset=np.zeros(1))},
        edges=[("in", "w"), ("w", "n")],
    )  # fmt: skip
    net = nir_to_network(graph, dt=H).network
    sim = nv.compile(net, backend="reference", dt=0.1, seed=0)
    sim.record("n", "v")
    sim.run(30.0)
    t, v = sim.trace("n", "v")
    np.testing.assert_allclose(v[:, 0], r * b * (1 - np.exp(-t / 1000.0 / tau)), rtol=1e-9)


def _euler_reference(alpha, beta, c_in, c_m, w, spikes, thresh):
    """The forward-Euler map a peer (snnTorch) runs, with reset to zero."""
    i = np.zeros(w.shape[0])
    v = np.zeros(w.shape[0])
    out = np.zeros((spikes.shape[0], w.shape[0]))
    for k, s in enumerate(spikes):
        i = alpha * i + c_in * (w @ s)
        v = beta * v + c_m * i
        out[k] = v > thresh
        v[out[k] > 0] = 0.0
    return out


@pytest.mark.parametrize("synaptic", [True, False])
def test_euler_reading_reproduces_the_euler_map_spike_for_spike(synaptic: bool) -> None:
    rng = np.random.default_rng(1)
    n_in, n, steps, h_s = 12, 9, 400, H / 1000.0
    w = rng.normal(0.4, 0.6, (n, n_in))
    tau_syn, tau_mem, r, w_in = np.full(n, 5e-4), np.full(n, 1.2e-3), np.full(n, 7.0), np.full(n, 2.5)
    if synaptic:
        neuron = nir.CubaLIF(tau_syn=tau_syn, tau_mem=tau_mem, r=r, v_leak=np.zeros(n), v_threshold=np.ones(n),
                             v_reset=np.zeros(n), w_in=w_in)  # fmt: skip
        alpha, c_in = 1 - h_s / tau_syn, w_in * h_s / tau_syn
    else:
        neuron = nir.LIF(tau=tau_mem, r=r, v_leak=np.zeros(n), v_threshold=np.ones(n), v_reset=np.zeros(n))
        alpha, c_in = np.zeros(n), np.ones(n)
    graph = nir.NIRGraph(
        nodes={"in": nir.Input(input_type={"input": np.array([n_in])}), "w": nir.Linear(weight=w), "n": neuron},
        edges=[("in", "w"), ("w", "n")],
    )
    spikes = (rng.random((steps, n_in)) < 0.25).astype(float)
    expected = _euler_reference(alpha, 1 - h_s / tau_mem, c_in, r * h_s / tau_mem, w, spikes, 1.0)
    net = nir_to_network(graph, dt=H, integration="euler").network
    sim = nv.compile(net, backend="reference", dt=H, seed=0)
    sim.run((steps + 5) * H, inputs={"in": [list(np.flatnonzero(spikes[:, i]) * H) for i in range(n_in)]})
    t, idx = sim.spike_trains("n")
    got = np.zeros((steps + 10, n))
    got[np.rint(t / H).astype(int) - 2, idx] = 1  # one layer: spikes stamped 2 steps after a zero-latency peer
    assert expected.sum() > 100
    np.testing.assert_array_equal(got[:steps], expected)
