"""Build functions: a neurovpr network as a Nengo network (and its simulator).

One build function per IR element: a neuron population becomes a ``nengo.Ensemble``
of ``nengo.LIF`` neurons addressed through ``.neurons``; a spike source becomes a
``nengo.Node`` that replays the spikes drawn by the simulation, feeding an
ensemble of :class:`SpikeGate` neurons (kept off-chip under NengoLoihi) that turn
them into real spikes; a projection becomes one ``nengo.Connection`` per distinct
delay, with a ``Dense``, ``Sparse`` or ``Convolution`` transform.
"""

from __future__ import annotations

import warnings
from collections.abc import Mapping
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import Any, Iterator

import nengo
import numpy as np
import scipy.sparse

from neurovpr.backendkit.lif import NormalisedLIF, normalised_lif
from neurovpr.backendkit.timing import delay_steps
from neurovpr.errors import UnsupportedFeatureError
from neurovpr.ir.cells import IF_curr_exp
from neurovpr.ir.connectivity import Connections
from neurovpr.ir.connectors import ConvolutionConnector
from neurovpr.ir.network import Network, Projection

from .translation import conv_padding_mode, filter_delay, transform_scale

__all__ = ["SpikeGate", "SpikeFeed", "BuiltNetwork", "build_network", "quiet_nengo"]

#: Above this fraction of connected pairs a projection is built with a dense transform.
_DENSE_FRACTION = 0.25


@contextmanager
def quiet_nengo() -> Iterator[None]:
    """Silence the warnings Nengo and NengoLoihi raise for this use of them.

    Gains and biases set directly make Nengo's rate estimates divide by zero, and
    NengoLoihi 1.1 warns that it was tested up to Nengo 3.2; neither affects results.
    """
    with warnings.catch_warnings(), np.errstate(divide="ignore", invalid="ignore"):
        warnings.filterwarnings("ignore", message=".*nengo_loihi.*has not been tested.*")
        warnings.filterwarnings("ignore", message=".*Non-finite values detected.*")
        warnings.filterwarnings("ignore", message=".*Model is precomputable.*")
        warnings.filterwarnings("ignore", category=RuntimeWarning, module=r"nengo\..*")
        yield


class SpikeGate(nengo.neurons.NeuronType):
    """Emits a spike (height ``1 / dt``) on every step its input exceeds one half.

    Driven by a :class:`SpikeFeed` node through a connection without synapse, it
    turns the replayed 0/1 source spikes into spikes Nengo (and NengoLoihi's
    host-to-chip spike transfer) treat as neuron output.
    """

    spiking = True

    def max_rates_intercepts(self, gain: Any, bias: Any) -> tuple[None, None]:
        """Not a rate neuron: no rates or intercepts."""
        return None, None

    def step(self, dt: float, J: np.ndarray, output: np.ndarray) -> None:
        """Spike where the input is on."""
        output[...] = (J > 0.5) / dt


class SpikeFeed:
    """The output function of a source's node: the spikes drawn for each run, step by step.

    Parameters
    ----------
    size
        Number of source neurons.
    dt_s
        Nengo's time step in seconds.
    shift
        Steps by which the replay lags the stamps (NengoLoihi: a source projection's
        delay beyond one step, applied off-chip before the spikes are sent).
    """

    def __init__(self, size: int, dt_s: float, shift: int = 0) -> None:
        self._dt_s = dt_s
        self._shift = int(shift)
        self._zeros = np.zeros(size)
        self.clear()

    def clear(self) -> None:
        """Forget every spike (spikes in flight included)."""
        self._rows = np.zeros((0, self._zeros.size))
        self._first = 1

    def load(self, raster: np.ndarray, first_step: int) -> None:
        """Spikes ``raster[i]`` (0/1 per neuron) for Nengo step ``first_step + i`` (1-based), before the shift.

        Rows of the previous run still due (the last ``shift`` of them) are kept.
        """
        raster = np.asarray(raster, dtype=np.float64)
        n_old = self._rows.shape[0]
        if n_old and first_step == self._first + n_old:
            keep = self._rows[max(0, n_old - self._shift) :]
            self._first = first_step - keep.shape[0]
            self._rows = np.concatenate([keep, raster])
        else:
            self._rows, self._first = raster, int(first_step)

    def __call__(self, t: float) -> np.ndarray:
        i = int(np.rint(t / self._dt_s)) - self._shift - self._first
        if 0 <= i < self._rows.shape[0]:
            return self._rows[i]
        return self._zeros


@dataclass
class BuiltNetwork:
    """The Nengo objects standing for each IR element."""

    net: nengo.Network
    mappings: dict[str, NormalisedLIF] = field(default_factory=dict)
    ensembles: dict[str, nengo.Ensemble] = field(default_factory=dict)
    gates: dict[tuple[str, int], nengo.Ensemble] = field(default_factory=dict)
    feeds: dict[str, list[SpikeFeed]] = field(default_factory=dict)
    spike_probes: dict[str, nengo.Probe] = field(default_factory=dict)
    voltage_probes: dict[str, nengo.Probe] = field(default_factory=dict)
    connections: dict[str, list[nengo.Connection]] = field(default_factory=dict)


def _gate(built: BuiltNetwork, name: str, size: int, shift: int, *, dt_s: float, loihi: bool) -> nengo.Ensemble:
    """The spike-gate ensemble replaying source ``name`` ``shift`` steps late (made on first use)."""
    key = (name, shift)
    if key not in built.gates:
        gate = nengo.Ensemble(
            size,
            1,
            neuron_type=SpikeGate(),
            gain=np.ones(size),
            bias=np.zeros(size),
            encoders=np.ones((size, 1)),
            label=name if shift == 0 else f"{name}+{shift}",
        )
        feed = SpikeFeed(size, dt_s, shift)
        node = nengo.Node(feed, size_in=0, size_out=size, label=f"{gate.label}:spikes")
        nengo.Connection(node, gate.neurons, synapse=None)
        if loihi:
            built.net.config[gate].on_chip = False
        built.gates[key] = gate
        built.feeds.setdefault(name, []).append(feed)
    return built.gates[key]


def _synapse(tau_syn_ms: float, dt: float, delay: int, loihi: bool) -> nengo.synapses.Synapse:
    if loihi or delay == 1:
        return nengo.Lowpass(tau_syn_ms / 1000.0)
    e_s = float(np.exp(-dt / tau_syn_ms))
    # (1 - e_s) z^-delay / (1 - e_s z^-1): unit DC gain, first output `delay` steps after the input
    den = [1.0, -e_s] + [0.0] * (delay - 1)
    return nengo.LinearFilter([1.0 - e_s], den, analog=False)


def _conv_transform(proj: Projection, conn: ConvolutionConnector, kernel: np.ndarray) -> nengo.Convolution:
    mode = conv_padding_mode(conn)
    if mode is None:
        raise UnsupportedFeatureError(
            f"Projection {proj.name!r}: ConvolutionConnector padding {conn.padding} is neither 0 nor Nengo's "
            "'same' padding for this input, stride and kernel."
        )
    return nengo.Convolution(
        n_filters=conn.out_channels,
        input_shape=nengo.transforms.ChannelShape(conn.input_shape, channels_last=False),
        kernel_size=conn.kernel_shape,
        strides=conn.stride,
        padding=mode,
        channels_last=False,
        init=np.ascontiguousarray(np.transpose(kernel, (2, 3, 1, 0))),  # (kh, kw, in, out)
    )


def _matrix_transform(pre: np.ndarray, post: np.ndarray, values: np.ndarray, n_pre: int, n_post: int) -> Any:
    if pre.size > _DENSE_FRACTION * n_pre * n_post:
        dense = np.zeros((n_post, n_pre))
        np.add.at(dense, (post, pre), values)
        return dense
    matrix = scipy.sparse.coo_matrix((values, (post, pre)), shape=(n_post, n_pre)).tocsr()
    matrix.sum_duplicates()
    return nengo.transforms.Sparse((n_post, n_pre), init=matrix)


def _build_projection(
    built: BuiltNetwork,
    network: Network,
    proj: Projection,
    conns: Connections,
    weights: np.ndarray,
    *,
    dt: float,
    loihi: bool,
) -> None:
    mapping = built.mappings[proj.post]
    tau_syn = mapping.tau_syn(proj.receptor_type)
    sign = 1.0 if proj.receptor_type == "excitatory" else -1.0
    scale = sign * transform_scale(tau_syn, mapping.tau_m, dt)
    from_source = network.populations[proj.pre].is_source
    post_obj = built.ensembles[proj.post].neurons
    n_pre, n_post = network.populations[proj.pre].size, network.populations[proj.post].size
    steps = delay_steps(conns.delay, dt)
    made: list[nengo.Connection] = []
    for k in np.unique(steps):
        if not from_source:
            pre_obj = built.ensembles[proj.pre].neurons
        else:
            # Nengo delays source spikes in the synapse filter, NengoLoihi (Lowpass only) when replaying them
            shift = int(k) - 1 if loihi else 0
            pre_obj = _gate(built, proj.pre, n_pre, shift, dt_s=dt / 1000.0, loihi=loihi).neurons
        synapse = _synapse(tau_syn, dt, filter_delay(int(k), from_source=from_source), loihi)
        if isinstance(proj.connector, ConvolutionConnector):
            transform: Any = _conv_transform(proj, proj.connector, np.asarray(proj.synapse.weight) * scale)
        else:
            sel = steps == k
            transform = _matrix_transform(conns.pre[sel], conns.post[sel], weights[sel] * scale, n_pre, n_post)
        label = proj.name if len(made) == 0 else f"{proj.name}#delay{int(k)}"
        made.append(nengo.Connection(pre_obj, post_obj, transform=transform, synapse=synapse, label=label))
    built.connections[proj.name] = made


def build_network(
    network: Network,
    connections: Mapping[str, Connections],
    weights: Mapping[str, np.ndarray],
    *,
    dt: float,
    seed: int,
    loihi: bool,
    voltage_populations: frozenset[str] = frozenset(),
    block_shapes: Mapping[str, tuple[tuple[int, ...], tuple[int, ...]]] | None = None,
) -> BuiltNetwork:
    """Build the Nengo network for ``network``.

    Parameters
    ----------
    network
        The (checked) neurovpr network.
    connections, weights
        Each projection's expanded connections and current weights (canonical order).
    dt
        Time step (ms).
    seed
        Seed of the Nengo network (nothing in it is random; it fixes Nengo's own seeds).
    loihi
        Build for NengoLoihi: ``nengo.Lowpass`` synapses, sources off-chip, block shapes.
    voltage_populations
        Populations whose membrane voltage is probed.
    block_shapes
        NengoLoihi ``BlockShape`` arguments ``(block shape, ensemble shape)`` per population.

    Returns
    -------
    BuiltNetwork
        The network and the Nengo objects of every population and projection.
    """
    with nengo.Network(label=network.name, seed=seed % 2**31) as net:
        if loihi:
            import nengo_loihi

            nengo_loihi.add_params(net)
        built = BuiltNetwork(net=net)
        for pop in network.populations.values():
            if pop.is_source:
                continue
            assert isinstance(pop.cell_type, IF_curr_exp)
            mapping = normalised_lif(pop)
            ens = nengo.Ensemble(
                pop.size,
                1,
                neuron_type=nengo.LIF(
                    tau_rc=mapping.tau_m / 1000.0,
                    tau_ref=mapping.tau_refrac / 1000.0,
                    min_voltage=-np.inf,
                    initial_state={"voltage": mapping.v_init, "refractory_time": np.zeros(pop.size)},
                ),
                gain=mapping.gain,
                bias=mapping.bias,
                encoders=np.ones((pop.size, 1)),
                label=pop.name,
            )
            if loihi and block_shapes and pop.name in block_shapes:
                import nengo_loihi

                shape, ens_shape = block_shapes[pop.name]
                net.config[ens].block_shape = nengo_loihi.BlockShape(tuple(shape), tuple(ens_shape))
            built.mappings[pop.name] = mapping
            built.ensembles[pop.name] = ens
            built.spike_probes[pop.name] = nengo.Probe(ens.neurons, "output", synapse=None)
            if pop.name in voltage_populations:
                built.voltage_probes[pop.name] = nengo.Probe(ens.neurons, "voltage", synapse=None)
        for proj in network.projections.values():
            _build_projection(built, network, proj, connections[proj.name], weights[proj.name], dt=dt, loihi=loihi)
    return built
