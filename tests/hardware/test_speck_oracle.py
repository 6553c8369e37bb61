"""The Speck checker against Sinabs's own DYNAP-CNN layer sizing and layer-to-core mapping, network by network.

For each network, the memory neurovpr counts per layer equals Sinabs's
``DynapcnnLayer.memory_summary``, the cores each layer fits equal ``find_chip_layers``, the
assignment equals ``get_valid_mapping`` (or both refuse), and the limit neurovpr names is the
one that leaves the layer without a core. The per-core memories in hwspecs/speck.toml equal
Sinabs's ``get_constraints``.
"""

from __future__ import annotations

import numpy as np
import pytest

import neurovpr as nv
from neurovpr.errors import BackendUnavailableError
from neurovpr.hardware import check_network, load_hwspec

try:
    from neurovpr.backends.speck.compat import import_dynapcnn

    import_dynapcnn()
except BackendUnavailableError as exc:  # pragma: no cover - depends on the install
    pytest.skip(f"Sinabs not importable: {exc}", allow_module_level=True)

from hw_models import locsnet
from synsense_oracles import sinabs_constraints, sinabs_speck


def conv_chain(input_shape: tuple[int, int, int], layers: list[tuple[int, int, int, int]], *, dense: tuple[int, ...] = (),
               bias: bool = False, name: str = "convnet") -> nv.Network:
    """Input -> convolutions ``(filters, kernel, stride, padding)`` -> dense layers of the given sizes."""
    rng = np.random.default_rng(0)
    net = nv.Network(name)
    net.add_population("input", int(np.prod(input_shape)), nv.SpikeSourcePoisson(rate=0.0))
    cell = nv.IF_curr_exp(tau_m=1000.0, i_offset=0.1 if bias else 0.0)
    prev, shape = "input", input_shape
    for k, (filters, kernel, stride, padding) in enumerate(layers, start=1):
        conv = nv.ConvolutionConnector(input_shape=shape, kernel_shape=(kernel, kernel), out_channels=filters,
                                       stride=(stride, stride), padding=(padding, padding))
        net.add_population(f"conv{k}", int(np.prod(conv.output_shape)), cell)
        net.connect(prev, f"conv{k}", conv, nv.StaticSynapse(weight=rng.normal(0, 0.1, conv.weight_shape)))
        prev, shape = f"conv{k}", conv.output_shape
    for k, size in enumerate(dense, start=1):
        n_pre = int(np.prod(shape))
        net.add_population(f"dense{k}", size, cell)
        net.connect(prev, f"dense{k}", nv.AllToAllConnector(), nv.StaticSynapse(weight=rng.normal(0, 0.1, (n_pre, size))))
        prev, shape = f"dense{k}", (size, 1, 1)
    return net


CASES = {
    # name: (network, limit neurovpr names (Sinabs refuses), or None when both map it)
    "locsnet_paper_3072_places": (locsnet(), "kernel memory"),
    "locsnet_16_places": (locsnet(n_places=16), None),
    "nine_layers": (conv_chain((2, 32, 32), [(4, 3, 1, 1)] * 9), None),
    "ten_layers": (conv_chain((2, 32, 32), [(4, 3, 1, 1)] * 10), "cores"),
    "two_64k_kernels": (conv_chain((64, 8, 8), [(64, 3, 1, 1)] * 2), None),
    "three_64k_kernels": (conv_chain((64, 8, 8), [(64, 3, 1, 1)] * 3), "cores"),
    "neurons_64k": (conv_chain((2, 128, 128), [(4, 3, 1, 1)]), None),
    "neurons_over_64k": (conv_chain((2, 128, 128), [(8, 3, 1, 1)]), "neuron memory"),
    "kernel_and_neurons_no_single_core": (conv_chain((32, 32, 32), [(64, 3, 1, 1)]), "core memory"),
    "bias_1024": (conv_chain((16, 1, 1), [], dense=(1024,), bias=True), None),
    "bias_over_1024": (conv_chain((16, 1, 1), [], dense=(1025,), bias=True), "bias memory"),
    "dense_after_conv": (conv_chain((2, 16, 16), [(8, 3, 2, 0)], dense=(100, 10)), None),
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_speck_memory_assignment_and_limit_agree_with_sinabs(case):
    network, limit = CASES[case]
    report = check_network(network, "speck")
    oracle = sinabs_speck(network)
    mine = {c.population: c for c in report.partition.cores}
    assert {name: c.usage for name, c in mine.items()} == oracle.memory
    spec = load_hwspec("speck")
    for name, cands in oracle.candidates.items():
        fits = [k for k in range(9) if all(mine[name].usage[m] <= spec.rules.core_memories(k)[m]
                                           for m in mine[name].usage)]
        assert fits == cands, name
    if oracle.assignment is None:
        assert not report.fits
        assert limit in {v.limit for v in report.partition.violations}, report.table()
    else:
        assert limit is None and report.fits, report.table()
        assert {name: c.location[0] for name, c in mine.items()} == oracle.assignment


def test_speck_core_memories_are_sinabs_get_constraints():
    rules = load_hwspec("speck").rules
    assert list(zip(rules.kernel_memory, rules.neuron_memory, rules.bias_memory, strict=True)) == sinabs_constraints()


def test_speck_refuses_non_square_kernels_as_sinabs_does():
    import torch

    d = import_dynapcnn()
    net = nv.Network("rect")
    net.add_population("input", 2 * 16 * 16, nv.SpikeSourcePoisson(rate=0.0))
    conv = nv.ConvolutionConnector(input_shape=(2, 16, 16), kernel_shape=(3, 5), out_channels=4)
    net.add_population("conv", int(np.prod(conv.output_shape)), nv.IF_curr_exp())
    net.connect("input", "conv", conv, nv.StaticSynapse(weight=np.ones(conv.weight_shape)))
    report = check_network(net, "speck")
    assert [v.limit for v in report.partition.violations] == ["square kernel"]
    with pytest.raises(ValueError, match="same height and width"):
        d.layer.DynapcnnLayer(torch.nn.Conv2d(2, 4, (3, 5)), d.layers.IAFSqueeze(batch_size=1), (2, 16, 16),
                              pool=[[1, 1]], discretize=False)
