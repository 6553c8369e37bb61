"""``hardware="speck"`` on the reference backend reproduces Sinabs's simulation of DYNAP-CNN layers spike for spike.

Random feed-forward networks within Speck's limits (square convolutions with stride and
padding, dense layers after them, inhibitory projections, biases, thresholds and synaptic
scales of every size, several spikes of one input in one step) run on the reference backend
in Speck's integers and, independently built here, as Sinabs's own ``DynapcnnLayer``
objects (torch ``Conv2d``/``Linear`` + ``IAFSqueeze``, discretised by ``DynapcnnLayer`` as
``DynapcnnNetwork`` does) fed the same input raster layer after layer. The integers of every
layer and every spike of every layer at every step must agree.
"""

from __future__ import annotations

import numpy as np
import pytest

import neurovpr as nv
from neurovpr.errors import BackendUnavailableError
from neurovpr.hardware import load_hwspec
from neurovpr.hardware.speck_values import lowest_state, speck_values

try:
    from neurovpr.backends.speck.compat import import_dynapcnn

    SINABS = import_dynapcnn()
except BackendUnavailableError as exc:  # pragma: no cover - depends on the install
    pytest.skip(f"Sinabs not importable: {exc}", allow_module_level=True)

torch = pytest.importorskip("torch")

STEPS = 60
#: Totals over the default sweep, filled by the test (printed with -s).
TOTALS = {"networks": 0, "active": 0, "layers": 0, "spikes": 0, "mismatches": 0}


def _random_network(seed: int) -> tuple[nv.Network, list[dict], np.ndarray]:
    """A random network, its layers as the test builds them for Sinabs, and the input raster ``(STEPS, inputs)``."""
    rng = np.random.default_rng(seed)
    side = int(rng.integers(6, 13))  # square maps: a dense layer's kernel covers its input, and Speck's are square
    shape = (int(rng.integers(1, 4)), side, side)
    raster = rng.poisson(float(rng.uniform(0.05, 0.4)), size=(STEPS, int(np.prod(shape))))
    times = [list(np.repeat(np.arange(STEPS), raster[:, i]).astype(float)) for i in range(raster.shape[1])]
    net = nv.Network(f"speck_random_{seed}")
    net.add_population("input", raster.shape[1], nv.SpikeSourceArray(spike_times=times))
    layers: list[dict] = []
    prev = "input"
    n_conv, n_dense = int(rng.integers(1, 4)), int(rng.integers(0, 3))
    for k in range(n_conv + n_dense):
        cm, tau = float(rng.uniform(0.2, 3.0)), float(rng.uniform(0.5, 8.0))
        inhibitory = k > 0 and bool(rng.random() < 0.3)
        bias = rng.random() < 0.5
        if k < n_conv:
            kernel = int(rng.choice([k for k in (1, 3, 5) if k <= shape[1]]))
            pad = int(rng.integers(0, 2)) if kernel > 1 else 0
            stride = int(rng.integers(1, 3)) if shape[1] > 6 else 1
            conn = nv.ConvolutionConnector(
                input_shape=shape,
                kernel_shape=(kernel, kernel),
                out_channels=int(rng.integers(2, 7)),
                stride=(stride, stride),
                padding=(pad, pad),
            )
            weight = rng.normal(0.3, 0.5, conn.weight_shape) * float(rng.uniform(0.1, 5))
            size, out_shape = int(np.prod(conn.output_shape)), conn.output_shape
            kernel_arr = weight
        else:
            conn = nv.AllToAllConnector()
            n_out = int(rng.integers(4, 30))
            weight = rng.normal(0.05, 0.3, (int(np.prod(shape)), n_out)) * float(rng.uniform(0.1, 5))
            size, out_shape = n_out, (n_out, 1, 1)
            kernel_arr = weight.T.reshape(n_out, *shape)
        if inhibitory:
            weight = np.abs(weight)  # an inhibitory receptor takes weights >= 0; the receptor gives the sign
            kernel_arr = np.abs(kernel_arr)
        channel_bias = rng.normal(0.0, 0.2, out_shape[0]) if bias else None
        i_offset = 0.0 if channel_bias is None else np.repeat(channel_bias, size // out_shape[0])
        thresh = float(rng.uniform(0.5, 6.0))
        cell = nv.IF_curr_exp(
            tau_m=nv.NO_LEAK,
            cm=cm,
            tau_syn_E=tau,
            tau_syn_I=tau,
            v_rest=-1.0,
            v_reset=-2.0,
            v_thresh=-1.0 + thresh,
            i_offset=i_offset,
        )
        name = f"layer{k}"
        net.add_population(name, size, cell)
        net.connect(prev, name, conn, nv.StaticSynapse(weight=weight), receptor_type="inhibitory" if inhibitory else "excitatory")
        gain = (-1.0 if inhibitory else 1.0) * tau / cm
        layers.append(
            {
                "name": name,
                "in_shape": shape,
                "kernel": kernel_arr * gain,
                "conn": conn,
                "threshold": thresh,
                "bias": None if channel_bias is None else channel_bias * 1.0 / cm,
                "dense": k >= n_conv,
            }
        )
        prev, shape = name, out_shape
    return net, layers, raster


def _sinabs_layers(net: nv.Network, layers: list[dict]) -> list:
    """Each layer as Sinabs's discretised ``DynapcnnLayer``, built from the test's own arrays."""
    spec = load_hwspec("speck")
    floors = {v.population: lowest_state(v, spec) for v in speck_values(net, dt=1.0, seed=0)}
    built = []
    for lyr in layers:
        f, c, kh, kw = lyr["kernel"].shape
        has_bias = lyr["bias"] is not None
        if lyr["dense"]:
            mod = torch.nn.Linear(c * kh * kw, f, bias=has_bias)
            weight = lyr["kernel"].reshape(f, -1)
        else:
            conn = lyr["conn"]
            mod = torch.nn.Conv2d(c, f, (kh, kw), stride=conn.stride, padding=conn.padding, bias=has_bias)
            weight = lyr["kernel"]
        with torch.no_grad():
            mod.weight.copy_(torch.tensor(weight, dtype=torch.float32))
            if has_bias:
                mod.bias.copy_(torch.tensor(lyr["bias"], dtype=torch.float32))
        spk = SINABS.layers.IAFSqueeze(
            batch_size=1, spike_threshold=torch.tensor(lyr["threshold"], dtype=torch.float32), min_v_mem=floors[lyr["name"]]
        )
        built.append(SINABS.layer.DynapcnnLayer(mod, spk, lyr["in_shape"], pool=[[1, 1]], discretize=True))
    return built


def _sinabs_spikes(built: list, layers: list[dict], raster: np.ndarray, split: int) -> dict[str, np.ndarray]:
    """Spike counts ``(STEPS, size)`` of every layer, the raster fed in two windows (state kept in between)."""
    out: dict[str, list[np.ndarray]] = {lyr["name"]: [] for lyr in layers}
    with torch.no_grad():
        for lo, hi in ((0, split), (split, STEPS)):
            x = torch.tensor(raster[lo:hi], dtype=torch.float32)
            for lyr, layer in zip(layers, built, strict=True):
                x = layer(x.reshape(hi - lo, *lyr["in_shape"]))
                out[lyr["name"]].append(x.reshape(hi - lo, -1).numpy().astype(np.int64))
                x = x.reshape(hi - lo, -1)
    return {name: np.concatenate(parts) for name, parts in out.items()}


def _reference_spikes(net: nv.Network, layers: list[dict], split: int):
    sim = nv.compile(net, backend="reference", hardware="speck", dt=1.0, seed=0)
    sim.run(float(split))
    sim.run(float(STEPS - split))
    counts = {}
    for lyr in layers:
        times, idx = sim.spike_trains(lyr["name"])
        r = np.zeros((STEPS, net.populations[lyr["name"]].size), dtype=np.int64)
        np.add.at(r, (np.round(times).astype(int) - 1, idx), 1)  # a spike of step j is recorded at (j + 1) dt
        counts[lyr["name"]] = r
    return sim, counts


def _check(seed: int) -> bool:
    net, layers, raster = _random_network(seed)
    built = _sinabs_layers(net, layers)
    split = STEPS // 3
    sim, mine = _reference_spikes(net, layers, split)
    theirs = _sinabs_spikes(built, layers, raster, split)
    for block, layer in zip(sim.quantised.blocks, built, strict=True):
        kernel = layer.conv_layer.weight.detach().numpy().astype(np.int64)
        np.testing.assert_array_equal(block["kernel"].reshape(kernel.shape), kernel)
        bias = layer.conv_layer.bias
        np.testing.assert_array_equal(block["bias"], 0 if bias is None else bias.detach().numpy().astype(np.int64))
        assert block["threshold"] == int(layer.spk_layer.spike_threshold)
        assert block["min_v_mem"] == int(layer.spk_layer.min_v_mem) == -(2**15)
    TOTALS["networks"] += 1
    for lyr in layers:
        name = lyr["name"]
        TOTALS["layers"] += 1
        TOTALS["spikes"] += int(theirs[name].sum())
        TOTALS["mismatches"] += int(np.abs(mine[name] - theirs[name]).sum())
        np.testing.assert_array_equal(mine[name], theirs[name], err_msg=f"seed {seed}, {name}")
    active = sum(int(theirs[lyr["name"]].sum()) for lyr in layers) > 0
    TOTALS["active"] += int(active)
    print(f"speck sweep so far: {TOTALS}")
    return active


@pytest.mark.parametrize("seed", range(8))
def test_reference_speck_arithmetic_equals_sinabs(seed):
    assert _check(seed), "the network should be active"


@pytest.mark.slow
@pytest.mark.parametrize("seed", range(1000, 1100))
def test_reference_speck_arithmetic_equals_sinabs_sweep(seed):
    _check(seed)  # a silent network still has to agree
