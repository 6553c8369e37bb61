"""neurovpr network -> NIR graph, following the table in :mod:`.mapping`.

Sources become ``Input`` nodes, ``IF_curr_exp`` populations CubaLIF/LIF/IF (or
their non-spiking forms), convolutions ``Conv2d``, one-to-one projections ``Scale``
and every other projection a ``Linear`` node holding the dense weight matrix, with
``Flatten`` and ``Delay`` nodes where needed. Anything NIR cannot express raises one
:class:`~neurovpr.errors.ValidationError` sentence naming the object and the feature.
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence
from typing import Any

import numpy as np

from neurovpr.errors import ValidationError
from neurovpr.ir.cells import (
    IF_cond_exp,
    IF_cond_exp_adaptive,
    IF_curr_exp,
    IF_curr_exp_ca2_adaptive,
    SoftLIF,
    SpikeSourceArray,
    SpikeSourcePoisson,
)
from neurovpr.ir.connectivity import expand
from neurovpr.ir.connectors import ConvolutionConnector, FromListConnector, OneToOneConnector
from neurovpr.ir.network import Network, Projection

from .mapping import check_options, node_fields_from_cell

__all__ = ["build_graph", "METADATA_PREFIX"]

#: Prefix of every graph-level metadata key neurovpr writes.
METADATA_PREFIX = "neurovpr_"
#: The largest dense weight matrix an export writes (entries).
MAX_DENSE = 200_000_000

_UNSUPPORTED_CELLS = {
    IF_cond_exp: "conductance-based synapses",
    IF_cond_exp_adaptive: "conductance-based synapses and an adaptive threshold",
    IF_curr_exp_ca2_adaptive: "a Ca2+-activated adaptation current",
    SoftLIF: "a rate (SoftLIF) model, which only trains and never spikes",
}


def _shapes(network: Network) -> dict[str, tuple[int, ...]]:
    """Each population's NIR shape: its convolution map ``(C, H, W)`` or ``(n,)``."""
    found: dict[str, set[tuple[int, ...]]] = {name: set() for name in network.populations}
    for proj in network.projections.values():
        conn = proj.connector
        if isinstance(conn, ConvolutionConnector):
            found[proj.pre].add(tuple(conn.input_shape))
            found[proj.post].add(tuple(conn.output_shape))
    shapes: dict[str, tuple[int, ...]] = {}
    for name, pop in network.populations.items():
        maps = found[name]
        if len(maps) > 1:
            raise ValidationError(
                f"Population {name!r} is used as feature maps of shapes {sorted(maps)}; NIR has no reshape node to join them."
            )
        shapes[name] = maps.pop() if maps else (pop.size,)
    return shapes


def _check(network: Network, allow_refractory: bool) -> dict[str, set[str]]:
    """Refuse what NIR cannot express; return the receptor types reaching each population."""
    for name, pop in network.populations.items():
        cell = pop.cell_type
        for cls, what in _UNSUPPORTED_CELLS.items():
            if type(cell) is cls:
                raise ValidationError(f"Population {name!r} ({cls.__name__}) has {what}, which NIR cannot express.")
        if not isinstance(cell, (IF_curr_exp, SpikeSourceArray, SpikeSourcePoisson)):
            raise ValidationError(f"Population {name!r} has cell type {type(cell).__name__}, which has no NIR equivalent.")
        if isinstance(cell, IF_curr_exp) and not allow_refractory and np.any(np.asarray(cell.tau_refrac) > 0):
            raise ValidationError(
                f"Population {name!r} has tau_refrac = {cell.tau_refrac!r} ms, and NIR neurons have no refractory "
                "period (set it to 0, or allow it to be kept in neurovpr metadata only)."
            )
    receptors: dict[str, set[str]] = {name: set() for name in network.populations}
    for proj in network.projections.values():
        if proj.plastic:
            raise ValidationError(
                f"Projection {proj.name!r} learns with {type(proj.synapse).__name__}, and NIR cannot express plasticity rules."
            )
        receptors[proj.post].add(proj.receptor_type)
    return receptors


def _delays(
    proj: Projection, pre: np.ndarray, post: np.ndarray, delay: np.ndarray, n_pre: int, n_post: int
) -> tuple[str | None, np.ndarray | None]:
    """``(side, per-element delays in ms)`` with side ``None`` (no delay), ``pre`` or ``post``."""
    syn, conn = proj.synapse, proj.connector
    explicit = syn.delay is not None or (isinstance(conn, FromListConnector) and conn.conn_list.shape[1] == 4)
    if not explicit or delay.size == 0:
        return None, None
    if np.all(delay == delay[0]):
        return "pre", np.full(n_pre, delay[0])
    for side, idx, n in (("pre", pre, n_pre), ("post", post, n_post)):
        per = np.full(n, np.nan)
        per[idx] = delay
        if np.array_equal(per[idx], delay):
            return side, np.where(np.isnan(per), 0.0, per)
    raise ValidationError(
        f"Projection {proj.name!r} has delays that vary with both the pre- and the postsynaptic neuron; "
        "a NIR Delay node delays a whole signal."
    )


class _Graph:
    """Nodes and edges under unique NIR names."""

    def __init__(self) -> None:
        self.nodes: dict[str, Any] = {}
        self.edges: list[tuple[str, str]] = []

    def add(self, name: str, node: Any) -> str:
        key, k = name, 2
        while key in self.nodes:
            key = f"{name}_{k}"
            k += 1
        self.nodes[key] = node
        return key

    def chain(self, names: list[str]) -> None:
        self.edges.extend(itertools.pairwise(names))


def build_graph(
    network: Network,
    *,
    dt: float,
    integration: str,
    seed: int = 0,
    allow_refractory: bool = False,
    outputs: Sequence[str] | None = None,
) -> tuple[Any, tuple[str, ...]]:
    """The NIR graph of ``network`` and the notes on what peers will not see.

    Parameters are those of :func:`neurovpr.interop.nir.network_to_nir`.
    """
    import nir

    dt, integration = check_options(dt, integration)
    if not isinstance(network, Network):
        raise ValidationError(f"NIR export needs a neurovpr Network, got {type(network).__name__}.")
    receptors = _check(network, allow_refractory)
    shapes = _shapes(network)
    g = _Graph()
    notes: list[str] = []
    node_of: dict[str, str] = {}
    for name, pop in network.populations.items():
        shape = shapes[name]
        cell = pop.cell_type
        if pop.is_source:
            node_of[name] = g.add(name, nir.Input(input_type={"input": np.array(shape)}))
            notes.append(
                f"Population {name!r} ({type(cell).__name__}) is a NIR Input; its spikes or rates stay in neurovpr metadata."
            )
            continue
        kind, fields = node_fields_from_cell(
            cell, pop.size, receptors=receptors[name], dt=dt, integration=integration, where=f"Population {name!r}"
        )  # type: ignore[arg-type]
        node = getattr(nir, kind)(**{k: v.reshape(shape) for k, v in fields.items()})
        node_of[name] = g.add(name, node)
        start = np.asarray(cell.v_rest if pop.v_init is None else pop.v_init)
        if np.any(start != 0):
            notes.append(f"Population {name!r} starts at v != 0 mV; NIR peers start at 0 (kept in neurovpr metadata).")
        if np.any(np.asarray(cell.tau_refrac) > 0):
            notes.append(f"Population {name!r}: its refractory period is kept in neurovpr metadata only; peers run without it.")
    for proj in network.projections.values():
        _add_projection(g, nir, network, proj, shapes, node_of, dt, seed, notes)
    sinks = {p.pre for p in network.projections.values()}
    if outputs is not None:
        chosen = list(outputs)
    else:
        chosen = [n for n, p in network.populations.items() if not p.is_source and n not in sinks]
    for name in chosen:
        if name not in network.populations:
            raise ValidationError(f"NIR export: output population {name!r} does not exist.")
        out = nir.Output(output_type={"output": np.array(shapes[name])})
        key = g.add("output" if len(chosen) == 1 else f"output_{name}", out)
        g.chain([node_of[name], key])
    meta = {
        f"{METADATA_PREFIX}format": "neurovpr-nir",
        f"{METADATA_PREFIX}format_version": 1,
        f"{METADATA_PREFIX}network_name": network.name,
        f"{METADATA_PREFIX}dt_ms": dt,
        f"{METADATA_PREFIX}integration": integration,
        f"{METADATA_PREFIX}seed": int(seed),
        f"{METADATA_PREFIX}allow_refractory": int(bool(allow_refractory)),
        f"{METADATA_PREFIX}outputs": ",".join(chosen),
    }
    try:
        graph = nir.NIRGraph(nodes=g.nodes, edges=g.edges, metadata=meta, type_check=True)
    except (ValueError, AssertionError, TypeError, KeyError, IndexError) as exc:
        raise ValidationError(f"NIR export of network {network.name!r} failed NIR's type check: {exc}") from None
    return graph, tuple(notes)


def _flatten(g: _Graph, nir: Any, proj_name: str, shape: tuple[int, ...]) -> str:
    return g.add(f"{proj_name}:flatten", nir.Flatten(input_type={"input": np.array(shape)}, start_dim=0, end_dim=-1))


def _add_projection(g: _Graph, nir: Any, network: Network, proj: Projection, shapes: dict, node_of: dict,
                    dt: float, seed: int, notes: list[str]) -> None:  # fmt: skip
    """Add the nodes and edges of one projection."""
    conn, syn = proj.connector, proj.synapse
    pre_shape, post_shape = shapes[proj.pre], shapes[proj.post]
    n_pre, n_post = network.populations[proj.pre].size, network.populations[proj.post].size
    sign = -1.0 if proj.receptor_type == "inhibitory" else 1.0
    head = [node_of[proj.pre]]
    if isinstance(conn, ConvolutionConnector):
        kernel = np.array(syn.weight, dtype=np.float64, copy=True)
        if sign < 0:
            kernel = -kernel
        if syn.delay is not None:
            head.append(g.add(f"{proj.name}:delay", nir.Delay(delay=np.full(pre_shape, float(syn.delay) / 1000.0))))
        weight = nir.Conv2d(
            input_shape=tuple(conn.input_shape[1:]), weight=kernel, stride=tuple(conn.stride), padding=tuple(conn.padding),
            dilation=(1, 1), groups=1, bias=np.zeros(conn.out_channels),
        )  # fmt: skip
        g.chain([*head, g.add(proj.name, weight), node_of[proj.post]])
        return
    c = expand(network, proj, dt=dt, seed=seed)
    if conn.random or not isinstance(syn.weight, (float, np.ndarray)):
        notes.append(f"Projection {proj.name!r}: its random connections or weights were drawn with seed {seed}.")
    side, per = _delays(proj, c.pre, c.post, c.delay, n_pre, n_post)
    if side == "pre":
        head.append(g.add(f"{proj.name}:delay", nir.Delay(delay=(per / 1000.0).reshape(pre_shape))))
    if isinstance(conn, OneToOneConnector):
        if pre_shape != post_shape and len(pre_shape) > 1 and len(post_shape) == 1:
            head.append(_flatten(g, nir, proj.name, pre_shape))
        elif pre_shape != post_shape:
            raise ValidationError(
                f"Projection {proj.name!r} joins shapes {pre_shape} and {post_shape}; NIR has no reshape node."
            )
        scale = np.zeros(n_post)
        scale[c.post] = c.weight
        weight_node = nir.Scale(scale=(sign * scale if sign < 0 else scale).reshape(post_shape))
    else:
        if len(post_shape) > 1:
            raise ValidationError(
                f"Projection {proj.name!r} is dense onto the feature map {proj.post!r} {post_shape}; "
                "NIR has no reshape node for it."
            )
        if n_pre * n_post > MAX_DENSE:
            raise ValidationError(
                f"Projection {proj.name!r} needs a dense {n_post} x {n_pre} NIR weight matrix, "
                f"above the limit of {MAX_DENSE} entries."
            )
        if len(pre_shape) > 1:
            head.append(_flatten(g, nir, proj.name, pre_shape))
        dense = np.zeros((n_post, n_pre))
        if np.unique(c.post * n_pre + c.pre).size != c.pre.size:
            notes.append(f"Projection {proj.name!r}: repeated connections between one pair were summed into one NIR weight.")
            np.add.at(dense, (c.post, c.pre), c.weight)
        else:
            dense[c.post, c.pre] = c.weight
        weight_node = nir.Linear(weight=-dense if sign < 0 else dense)
    tail = [g.add(proj.name, weight_node)]
    if side == "post":
        tail.append(g.add(f"{proj.name}:delay", nir.Delay(delay=(per / 1000.0).reshape(post_shape))))
    g.chain([*head, *tail, node_of[proj.post]])
