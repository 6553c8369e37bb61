"""From trained rate weights to a spiking neurovpr network, and back.

The trained network computes, layer by layer, ``J = W * a + b`` (a convolution or a
dense product) and ``a' = amplitude * r(J)`` with ``r`` the LIF rate (spikes/ms) of a
neuron whose threshold is at ``J = 1``; the input ``a`` of the first layer is the
image, with pixel values in [0, 1].

The spiking network replaces every layer by a population of ``IF_curr_exp`` neurons
with ``tau_m = tau_rc``, ``tau_refrac = tau_ref``, ``v_rest = v_reset = 0 mV``,
``v_thresh = 1 mV`` and capacitance ``cm``, so that a constant current ``I`` (nA) gives
``J = (tau_m / cm) I / (1 mV)`` and the same steady firing rate as the rate neuron.
A presynaptic neuron firing at ``r`` spikes/ms through a weight ``w`` (nA) with an
exponential synaptic current of time constant ``tau_syn`` contributes a mean current
``w r tau_syn``, so a trained weight ``W`` becomes

    ``w = W * amplitude * cm / (tau_m * tau_syn)``

and a bias ``b`` becomes the offset current ``i_offset = b * cm / tau_m``. The input
population fires at ``x * input_rate`` for a pixel of value ``x``, so the first
layer's weights are ``w = W * cm / (tau_m * tau_syn * input_rate)`` (rate in spikes/ms).
Convolutions keep their kernels (a :class:`~neurovpr.ConvolutionConnector`, channel-major
maps); the place layer is an all-to-all projection. Weights are signed currents onto
the excitatory receptor (allowed for current-based neurons).

Because the scale factors are recorded, :func:`trained_parameters` recovers the trained
arrays from a saved network, so a run directory stores its weights once, as the
network file.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

import neurovpr as nv
from neurovpr.errors import ValidationError

from .architecture import LAYER_NAMES, Architecture

__all__ = [
    "SpikingParameters",
    "layer_populations",
    "INPUT_CODINGS",
    "INPUT",
    "to_spiking_network",
    "trained_parameters",
    "check_parameters",
    "weight_scales",
]

#: Name of the input population.
INPUT = "input"
#: How pixels become spikes: Poisson trains, or deterministic evenly spaced trains.
INPUT_CODINGS = ("poisson", "regular")
_V_THRESH = 1.0  # mV above rest


@dataclass(frozen=True, slots=True, kw_only=True)
class SpikingParameters:
    """How the spiking network runs: time step, synapses, input coding, presentation.

    Attributes
    ----------
    dt
        Time step (ms); 1 ms is Loihi's step.
    tau_syn
        Synaptic current time constant (ms), every layer.
    cm
        Membrane capacitance (nF).
    input_rate
        Firing rate (Hz) of an input pixel of value 1.
    presentation
        How long each image is shown (ms); the place is the argmax of the place layer's
        spike counts over this window.
    input_coding
        ``"poisson"`` (:class:`~neurovpr.SpikeSourcePoisson`, rates change per query without
        rebuilding) or ``"regular"`` (deterministic evenly spaced trains as a
        :class:`~neurovpr.SpikeSourceArray`, the same spikes on every backend).
    feature_groups
        The third convolutional layer is built as this many populations of consecutive
        channels (``conv3.0``, ``conv3.1``, ...), each projecting to the place layer.
        The network computes the same thing; on Loihi each group gets its own cores,
        which keeps a core's output axons (one per place-layer core it reaches) under
        the limit, as NengoLoihi's ``BlockShape`` does.
    """

    dt: float = 1.0
    tau_syn: float = 1.0
    cm: float = 1.0
    input_rate: float = 250.0
    presentation: float = 50.0
    input_coding: str = "poisson"
    feature_groups: int = 1

    def __post_init__(self) -> None:
        for name in ("dt", "tau_syn", "cm", "input_rate", "presentation"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not np.isfinite(value) or value <= 0:
                raise ValidationError(f"SpikingParameters.{name} must be a positive number, got {value!r}.")
            object.__setattr__(self, name, float(value))
        if self.input_coding not in INPUT_CODINGS:
            raise ValidationError(
                f"SpikingParameters.input_coding must be one of {', '.join(INPUT_CODINGS)}, got {self.input_coding!r}."
            )
        if self.input_rate * self.dt / 1000.0 > 1.0:
            raise ValidationError(
                f"SpikingParameters.input_rate {self.input_rate:g} Hz exceeds one spike per {self.dt:g} ms step."
            )
        if isinstance(self.feature_groups, bool) or not isinstance(self.feature_groups, int) or self.feature_groups < 1:
            raise ValidationError(f"SpikingParameters.feature_groups must be an integer >= 1, got {self.feature_groups!r}.")
        steps = self.presentation / self.dt
        if abs(steps - round(steps)) > 1e-9 or round(steps) < 1:
            raise ValidationError(
                f"SpikingParameters.presentation {self.presentation:g} ms is not a whole number of {self.dt:g} ms steps."
            )

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready values."""
        return {"dt": self.dt, "tau_syn": self.tau_syn, "cm": self.cm, "input_rate": self.input_rate,
                "presentation": self.presentation, "input_coding": self.input_coding,
                "feature_groups": self.feature_groups}

    @classmethod
    def from_dict(cls, data: Any, *, where: str = "spiking parameters") -> SpikingParameters:
        """Rebuild from :meth:`to_dict` output (unknown keys are refused)."""
        if not isinstance(data, dict):
            raise ValidationError(f"{where} must be a JSON object, got {type(data).__name__}.")
        unknown = sorted(set(data) - set(cls.__dataclass_fields__))  # type: ignore[attr-defined]
        if unknown:
            raise ValidationError(f"{where} has unknown field {unknown[0]!r}.")
        return cls(**data)


def layer_populations(arch: Architecture, spiking: SpikingParameters) -> dict[str, list[str]]:
    """Population names of each layer (``conv3`` is split into ``spiking.feature_groups``)."""
    channels = arch.convs[2].filters
    groups = spiking.feature_groups
    if channels % groups:
        raise ValidationError(
            f"feature groups {groups} do not divide the {channels} channels of conv3; choose a divisor of {channels}."
        )
    conv3 = ["conv3"] if groups == 1 else [f"conv3.{g}" for g in range(groups)]
    return {"conv1": ["conv1"], "conv2": ["conv2"], "conv3": conv3, "places": ["places"]}


def weight_scales(arch: Architecture, spiking: SpikingParameters) -> dict[str, float]:
    """Factor from a trained weight to a synaptic weight (nA), per layer, and ``"bias"`` for biases."""
    tau_m = float(arch.neuron.tau_rc)
    amplitude = float(arch.neuron.amplitude)
    per_spike = spiking.cm / (tau_m * spiking.tau_syn)
    scales = {name: amplitude * per_spike for name in LAYER_NAMES}
    scales["conv1"] = per_spike / (spiking.input_rate / 1000.0)
    scales["bias"] = spiking.cm / tau_m
    return scales


def check_parameters(arch: Architecture, params: dict[str, np.ndarray], *, where: str = "trained parameters") -> None:
    """Raise a :class:`ValidationError` unless ``params`` holds exactly the arrays ``arch`` needs."""
    expected = arch.parameter_shapes()
    missing = sorted(set(expected) - set(params))
    extra = sorted(set(params) - set(expected))
    if missing or extra:
        what = f"lacks {missing[0]!r}" if missing else f"has {extra[0]!r}, which the architecture does not use"
        raise ValidationError(f"{where} {what}; they were made for a different architecture.")
    for name, shape in expected.items():
        got = tuple(np.shape(params[name]))
        if got != shape:
            raise ValidationError(
                f"{where} array {name!r} has shape {got} but the architecture needs {shape}; "
                "they were made for a different architecture."
            )
        if not np.all(np.isfinite(params[name])):
            raise ValidationError(f"{where} array {name!r} contains NaN or infinite values.")


def _neurons(arch: Architecture, spiking: SpikingParameters, size: int, bias: np.ndarray | None) -> nv.IF_curr_exp:
    offset: Any = 0.0 if bias is None else np.ascontiguousarray(bias, dtype=np.float64)
    return nv.IF_curr_exp(
        cm=spiking.cm,
        tau_m=float(arch.neuron.tau_rc),
        tau_refrac=float(arch.neuron.tau_ref),
        tau_syn_E=spiking.tau_syn,
        tau_syn_I=spiking.tau_syn,
        v_rest=0.0,
        v_reset=0.0,
        v_thresh=_V_THRESH,
        i_offset=offset,
    )


def to_spiking_network(
    arch: Architecture, params: dict[str, np.ndarray], spiking: SpikingParameters, *, name: str = "locsnet"
) -> nv.Network:
    """The spiking LoCS-Net: an input population, three convolutional LIF layers and the place layer.

    Parameters
    ----------
    arch
        The architecture the parameters were trained for.
    params
        Trained arrays by name (see :meth:`Architecture.parameter_shapes`).
    spiking
        Synapse, capacitance, input coding and conv3 grouping used for the conversion.
    name
        The network's name.
    """
    check_parameters(arch, params)
    pops = layer_populations(arch, spiking)
    scales = weight_scales(arch, spiking)
    shapes = arch.layer_shapes()
    sizes = arch.layer_sizes()
    net = nv.Network(name)
    n_in = sizes["input"]
    if spiking.input_coding == "poisson":
        net.add_population(INPUT, n_in, nv.SpikeSourcePoisson(rate=0.0))
    else:
        net.add_population(INPUT, n_in, nv.SpikeSourceArray(times=np.zeros(0), offsets=np.zeros(n_in + 1, np.int64)))
    prev, prev_shape = INPUT, shapes["input"]
    for layer, conv in zip(LAYER_NAMES[:3], arch.convs, strict=True):
        c, h, w = shapes[layer]
        kernel = np.asarray(params[f"{layer}.weight"], dtype=np.float64) * scales[layer]
        bias = np.asarray(params[f"{layer}.bias"], dtype=np.float64) * scales["bias"] if arch.conv_bias else None
        names = pops[layer]
        per = c // len(names)
        for g, pop_name in enumerate(names):
            chans = slice(g * per, (g + 1) * per)
            size = per * h * w
            offset = None if bias is None else np.repeat(bias[chans], h * w)
            net.add_population(pop_name, size, _neurons(arch, spiking, size, offset))
            connector = nv.ConvolutionConnector(
                input_shape=prev_shape, kernel_shape=(conv.kernel, conv.kernel), out_channels=per,
                stride=(conv.stride, conv.stride), padding=(conv.padding, conv.padding),
            )
            net.connect(prev, pop_name, connector, nv.StaticSynapse(weight=np.ascontiguousarray(kernel[chans]),
                                                                    delay=spiking.dt))
        prev, prev_shape = names[0], (c, h, w)
    bias = np.asarray(params["places.bias"], dtype=np.float64) * scales["bias"] if arch.dense_bias else None
    net.add_population("places", arch.n_places, _neurons(arch, spiking, arch.n_places, bias))
    dense = np.asarray(params["places.weight"], dtype=np.float64).T * scales["places"]  # (features, places)
    group = sizes["conv3"] // len(pops["conv3"])
    for g, pop_name in enumerate(pops["conv3"]):
        rows = np.ascontiguousarray(dense[g * group : (g + 1) * group])
        net.connect(pop_name, "places", nv.AllToAllConnector(), nv.StaticSynapse(weight=rows, delay=spiking.dt))
    return net


def trained_parameters(network: nv.Network, arch: Architecture, spiking: SpikingParameters) -> dict[str, np.ndarray]:
    """The trained arrays a network made by :func:`to_spiking_network` carries (its inverse).

    Raises
    ------
    ValidationError
        When the network's populations or projections do not match ``arch`` (a network
        of another architecture, or another model).
    """
    pops = layer_populations(arch, spiking)
    sizes = arch.layer_sizes()
    shapes = arch.parameter_shapes()
    have = network.populations
    expected = {INPUT: sizes["input"]}
    for layer, names in pops.items():
        for pop_name in names:
            expected[pop_name] = sizes[layer] // len(names)
    for pop_name, size in expected.items():
        if pop_name not in have:
            raise ValidationError(
                f"network {network.name!r} has no population {pop_name!r}; it is not a LoCS-Net of this architecture."
            )
        if have[pop_name].size != size:
            raise ValidationError(
                f"network {network.name!r} population {pop_name!r} has {have[pop_name].size} neurons but the "
                f"architecture needs {size}; it was made for a different architecture."
            )
    scales = weight_scales(arch, spiking)

    def weight(pre: str, post: str) -> np.ndarray:
        proj = network.projections.get(f"{pre}->{post}")
        if proj is None or not isinstance(proj.synapse.weight, np.ndarray):
            raise ValidationError(f"network {network.name!r} has no weighted projection {pre}->{post}; it is not a LoCS-Net.")
        return np.asarray(proj.synapse.weight, dtype=np.float64)

    def offsets(pop_name: str) -> np.ndarray:
        return np.broadcast_to(np.asarray(have[pop_name].cell_type.i_offset, dtype=np.float64), (have[pop_name].size,))

    params: dict[str, np.ndarray] = {}
    prev = [INPUT]
    for layer in LAYER_NAMES[:3]:
        names = pops[layer]
        params[f"{layer}.weight"] = np.concatenate([weight(prev[0], n) for n in names]) / scales[layer]
        if f"{layer}.bias" in shapes:
            per = shapes[f"{layer}.bias"][0] // len(names)
            params[f"{layer}.bias"] = np.concatenate([offsets(n).reshape(per, -1)[:, 0] for n in names]) / scales["bias"]
        prev = names
    params["places.weight"] = np.concatenate([weight(n, "places") for n in pops["conv3"]]).T / scales["places"]
    if "places.bias" in shapes:
        params["places.bias"] = offsets("places") / scales["bias"]
    check_parameters(arch, params, where=f"network {network.name!r}")
    return params
