"""LoCS-Net's architecture as data: layer sizes, neuron parameters and their JSON form.

LoCS-Net (Akcal et al., Frontiers in Neurorobotics 2025) treats visual place
recognition as classification: a 56x56 grayscale image goes through three
convolutional layers and a dense "place layer" with one neuron per place, every layer
made of LIF neurons. It is trained through the smooth rate approximation of LIF
(:class:`neurovpr.SoftLIF`, Hunsberger & Eliasmith 2015) and then run with spiking LIF
neurons.

What the paper fixes and what this module chooses
-------------------------------------------------
From the paper: the 56x56 grayscale input, three convolutional layers, a dense place
layer of LIF neurons, SoftLIF training with sparse categorical cross-entropy, biases
removed for Loihi, 8-bit weights on chip. The filter counts, kernel sizes and strides
could not be checked against the paper's text or published code here, so
:func:`paper_architecture` *chooses* them: 8 filters 5x5 stride 2, 16 filters 3x3
stride 2, 32 filters 3x3 stride 2, no padding (56 -> 26 -> 12 -> 5), i.e. 5,408,
2,304 and 800 LIF neurons before the place layer, small enough for Kapoho Bay's cores
and for a fast CPU simulation. No layer has a bias (the paper removed the conv
biases; the place layer's is left out too, so no neuron fires before input arrives).
The neuron parameters are also chosen: ``tau_rc`` 10 ms and ``tau_ref`` 1 ms (one
Loihi step) rather than Nengo's defaults of 20 ms and 2 ms, because four LIF layers
must settle within a short presentation window (30 ms at 1 ms steps); with 20 ms the
third layer fires at a fraction of its trained rate by the end of the window. The
smoothing ``sigma`` (gamma) is 0.02 and the amplitude 10 (an activation of 1 is 100
spikes/s).

Units: ``tau_rc`` and ``tau_ref`` in ms. A layer's activation is ``amplitude * r`` with
``r`` the firing rate in spikes per ms.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from typing import Any

from neurovpr.errors import ValidationError
from neurovpr.ir.cells import SoftLIF

__all__ = [
    "ConvSpec",
    "Architecture",
    "ARCHITECTURE_FORMAT",
    "LAYER_NAMES",
    "paper_architecture",
    "small_architecture",
]

#: Format tag of the architecture JSON.
ARCHITECTURE_FORMAT = "neurovpr-locsnet-architecture/1"
#: Names of the layers, in order (also the population names of the spiking network).
LAYER_NAMES = ("conv1", "conv2", "conv3", "places")

_KW = {"frozen": True, "slots": True, "kw_only": True}


def _int(where: str, value: Any, low: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or value < low:
        raise ValidationError(f"{where} must be an integer >= {low}, got {value!r}.")
    return int(value)


@dataclass(**_KW)
class ConvSpec:
    """One convolutional layer: ``filters`` output channels, square ``kernel``, ``stride``, zero ``padding``."""

    filters: int
    kernel: int
    stride: int = 1
    padding: int = 0

    def __post_init__(self) -> None:
        for name, low in (("filters", 1), ("kernel", 1), ("stride", 1), ("padding", 0)):
            object.__setattr__(self, name, _int(f"ConvSpec.{name}", getattr(self, name), low))

    def output_size(self, size: int) -> int:
        """Output height (or width) for an input of ``size`` pixels."""
        return (size + 2 * self.padding - self.kernel) // self.stride + 1


@dataclass(**_KW)
class Architecture:
    """A LoCS-Net: input size, three convolutional layers, the place layer and its neurons.

    Attributes
    ----------
    n_places
        Number of places (classes), one neuron each in the place layer.
    input_size
        ``(height, width)`` of the grayscale input (56x56 in the paper).
    convs
        The three convolutional layers.
    neuron
        The rate neuron used for training; the spiking network uses LIF neurons with
        the same ``tau_rc`` and ``tau_ref``.
    conv_bias, dense_bias
        Whether the convolutional layers and the place layer have biases (the paper
        removed the convolutional biases for Loihi; a bias becomes an offset current,
        which drives a neuron before any input spike arrives).
    """

    n_places: int
    input_size: tuple[int, int] = (56, 56)
    convs: tuple[ConvSpec, ConvSpec, ConvSpec] = field(
        default_factory=lambda: (ConvSpec(filters=8, kernel=5, stride=2), ConvSpec(filters=16, kernel=3, stride=2),
                                 ConvSpec(filters=32, kernel=3, stride=2))
    )
    neuron: SoftLIF = field(default_factory=lambda: SoftLIF(tau_rc=10.0, tau_ref=1.0, sigma=0.02, amplitude=10.0))
    conv_bias: bool = False
    dense_bias: bool = False

    def __post_init__(self) -> None:
        _int("Architecture.n_places", self.n_places, 2)
        size = tuple(self.input_size)
        if len(size) != 2:
            raise ValidationError(f"Architecture.input_size must be (height, width), got {self.input_size!r}.")
        object.__setattr__(self, "input_size", (_int("Architecture.input_size", size[0], 1),
                                                _int("Architecture.input_size", size[1], 1)))
        convs = tuple(self.convs)
        if len(convs) != 3 or not all(isinstance(c, ConvSpec) for c in convs):
            raise ValidationError(f"Architecture.convs must be three ConvSpec layers, got {len(convs)} items.")
        object.__setattr__(self, "convs", convs)
        if not isinstance(self.neuron, SoftLIF):
            raise ValidationError(f"Architecture.neuron must be a SoftLIF, got {type(self.neuron).__name__}.")
        for name in ("conv_bias", "dense_bias"):
            if not isinstance(getattr(self, name), bool):
                raise ValidationError(f"Architecture.{name} must be True or False, got {getattr(self, name)!r}.")
        h, w = self.input_size
        for i, conv in enumerate(convs, start=1):
            oh, ow = conv.output_size(h), conv.output_size(w)
            if oh < 1 or ow < 1:
                raise ValidationError(
                    f"Architecture: conv{i} kernel {conv.kernel} (stride {conv.stride}, padding {conv.padding}) "
                    f"does not fit its {h}x{w} input."
                )
            h, w = oh, ow

    # -- shapes ---------------------------------------------------------------------
    def layer_shapes(self) -> dict[str, tuple[int, ...]]:
        """``{"input": (1, H, W), "conv1": (C, H, W), ..., "places": (n_places,)}``."""
        h, w = self.input_size
        shapes: dict[str, tuple[int, ...]] = {"input": (1, h, w)}
        for name, conv in zip(LAYER_NAMES[:3], self.convs, strict=True):
            h, w = conv.output_size(h), conv.output_size(w)
            shapes[name] = (conv.filters, h, w)
        shapes["places"] = (self.n_places,)
        return shapes

    def layer_sizes(self) -> dict[str, int]:
        """Neurons per layer (the input counts its pixels)."""
        return {name: math.prod(shape) for name, shape in self.layer_shapes().items()}

    @property
    def n_features(self) -> int:
        """Inputs of each place neuron (the flattened third convolutional layer)."""
        return self.layer_sizes()["conv3"]

    def parameter_shapes(self) -> dict[str, tuple[int, ...]]:
        """Shape of every trained array, by the names the checkpoint and the converter use."""
        shapes = self.layer_shapes()
        out: dict[str, tuple[int, ...]] = {}
        in_ch = 1
        for name, conv in zip(LAYER_NAMES[:3], self.convs, strict=True):
            out[f"{name}.weight"] = (conv.filters, in_ch, conv.kernel, conv.kernel)
            if self.conv_bias:
                out[f"{name}.bias"] = (conv.filters,)
            in_ch = conv.filters
        out["places.weight"] = (self.n_places, math.prod(shapes["conv3"]))
        if self.dense_bias:
            out["places.bias"] = (self.n_places,)
        return out

    def n_synapses(self) -> int:
        """Connections of the spiking network (zero padding adds none)."""
        total = 0
        shapes = self.layer_shapes()
        prev = shapes["input"]
        for name, conv in zip(LAYER_NAMES[:3], self.convs, strict=True):
            c, oh, ow = shapes[name]
            total += _conv_connections(prev, conv, oh, ow) * c
            prev = shapes[name]
        return total + math.prod(shapes["conv3"]) * self.n_places

    # -- JSON -------------------------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        """A JSON-ready description (numbers and strings only)."""
        n = self.neuron
        return {
            "format": ARCHITECTURE_FORMAT,
            "n_places": self.n_places,
            "input_size": list(self.input_size),
            "convs": [{"filters": c.filters, "kernel": c.kernel, "stride": c.stride, "padding": c.padding}
                      for c in self.convs],
            "neuron": {"tau_rc": float(n.tau_rc), "tau_ref": float(n.tau_ref), "sigma": float(n.sigma),
                       "amplitude": float(n.amplitude)},
            "conv_bias": self.conv_bias,
            "dense_bias": self.dense_bias,
        }

    @classmethod
    def from_dict(cls, data: Any, *, where: str = "architecture") -> Architecture:
        """Rebuild from :meth:`to_dict` output, checking every field (nothing is evaluated)."""
        if not isinstance(data, dict):
            raise ValidationError(f"{where} must be a JSON object, got {type(data).__name__}.")
        if data.get("format") != ARCHITECTURE_FORMAT:
            raise ValidationError(f"{where} has format {data.get('format')!r}, expected {ARCHITECTURE_FORMAT!r}.")
        try:
            convs = tuple(
                ConvSpec(filters=c["filters"], kernel=c["kernel"], stride=c["stride"], padding=c["padding"])
                for c in data["convs"]
            )
            neuron = data["neuron"]
            return cls(
                n_places=data["n_places"],
                input_size=tuple(data["input_size"]),  # type: ignore[arg-type]
                convs=convs,  # type: ignore[arg-type]
                neuron=SoftLIF(tau_rc=float(neuron["tau_rc"]), tau_ref=float(neuron["tau_ref"]),
                               sigma=float(neuron["sigma"]), amplitude=float(neuron["amplitude"])),
                conv_bias=data["conv_bias"],
                dense_bias=data["dense_bias"],
            )
        except (KeyError, TypeError) as exc:
            raise ValidationError(f"{where} is missing or mistypes a field ({type(exc).__name__}: {exc}).") from None

    def to_json(self) -> str:
        """:meth:`to_dict` as indented JSON text."""
        return json.dumps(self.to_dict(), indent=2)

    def describe(self) -> str:
        """One line: layer shapes and sizes."""
        shapes = self.layer_shapes()
        parts = [f"{name} {'x'.join(str(s) for s in shape)}" for name, shape in shapes.items()]
        return " -> ".join(parts) + f" ({sum(self.layer_sizes().values()) - self.layer_sizes()['input']} LIF neurons)"


def _conv_connections(in_shape: tuple[int, ...], conv: ConvSpec, oh: int, ow: int) -> int:
    """Connections from a ``(C, H, W)`` map into one output channel (padding left out)."""
    c, h, w = in_shape

    def valid(size: int, out: int) -> int:
        count = 0
        for o in range(out):
            start = o * conv.stride - conv.padding
            count += sum(1 for k in range(conv.kernel) if 0 <= start + k < size)
        return count

    return c * valid(h, oh) * valid(w, ow)


def paper_architecture(n_places: int) -> Architecture:
    """The default LoCS-Net (see the module docstring for what is the paper's and what is chosen)."""
    return Architecture(n_places=n_places)


def small_architecture(n_places: int, input_size: tuple[int, int] = (28, 28)) -> Architecture:
    """A small LoCS-Net for tests and quick runs: 4, 8 and 8 filters on a 28x28 input."""
    return Architecture(
        n_places=n_places,
        input_size=input_size,
        convs=(ConvSpec(filters=4, kernel=5, stride=2), ConvSpec(filters=8, kernel=3, stride=2),
               ConvSpec(filters=8, kernel=3, stride=1)),
    )
