"""Speck layers of a neurovpr network as Sinabs builds them for the chip.

Each layer of :func:`neurovpr.hardware.speck_values.speck_values` becomes the torch
``Conv2d`` (or, for a dense layer, the ``Linear`` that Sinabs's ``convert_linear_to_conv``
turns into a convolution covering its input) and the ``IAFSqueeze`` spiking layer
(threshold, ``min_v_mem``; Sinabs's defaults: ``MultiSpike``, reset by subtracting the
threshold, no leak) that Sinabs's ``DynapcnnLayer`` takes. ``DynapcnnLayer`` with
``discretize=True`` then applies Sinabs's own ``discretize_conv_spike_``, as
``DynapcnnNetwork`` does before writing the chip configuration: one scale per layer for
weights, bias, threshold and ``min_v_mem``, rounded to integers (8-bit weights and bias,
16-bit state).
"""

from __future__ import annotations

from types import SimpleNamespace
from typing import Any

from neurovpr.hardware.hwspec import HwSpec
from neurovpr.hardware.speck_values import SpeckLayerValues, lowest_state

__all__ = ["dynapcnn_layer"]


def dynapcnn_layer(values: SpeckLayerValues, spec: HwSpec, sinabs: SimpleNamespace) -> Any:
    """The discretised ``DynapcnnLayer`` of one layer (``sinabs`` from :func:`.compat.import_dynapcnn`)."""
    import torch

    f, c, kh, kw = values.kernel.shape
    bias = values.bias is not None
    kernel = torch.tensor(values.kernel, dtype=torch.float32)
    if values.dense:
        conv: Any = torch.nn.Linear(c * kh * kw, f, bias=bias)
        kernel = kernel.reshape(f, c * kh * kw)
    else:
        conv = torch.nn.Conv2d(c, f, (kh, kw), stride=values.stride, padding=values.padding, bias=bias)
    with torch.no_grad():
        conv.weight.copy_(kernel)
        if bias:
            conv.bias.copy_(torch.tensor(values.bias, dtype=torch.float32))
    spk = sinabs.layers.IAFSqueeze(
        batch_size=1, spike_threshold=torch.tensor(values.threshold, dtype=torch.float32), min_v_mem=lowest_state(values, spec)
    )
    return sinabs.layer.DynapcnnLayer(conv, spk, values.input_shape, pool=[[1, 1]], discretize=True)
