"""What a network that fits Speck holds per layer, in the units Sinabs's DYNAP-CNN layers take.

Speck's neurons are Sinabs's ``IAFSqueeze``: non-leaky integrate-and-fire, a spike adds
its weight to the membrane at once, a neuron spikes ``floor(v / threshold)`` times when
``v >= threshold`` and subtracts that many thresholds, and ``v`` is clipped from below
at ``min_v_mem``; a layer's bias is added every step. An ``IF_curr_exp`` population maps
onto that as its non-leaky limit (``tau_m = nv.NO_LEAK``), in mV:

* weight: the charge one spike delivers, ``w * tau_syn / cm`` (the whole exponential
  postsynaptic current, ``tau_syn_E`` for an excitatory projection; negated with
  ``tau_syn_I`` for an inhibitory one), delivered at once;
* threshold ``v_thresh - v_rest``; bias ``i_offset * dt / cm`` per step, one per output
  channel (Speck's bias memory);
* ``min_v_mem``: the floor of Speck's state, ``-2 ** (voltage_bits - 1)`` state units at the
  layer's scale (the IR's membrane has no floor: this is the lowest the chip holds).

``v_reset`` and ``tau_refrac`` have no Speck counterpart and are not used (Speck resets by
subtraction, with no refractory period). Layers follow the order spikes take: a layer's
spikes of one step reach the next layer in the same step (Speck has no synaptic delays;
Sinabs evaluates a time bin layer after layer). :func:`speck_problems` lists what cannot
be expressed that way, each as one sentence; :func:`speck_values` gives the layers.
Both the ``speck`` backend (which hands these values to Sinabs's ``DynapcnnLayer``) and the
reference backend's Speck arithmetic read them from here.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from neurovpr.backendkit.params import per_neuron
from neurovpr.ir.cells import IF_curr_exp
from neurovpr.ir.connectivity import Connections, expand
from neurovpr.ir.connectors import AllToAllConnector, ConvolutionConnector
from neurovpr.ir.network import Network

from .hwspec import HwSpec
from .speck import population_shapes

__all__ = [
    "SpeckLayerValues",
    "speck_problems",
    "speck_values",
    "lowest_state",
    "layer_order",
    "discretisation_scale",
    "threshold_problems",
]


@dataclass(frozen=True, slots=True, kw_only=True, eq=False)
class SpeckLayerValues:
    """One Speck layer: a convolution (a dense layer is one whose kernel covers its input) into IAF neurons.

    Attributes
    ----------
    population, projection, source
        The layer's population, the projection feeding it and that projection's presynaptic population.
    input_shape
        ``(channels, height, width)`` of the presynaptic map.
    kernel
        ``(out_channels, channels, kh, kw)`` charges per spike (mV), 0 where there is no connection.
    stride, padding
        Of the convolution (``(1, 1)``, ``(0, 0)`` for a dense layer).
    bias
        Per output channel, mV per step, or ``None`` without a bias.
    threshold
        ``v_thresh - v_rest`` (mV).
    gain
        mV per unit of IR weight (``+-tau_syn / cm``): the kernel is the IR weights times this.
    v_rest
        Added back to the layer's membrane when it is recorded (mV).
    dense
        True for a dense (all-to-all) layer, whose kernel covers its whole input.
    """

    population: str
    projection: str
    source: str
    input_shape: tuple[int, int, int]
    kernel: np.ndarray
    stride: tuple[int, int]
    padding: tuple[int, int]
    bias: np.ndarray | None
    threshold: float
    gain: float
    v_rest: float
    dense: bool

    @property
    def out_shape(self) -> tuple[int, int, int]:
        """``(out_channels, out_h, out_w)``."""
        (_, h, w), (_, _, kh, kw) = self.input_shape, self.kernel.shape
        oh = (h + 2 * self.padding[0] - kh) // self.stride[0] + 1
        ow = (w + 2 * self.padding[1] - kw) // self.stride[1] + 1
        return (self.kernel.shape[0], oh, ow)


def _same(value: object, size: int) -> float | None:
    arr = per_neuron(value, size)
    return float(arr[0]) if size and np.all(arr == arr[0]) else None


def layer_order(network: Network) -> list[str] | None:
    """Neuron populations fed by projections, in the order spikes take (``None`` when the projections loop)."""
    fed = {p.post: p.pre for p in network.projections.values()}
    order: list[str] = []
    placed = {n for n, p in network.populations.items() if p.is_source}
    pending = [n for n in network.populations if n in fed]
    while pending:
        ready = [n for n in pending if fed[n] in placed]
        if not ready:
            return None
        order += ready
        placed.update(ready)
        pending = [n for n in pending if n not in placed]
    return order


def speck_problems(network: Network, spec: HwSpec, dt: float) -> list[str]:
    """Why ``network`` cannot run as Speck's IAF layers at step ``dt``: one sentence each (empty when it can)."""
    out: list[str] = []
    shapes = population_shapes(network)
    step = spec.timing.time_step_ms
    if not math.isclose(dt, step, rel_tol=1e-9):
        out.append(f"network {network.name!r} at dt={dt:g} ms: {spec.name} runs in steps of {step:g} ms ([timing].time_step_ms)")
    incoming: dict[str, list[str]] = {}
    for proj in network.projections.values():
        incoming.setdefault(proj.post, []).append(proj.name)
        if proj.plastic:
            out.append(f"projection {proj.name!r}: it is plastic, and {spec.name} runs inference only")
        if not isinstance(proj.connector, (ConvolutionConnector, AllToAllConnector)):
            out.append(
                f"projection {proj.name!r}: {type(proj.connector).__name__}, where a {spec.name} layer is a "
                "convolution or a dense (all-to-all) layer"
            )
    for name, pop in network.populations.items():
        if pop.is_source:
            continue
        cell = pop.cell_type
        if type(cell) is not IF_curr_exp:
            out.append(f"population {name!r}: {type(cell).__name__}, where {spec.name}'s neurons are IF_curr_exp without leak")
            continue
        if len(incoming.get(name, ())) != 1:
            out.append(
                f"population {name!r}: it receives {len(incoming.get(name, ()))} projections, where a "
                f"{spec.name} layer is fed by exactly one"
            )
        tau_m = per_neuron(cell.tau_m, pop.size)
        if np.any(np.exp(-dt / tau_m) != 1.0):
            out.append(
                f"population {name!r}: tau_m {tau_m.min():g} ms leaks, where {spec.name}'s integrate-and-fire "
                "neurons do not (use tau_m=nv.NO_LEAK)"
            )
        for field in ("cm", "tau_syn_E", "tau_syn_I"):
            if _same(getattr(cell, field), pop.size) is None:
                out.append(
                    f"population {name!r}: {field} differs between neurons, where a {spec.name} layer shares one weight scale"
                )
        thresh = per_neuron(cell.v_thresh, pop.size) - per_neuron(cell.v_rest, pop.size)
        if not np.all(thresh == thresh[0]) or thresh[0] <= 0:
            out.append(
                f"population {name!r}: v_thresh - v_rest is {thresh.min():g}..{thresh.max():g} mV, where a "
                f"{spec.name} layer has one positive threshold"
            )
        if pop.v_init is not None and not np.array_equal(per_neuron(pop.v_init, pop.size), per_neuron(cell.v_rest, pop.size)):
            out.append(f"population {name!r}: v_init differs from v_rest, where {spec.name}'s neurons start at 0")
        channels = shapes[name][0]
        bias = per_neuron(cell.i_offset, pop.size).reshape(channels, -1)
        if np.any(bias != bias[:, :1]):
            out.append(
                f"population {name!r}: i_offset differs within an output channel, where {spec.name} holds one bias per channel"
            )
    if not out and layer_order(network) is None:
        out.append(f"network {network.name!r}: its projections form a loop, where {spec.name}'s layers feed forward")
    return out


def _kernel(conn: object, c: Connections, shape: tuple[int, int, int], n_post: int) -> np.ndarray:
    """The ``(f, c, kh, kw)`` kernel holding the weights of ``c`` (0 where there is no connection)."""
    ch, h, w = shape
    if isinstance(conn, ConvolutionConnector):
        f, (kh, kw), (sh, sw), (ph, pw) = conn.out_channels, conn.kernel_shape, conn.stride, conn.padding
        oh, ow = conn.output_hw
        o, rest = np.divmod(c.post, oh * ow)
        y, x = np.divmod(rest, ow)
        ci, rest = np.divmod(c.pre, h * w)
        iy, ix = np.divmod(rest, w)
        kernel = np.zeros((f, ch, kh, kw))
        kernel[o, ci, iy - y * sh + ph, ix - x * sw + pw] = c.weight
        return kernel
    dense = np.zeros((n_post, ch * h * w))
    np.add.at(dense, (c.post, c.pre), c.weight)
    return dense.reshape(n_post, ch, h, w)


def speck_values(
    network: Network,
    *,
    dt: float,
    seed: int,
    weights: dict[str, np.ndarray] | None = None,
) -> list[SpeckLayerValues]:
    """The layers of ``network`` (free of :func:`speck_problems`) in the order spikes take.

    ``weights`` replaces the weights of projections (canonical order), as ``set_weights`` does.
    """
    order = layer_order(network)
    assert order is not None, "speck_values needs a network free of speck_problems"
    feeding = {p.post: p for p in network.projections.values()}
    shapes = population_shapes(network)
    layers = []
    for name in order:
        proj, pop = feeding[name], network.populations[name]
        cell = pop.cell_type
        assert isinstance(cell, IF_curr_exp)
        conns = expand(network, proj, dt=dt, seed=seed)
        if weights is not None and proj.name in weights:
            conns = Connections(
                pre=conns.pre, post=conns.post, weight=np.asarray(weights[proj.name], np.float64), delay=conns.delay
            )
        inhibitory = proj.receptor_type == "inhibitory"
        tau = float(per_neuron(cell.tau_syn_I if inhibitory else cell.tau_syn_E, pop.size)[0])
        gain = (-1.0 if inhibitory else 1.0) * tau / float(per_neuron(cell.cm, pop.size)[0])
        shape = shapes[proj.pre]
        conn = proj.connector
        kernel = _kernel(conn, conns, shape, pop.size) * gain
        channels = kernel.shape[0]
        i_offset = per_neuron(cell.i_offset, pop.size).reshape(channels, -1)[:, 0]
        bias = i_offset * dt / float(per_neuron(cell.cm, pop.size)[0]) if np.any(i_offset != 0) else None
        conv = isinstance(conn, ConvolutionConnector)
        layers.append(
            SpeckLayerValues(
                population=name,
                projection=proj.name,
                source=proj.pre,
                input_shape=shape,
                kernel=kernel,
                stride=conn.stride if conv else (1, 1),
                padding=conn.padding if conv else (0, 0),
                bias=bias,
                threshold=float(per_neuron(cell.v_thresh, pop.size)[0] - per_neuron(cell.v_rest, pop.size)[0]),
                gain=gain,
                v_rest=float(per_neuron(cell.v_rest, pop.size)[0]),
                dense=not conv,
            )
        )
    return layers


def discretisation_scale(values: np.ndarray, bits: int) -> float:
    """The factor that brings ``values`` to the edge of ``bits``-bit signed integers, as Sinabs's
    ``determine_discretization_scale`` chooses it (``inf`` for all zeros)."""
    lo, hi = -(2 ** (bits - 1)), 2 ** (bits - 1) - 1
    v_min, v_max = float(np.min(values)), float(np.max(values))
    with np.errstate(divide="ignore"):
        if abs(v_min) <= abs(v_max) * abs(lo / hi):
            return abs(hi / np.float64(v_max))
        return abs(lo / np.float64(v_min))


def lowest_state(layer: SpeckLayerValues, spec: HwSpec) -> float:
    """``min_v_mem`` (mV): the floor of Speck's state, ``-2 ** (voltage_bits - 1)`` units at the layer's scale.

    The scale is the one Sinabs's ``discretize`` takes from the kernel and bias
    (``weight_bits``) and the threshold (``voltage_bits``); the floor is raised by one part
    in ``2 ** 20`` so that it never lowers that scale, and still rounds to the lowest state.
    """
    fmt = spec.formats
    bias = np.zeros(1) if layer.bias is None else layer.bias
    scale = min(
        discretisation_scale(layer.kernel, fmt.weight_bits),
        discretisation_scale(bias, fmt.weight_bits),
        discretisation_scale(np.array([0.0, layer.threshold]), fmt.voltage_bits),
    )
    return float(-(2.0 ** (fmt.voltage_bits - 1)) * (1.0 - 2.0**-20) / scale)


def threshold_problems(layers: list[SpeckLayerValues], spec: HwSpec) -> list[str]:
    """Layers whose threshold rounds below 1 at the layer's scale (weights so large that it vanishes): one sentence each."""
    out = []
    for layer in layers:
        fmt = spec.formats
        bias = np.zeros(1) if layer.bias is None else layer.bias
        scale = min(discretisation_scale(layer.kernel, fmt.weight_bits), discretisation_scale(bias, fmt.weight_bits))
        if layer.threshold * scale < 0.5:
            out.append(
                f"population {layer.population!r}: its threshold {layer.threshold:g} mV rounds to 0 at the scale "
                f"{scale:g} per mV that fits its largest charge per spike ({np.abs(layer.kernel).max():g} mV) and "
                f"bias into {fmt.weight_bits}-bit integers"
            )
    return out
