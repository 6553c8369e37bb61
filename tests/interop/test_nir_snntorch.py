"""Round trips with a real peer, snnTorch: its graphs run here, ours run there, spike for spike.

snnTorch simulates a NIR graph with forward-Euler coefficients at its step of 1e-4 s
(``beta = 1 - dt / tau``), so both directions use ``integration="euler", dt=0.1``.
Then the per-step maps are the same and the only differences are:

* latency: a NIR edge is instantaneous, an IR projection delivers one step later and
  spikes are stamped at the end of their step, so layer ``L`` spikes ``2 L`` steps after
  snnTorch's (compared after that shift);
* arithmetic: snnTorch runs in float32, neurovpr in float64, so a membrane within
  ~1e-6 of threshold may cross in one and not the other. A flip then changes that
  neuron's later spikes (reset) and those downstream. Tolerance: at most 1% of the
  spike-train entries (neuron x step) that hold a spike in either simulation differ,
  and no neuron's spike count differs by more than 2. Measured here: 0 differences.

Biases are left out of the spike-for-spike comparisons: a bias drives a neuron from
t = 0 in neurovpr but only from the step its layer is reached in the shifted snnTorch
run, and through CubaLIF's synapse it rises with tau_syn in NIR (see the mapping table).
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

import neurovpr as nv

nir = pytest.importorskip("nir")
torch = pytest.importorskip("torch")
snn = pytest.importorskip("snntorch")
pytest.importorskip("nirtorch")

from snntorch.export_nir import export_to_nir  # noqa: E402
from snntorch.import_nir import import_from_nir  # noqa: E402

from neurovpr.interop.nir import export_nir, import_nir, read_graph  # noqa: E402

H = 0.1  # ms: snnTorch's NIR step, 1e-4 s
pytestmark = pytest.mark.filterwarnings("ignore")


def _assert_within_tolerance(ours: np.ndarray, theirs: np.ndarray, what: str) -> None:
    assert theirs.sum() > 0, f"{what}: the peer produced no spikes; the comparison would be empty"
    differ = np.abs(ours - theirs).sum()
    either = np.logical_or(ours > 0, theirs > 0).sum()
    assert differ <= 0.01 * either, f"{what}: {differ:g} of {either} spike entries differ"
    assert np.abs(ours.sum(0) - theirs.sum(0)).max() <= 2, f"{what}: a neuron's spike count differs by more than 2"


def _run_here(network: nv.Network, inp: str, spikes: np.ndarray, pops: dict[str, int]) -> dict[str, np.ndarray]:
    """Spike rasters (step x neuron) of ``pops`` (name -> layer), shifted back by 2 steps per layer."""
    steps = spikes.shape[0]
    flat = spikes.reshape(steps, -1)
    sim = nv.compile(network, backend="reference", dt=H, seed=0)
    trains = [list(np.flatnonzero(flat[:, i]) * H) for i in range(flat.shape[1])]
    sim.run((steps + 2 * max(pops.values()) + 2) * H, inputs={inp: trains})
    out = {}
    for pop, layer in pops.items():
        t, idx = sim.spike_trains(pop)
        raster = np.zeros((steps + 4 * layer + 4, network.populations[pop].size))
        raster[np.rint(t / H).astype(int) - 2 * layer, idx] = 1
        out[pop] = raster[:steps]
    return out


def _peer_rasters(model, spikes: np.ndarray, record: dict[int, str]) -> dict[int, np.ndarray]:
    """Run an snnTorch Sequential step by step and keep the spikes of the modules in ``record``."""
    from snntorch import utils

    utils.reset(model)
    rows: dict[int, list[np.ndarray]] = {i: [] for i in record}
    with torch.no_grad():
        x = torch.tensor(spikes, dtype=torch.float32)
        for k in range(spikes.shape[0]):
            h = x[k : k + 1]
            for i, module in enumerate(model):
                h = module(h)
                h = h[0] if isinstance(h, tuple) else h
                if i in record:
                    rows[i].append(h[0].numpy().reshape(-1).copy())
    return {i: np.array(r) for i, r in rows.items()}


def test_snntorch_dense_graph_runs_here_spike_for_spike(tmp_path: Path) -> None:
    torch.manual_seed(1)
    n_in, n_h, n_o, steps = 20, 16, 8, 300
    model = torch.nn.Sequential(
        torch.nn.Linear(n_in, n_h, bias=False),
        snn.Synaptic(alpha=torch.full((n_h,), 0.8), beta=torch.full((n_h,), 0.9), threshold=torch.ones(n_h),
                     init_hidden=True, reset_mechanism="zero", reset_delay=False),
        torch.nn.Linear(n_h, n_o, bias=False),
        snn.Leaky(beta=torch.full((n_o,), 0.85), threshold=torch.ones(n_o), init_hidden=True, output=True,
                  reset_mechanism="zero", reset_delay=False),
    )  # fmt: skip
    with torch.no_grad():
        model[0].weight.mul_(3.0)
        model[2].weight.mul_(3.0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        nir.write(tmp_path / "dense.nir", export_to_nir(model, torch.zeros(1, n_in), ignore_dims=[0]))
    spikes = (np.random.default_rng(0).random((steps, n_in)) < 0.2).astype(np.float32)
    theirs = _peer_rasters(model, spikes, {1: "hidden", 3: "out"})
    result = import_nir(tmp_path / "dense.nir", integration="euler", dt=H)
    types = {p: type(c.cell_type).__name__ for p, c in result.network.populations.items()}
    assert types == {"input": "SpikeSourceArray", "n_1": "IF_curr_exp", "n_3": "IF_curr_exp"}
    assert result.outputs == {"output": "n_3"}
    ours = _run_here(result.network, "input", spikes, {"n_1": 1, "n_3": 2})
    _assert_within_tolerance(ours["n_1"], theirs[1], "hidden Synaptic layer")
    _assert_within_tolerance(ours["n_3"], theirs[3], "output Leaky layer")


def test_snntorch_conv_pool_graph_runs_here_spike_for_spike(tmp_path: Path) -> None:
    torch.manual_seed(2)
    steps = 100
    model = torch.nn.Sequential(
        torch.nn.Conv2d(1, 4, 3, stride=1, padding=1, bias=False),
        snn.Synaptic(alpha=torch.full((4, 8, 8), 0.7), beta=torch.full((4, 8, 8), 0.9), threshold=torch.ones(4, 8, 8),
                     init_hidden=True, reset_mechanism="zero", reset_delay=False),
        torch.nn.AvgPool2d(2),
        torch.nn.Conv2d(4, 6, 3, stride=2, padding=1, bias=False),
        snn.Leaky(beta=torch.full((6, 2, 2), 0.8), threshold=torch.ones(6, 2, 2), init_hidden=True,
                  reset_mechanism="zero", reset_delay=False),
        torch.nn.Flatten(),
        torch.nn.Linear(24, 5, bias=False),
        snn.Leaky(beta=torch.full((5,), 0.9), threshold=torch.ones(5), init_hidden=True, output=True,
                  reset_mechanism="zero", reset_delay=False),
    )  # fmt: skip
    with torch.no_grad():
        for i, gain in ((0, 2.5), (3, 3.0), (6, 6.0)):
            model[i].weight.mul_(gain)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        nir.write(tmp_path / "conv.nir", export_to_nir(model, torch.zeros(1, 1, 8, 8), ignore_dims=[0]))
    spikes = (np.random.default_rng(0).random((steps, 1, 8, 8)) < 0.3).astype(np.float32)
    theirs = _peer_rasters(model, spikes, {1: "c1", 4: "c2", 7: "out"})
    result = import_nir(tmp_path / "conv.nir", integration="euler", dt=H)
    kinds = {name: type(p.connector).__name__ for name, p in result.network.projections.items()}
    assert kinds == {"input->n_1": "ConvolutionConnector", "n_1->n_4": "FromListConnector", "n_4->n_7": "AllToAllConnector"}
    ours = _run_here(result.network, "input", spikes, {"n_1": 1, "n_4": 2, "n_7": 3})
    for pop, i in (("n_1", 1), ("n_4", 4), ("n_7", 7)):
        _assert_within_tolerance(ours[pop], theirs[i], f"layer {pop}")


def _our_network(seed: int, conv: bool) -> nv.Network:
    rng = np.random.default_rng(seed)
    lif = {"tau_refrac": 0.0, "v_rest": 0.0, "v_reset": 0.0, "v_thresh": 1.0}
    net = nv.Network("ours")
    if conv:
        c = nv.ConvolutionConnector(input_shape=(1, 8, 8), kernel_shape=(3, 3), out_channels=3, stride=(2, 2), padding=(1, 1))
        net.add_population("inp", 64, nv.SpikeSourceArray.from_lists([[]] * 64))
        net.add_population("hid", 48, nv.IF_curr_exp(cm=0.5, tau_m=2.0, tau_syn_E=1.0, tau_syn_I=1.0, **lif))
        net.connect("inp", "hid", c, nv.StaticSynapse(weight=rng.normal(0.3, 0.5, c.weight_shape)))
        n_h = 48
    else:
        net.add_population("inp", 20, nv.SpikeSourceArray.from_lists([[]] * 20))
        net.add_population("hid", 16, nv.IF_curr_exp(cm=0.5, tau_m=2.0, tau_syn_E=1.0, tau_syn_I=1.0, **lif))
        net.connect("inp", "hid", nv.AllToAllConnector(), nv.StaticSynapse(weight=rng.normal(0.05, 0.4, (20, 16))))
        n_h = 16
    net.add_population("out", 8, nv.IF_curr_exp(cm=0.25, tau_m=3.0, tau_syn_E=0.5, tau_syn_I=0.5, **lif))
    net.connect("hid", "out", nv.AllToAllConnector(), nv.StaticSynapse(weight=rng.normal(0.1, 0.5, (n_h, 8))))
    return net


@pytest.mark.parametrize("conv", [False, True], ids=["dense", "conv"])
def test_our_graph_runs_in_snntorch_spike_for_spike(tmp_path: Path, conv: bool) -> None:
    net = _our_network(4, conv)
    export_nir(net, tmp_path / "ours.nir", integration="euler", dt=H)
    n_in = net.populations["inp"].size
    steps = 300
    spikes = (np.random.default_rng(5).random((steps, n_in)) < 0.2).astype(np.float32)
    ours = _run_here(net, "inp", spikes, {"hid": 1, "out": 2})
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = import_from_nir(read_graph(tmp_path / "ours.nir"))
    hidden: list[np.ndarray] = []
    model.hid.register_forward_hook(
        lambda mod, args, out: hidden.append((out[0] if isinstance(out, tuple) else out)[0].numpy().copy())
    )
    x = torch.tensor(spikes.reshape((steps, 1, 8, 8)) if conv else spikes)
    state, outs = None, []
    with torch.no_grad():
        for k in range(steps):
            out, state = model(x[k : k + 1], state)
            outs.append(out.numpy().reshape(-1).copy())
    _assert_within_tolerance(ours["hid"], np.array(hidden).reshape(steps, -1), "hidden layer in snnTorch")
    _assert_within_tolerance(ours["out"], np.array(outs), "output layer in snnTorch")
