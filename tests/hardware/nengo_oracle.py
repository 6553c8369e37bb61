"""NengoLoihi's own partitioning of a neurovpr network, used as the oracle of the Loihi checker.

The network is rebuilt as the equivalent Nengo model (one ensemble per population, spike
sources as off-chip ensembles whose spikes NengoLoihi injects from the host; dense,
sparse and convolution transforms as the checker assumes) and NengoLoihi's builder
splits it into blocks. Validation is switched off during the build so that the blocks of
a network that does not fit can still be compared; ``validate_block`` is then run on
each block to collect NengoLoihi's own error message.
"""

from __future__ import annotations

import re
import warnings
from dataclasses import dataclass

import numpy as np

import neurovpr as nv

_LABEL = re.compile(r"<Ensemble '([^']+)'>(?:\[(\d+):(\d+)(?::\d+)?\])?")


@dataclass
class OracleBlock:
    population: str
    lo: int
    hi: int
    compartments: int
    input_axons: int
    output_axons: int
    synapse_bits: int
    error: str | None


def nengo_network(network: nv.Network, seed: int = 0):
    """The Nengo model NengoLoihi would be given for ``network``."""
    import nengo
    import nengo_loihi

    ens = {}
    with nengo.Network(seed=seed) as net:
        nengo_loihi.add_params(net)
        for pop in network.populations.values():
            n = pop.size
            if pop.is_source:
                e = nengo.Ensemble(n, 1, neuron_type=nengo.SpikingRectifiedLinear(), gain=np.ones(n),
                                   bias=np.zeros(n), label=pop.name)
                net.config[e].on_chip = False
            else:
                e = nengo.Ensemble(n, 1, neuron_type=nengo.LIF(), gain=np.ones(n), bias=np.zeros(n), label=pop.name)
            ens[pop.name] = e
        for proj in network.projections.values():
            pre, post = network.populations[proj.pre], network.populations[proj.post]
            sign = -1.0 if proj.receptor_type == "inhibitory" else 1.0
            conn = proj.connector
            if isinstance(conn, nv.ConvolutionConnector):
                if any(conn.padding):
                    raise ValueError("the oracle maps only unpadded convolutions")
                transform = nengo.Convolution(
                    n_filters=conn.out_channels, input_shape=conn.input_shape, kernel_size=conn.kernel_shape,
                    strides=conn.stride, padding="valid", channels_last=False,
                    init=sign * np.asarray(proj.synapse.weight).transpose(2, 3, 1, 0),
                )
            else:
                c = nv.expand(network, proj, dt=1.0, seed=seed)
                if isinstance(conn, nv.AllToAllConnector):
                    transform = np.zeros((post.size, pre.size))
                    transform[c.post, c.pre] = sign * c.weight
                else:
                    transform = nengo.transforms.Sparse(
                        (post.size, pre.size), indices=np.stack([c.post, c.pre], axis=1), init=sign * c.weight
                    )
            nengo.Connection(ens[proj.pre].neurons, ens[proj.post].neurons, transform=transform, synapse=0.005)
    return net


def nengo_blocks(network: nv.Network, seed: int = 0) -> list[OracleBlock]:
    """NengoLoihi's blocks for ``network``, in model order, with their utilisation."""
    from nengo_loihi.builder import Model
    from nengo_loihi.builder.builder import ValidationLevel
    from nengo_loihi.builder.validate import validate_block

    net = nengo_network(network, seed)
    model = Model(dt=0.001)
    model.validation_level = ValidationLevel.NONE
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model.build(net)
    out = []
    for block in model.blocks:
        match = _LABEL.match(str(block.label))
        assert match, block.label
        name = match.group(1)
        n = block.compartment.n_compartments
        lo = int(match.group(2)) if match.group(2) else 0
        hi = int(match.group(3)) if match.group(3) else n
        use = block.utilization()
        try:
            validate_block(block)
            error = None
        except Exception as exc:  # NengoLoihi raises BuildError or AssertionError
            error = str(exc)
        out.append(
            OracleBlock(name, lo, hi, use["compartments"][0], use["in-axons"][0], use["out-axons"][0],
                        use["synapses"][0], error)
        )
    return out


def nengo_chips(network: nv.Network, n_chips: int, cores_per_chip: int = 128, seed: int = 0) -> int:
    """Chips NengoLoihi's Greedy allocator uses (it raises when ``n_chips`` is too few)."""
    from nengo_loihi.builder import Model
    from nengo_loihi.builder.builder import ValidationLevel
    from nengo_loihi.hardware.allocators import Greedy

    model = Model(dt=0.001)
    model.validation_level = ValidationLevel.NONE
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model.build(nengo_network(network, seed))
    return Greedy(cores_per_chip=cores_per_chip)(model, n_chips=n_chips).n_chips
