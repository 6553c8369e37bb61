"""NIR graph -> neurovpr network, following the table in :mod:`.mapping`.

Input nodes become spike-source populations, neuron nodes ``IF_curr_exp``
populations, and every chain of linear nodes from one population to another becomes
one projection. Nested graphs are flattened first. The result also says which
population each NIR ``Input`` and ``Output`` node stands for (the IR has no output
marker) and lists every approximation the import made.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any

import numpy as np
import scipy.sparse as sp

from neurovpr.errors import ValidationError
from neurovpr.ir.cells import SpikeSourceArray
from neurovpr.ir.connectors import AllToAllConnector, ConvolutionConnector, FromListConnector, OneToOneConnector
from neurovpr.ir.network import Network, Population, Projection
from neurovpr.ir.synapses import StaticSynapse
from neurovpr.resources import require_memory, require_nodes

from .linear import Op, compose, op_from_node
from .mapping import NEURON_NODES, cell_from_node

__all__ = ["NIRImport", "graph_to_network", "flatten_graph"]

_MAX_DEPTH = 16
_MAX_PATHS = 100_000
_NAME_BAD = re.compile(r"[^A-Za-z0-9_.:\->]")


@dataclass(frozen=True, slots=True)
class NIRImport:
    """The outcome of importing a NIR graph.

    Attributes
    ----------
    network
        The IR network.
    inputs, outputs
        NIR ``Input`` / ``Output`` node name -> population name.
    notes
        One sentence per approximation or choice the import made.
    restored
        True when the network was restored exactly from neurovpr's own metadata.
    """

    network: Network
    inputs: Mapping[str, str] = field(default_factory=dict)
    outputs: Mapping[str, str] = field(default_factory=dict)
    notes: tuple[str, ...] = ()
    restored: bool = False


def flatten_graph(graph: Any, prefix: str = "", depth: int = 0) -> tuple[dict[str, Any], dict[str, str], list[tuple[str, str]]]:
    """Nodes, their roles (``input``, ``output``, ``neuron``, ``linear``) and edges, subgraphs inlined."""
    if depth > _MAX_DEPTH:
        raise ValidationError(f"NIR graph {prefix!r} nests subgraphs more than {_MAX_DEPTH} levels deep.")
    nodes: dict[str, Any] = {}
    roles: dict[str, str] = {}
    edges: list[tuple[str, str]] = []
    ports: dict[str, tuple[list[str], list[str]]] = {}
    for key, node in graph.nodes.items():
        key = str(key)
        kind = type(node).__name__
        full = prefix + key
        if kind == "NIRGraph":
            sub_nodes, sub_roles, sub_edges = flatten_graph(node, f"{full}.", depth + 1)
            ins = [f"{full}.{k}" for k, n in node.nodes.items() if type(n).__name__ == "Input"]
            outs = [f"{full}.{k}" for k, n in node.nodes.items() if type(n).__name__ == "Output"]
            for k in ins + outs:
                sub_roles[k] = "linear"  # the subgraph's ports pass the signal through
            nodes.update(sub_nodes)
            roles.update(sub_roles)
            edges.extend(sub_edges)
            ports[full] = (ins, outs)
            continue
        nodes[full] = node
        if kind == "Input":
            roles[full] = "input"
        elif kind == "Output":
            roles[full] = "output"
        elif kind in NEURON_NODES:
            roles[full] = "neuron"
        else:
            roles[full] = "linear"
    for a, b in graph.edges:
        a, b = prefix + str(a), prefix + str(b)
        if a in ports:
            outs = ports[a][1]
            if len(outs) != 1:
                raise ValidationError(f"NIR subgraph {a!r} has {len(outs)} Output nodes; neurovpr needs exactly one.")
            a = outs[0]
        if b in ports:
            ins = ports[b][0]
            if len(ins) != 1:
                raise ValidationError(f"NIR subgraph {b!r} has {len(ins)} Input nodes; neurovpr needs exactly one.")
            b = ins[0]
        for end in (a, b):
            if end not in nodes:
                raise ValidationError(f"NIR edge ({a!r}, {b!r}) names a node {end!r} that the graph does not have.")
        edges.append((a, b))
    return nodes, roles, edges


def _shape_of(value: Any) -> tuple[int, ...] | None:
    if value is None:
        return None
    arr = np.asarray(value).reshape(-1)
    if arr.size == 0 or np.any(arr < 1) or np.any(arr != np.round(arr)):
        return None
    return tuple(int(v) for v in arr)


def _neuron_shape(node: Any) -> tuple[int, ...] | None:
    shapes = [np.shape(v) for k in ("v_threshold", "r", "tau", "tau_mem") if (v := getattr(node, k, None)) is not None]
    full = [s for s in shapes if int(np.prod(s)) > 1]
    return tuple(int(v) for v in full[0]) if full else None


class _Builder:
    """Turns one flattened NIR graph into populations and projections."""

    def __init__(self, nodes: dict[str, Any], roles: dict[str, str], edges: list[tuple[str, str]], dt: float, integration: str):
        self.nodes, self.roles, self.dt, self.integration = nodes, roles, dt, integration
        self.succ: dict[str, list[str]] = {k: [] for k in nodes}
        self.pred: dict[str, list[str]] = {k: [] for k in nodes}
        for a, b in edges:
            if b not in self.succ[a]:
                self.succ[a].append(b)
                self.pred[b].append(a)
        self.notes: list[str] = []
        self.shapes: dict[str, tuple[int, ...]] = {}
        self.ops: dict[str, Op] = {}

    # -- shapes ------------------------------------------------------------------------
    def infer_shapes(self) -> None:
        for name, role in self.roles.items():
            node = self.nodes[name]
            if role == "input":
                shape = _shape_of(node.input_type.get("input") if isinstance(node.input_type, dict) else None)
                if shape is None:
                    raise ValidationError(f"NIR Input node {name!r} has no valid shape.")
                self.shapes[name] = shape
            elif role == "neuron" and (shape := _neuron_shape(node)) is not None:
                self.shapes[name] = shape
        changed = True
        while changed:
            changed = False
            for name, role in self.roles.items():
                if role not in ("linear", "neuron") or name in self.ops:
                    continue
                preds = self.pred[name]
                if not preds or any(p not in self.shapes for p in preds):
                    continue
                sizes = {int(np.prod(self.shapes[p])) for p in preds}
                if len(sizes) != 1:
                    raise ValidationError(f"NIR node {name!r} receives signals of different sizes {sorted(sizes)}.")
                in_shape = self.shapes[preds[0]]
                if role == "linear":
                    self.ops[name] = op_from_node(name, self.nodes[name], in_shape)
                    self.shapes[name] = self.ops[name].out_shape
                    changed = True
                elif name not in self.shapes:
                    self.shapes[name] = in_shape
                    changed = True
                elif int(np.prod(self.shapes[name])) != sizes.pop():
                    raise ValidationError(
                        f"NIR node {name!r} has {int(np.prod(self.shapes[name]))} neurons "
                        f"but receives a signal of shape {in_shape}."
                    )
        self._refuse_linear_cycles()
        for name, role in self.roles.items():
            if role == "neuron" and name not in self.shapes:
                raise ValidationError(
                    f"The size of NIR neuron node {name!r} cannot be inferred (it has scalar parameters and no sized input)."
                )

    def _refuse_linear_cycles(self) -> None:
        """A loop with no neuron in it has no time step to break it."""
        linear = {k for k, r in self.roles.items() if r == "linear"}
        state: dict[str, int] = {}
        for start in linear:
            if start in state:
                continue
            stack = [(start, iter(self.succ[start]))]
            trail = [start]
            state[start] = 1
            while stack:
                node, it = stack[-1]
                nxt = next((s for s in it if s in linear), None)
                if nxt is None:
                    state[node] = 2
                    stack.pop()
                    trail.pop()
                elif state.get(nxt) == 1:
                    loop = [*trail[trail.index(nxt):], nxt]
                    raise ValidationError(f"NIR graph has a cycle through linear nodes only ({' -> '.join(loop)}).")
                elif state.get(nxt) is None:
                    state[nxt] = 1
                    stack.append((nxt, iter(self.succ[nxt])))
                    trail.append(nxt)

    # -- paths ---------------------------------------------------------------------------
    def paths_from(self, src: str) -> list[list[str]]:
        """Every chain ``[src, linear..., target]`` that ends at a neuron or an Output node."""
        found: list[list[str]] = []
        stack: list[list[str]] = [[src, s] for s in reversed(self.succ[src])]
        while stack:
            path = stack.pop()
            last = path[-1]
            role = self.roles[last]
            if role in ("neuron", "output"):
                found.append(path)
            elif role == "input":
                raise ValidationError(f"NIR edge into Input node {last!r} from {path[-2]!r}: an Input cannot receive signals.")
            elif last in path[1:-1]:
                raise ValidationError(f"NIR graph has a cycle through linear nodes only ({' -> '.join(path[1:])}).")
            elif last not in self.ops:
                raise ValidationError(f"NIR node {last!r} receives no signal whose shape is known.")
            elif not self.succ[last]:
                self.notes.append(f"NIR node {last!r} leads nowhere and was left out.")
            else:
                stack.extend([*path, s] for s in reversed(self.succ[last]))
            if len(found) + len(stack) > _MAX_PATHS:
                raise ValidationError(f"NIR graph has more than {_MAX_PATHS} paths between neuron nodes.")
        return found


def _valid_name(raw: str) -> bool:
    """True when a NIR node name is already a valid IR name (not only a number)."""
    return 0 < len(raw) <= 120 and not _NAME_BAD.search(raw) and re.match(r"[A-Za-z_]", raw[0]) is not None


def _ir_name(raw: str, taken: set[str]) -> str:
    name = _NAME_BAD.sub("_", raw)[:120] or "node"
    if not re.match(r"[A-Za-z_]", name[0]):
        name = "n_" + name
    base, k = name, 2
    while name in taken:
        name = f"{base}_{k}"
        k += 1
    taken.add(name)
    return name


def _delays_ms(
    pre_delay: np.ndarray | None, post_delay: np.ndarray | None, dt: float, where: str, notes: list[str]
) -> tuple[np.ndarray | None, str]:
    """Per-element delays (ms) and on which side (``pre``/``post``), or ``None``."""
    vec, side = (pre_delay, "pre") if pre_delay is not None else (post_delay, "post")
    if vec is None or not np.any(vec > 0):
        return None, side
    ms = vec * 1000.0
    short = (ms < dt) & ~np.isclose(ms, dt, rtol=1e-9, atol=0.0)
    if np.any(short):
        notes.append(f"{where}: delays below the step {dt:g} ms (NIR zero delay included) become one step.")
    return np.where(short, dt, ms), side


def _connector(proj_ops: list[Op], chain: list[Op], n_pre: int, delays: np.ndarray | None, side: str) -> tuple[Any, Any]:
    """The connector and synapse for a chain: its weight ops alone, and all its non-delay ops."""
    uniform = delays is None or np.all(delays == delays[0])
    delay = None if delays is None else float(delays[0]) if uniform else None
    if uniform and len(proj_ops) == 0:
        return OneToOneConnector(), StaticSynapse(weight=1.0, delay=delay)
    if uniform and len(proj_ops) == 1:
        op = proj_ops[0]
        if op.kind in ("Affine", "Linear"):
            w = np.asarray(op.node.weight, dtype=np.float64).T
            if np.all(w != 0):
                return AllToAllConnector(), StaticSynapse(weight=np.ascontiguousarray(w), delay=delay)
            pre, post = np.nonzero(w)
            return FromListConnector(conn_list=np.column_stack([pre, post, w[pre, post]])), StaticSynapse(delay=delay)
        if op.kind == "Scale":
            s = op.extra["scale"]
            return OneToOneConnector(), StaticSynapse(weight=float(s[0]) if np.all(s == s[0]) else s, delay=delay)
        if op.convolution_ready or (op.kind in ("SumPool2d", "AvgPool2d") and op.in_shape[0] == 1 and op.pads[0] == op.pads[1]
                                    and op.pads[2] == op.pads[3]):  # fmt: skip
            kh, kw = op.extra["kernel"]
            if op.kind == "Conv2d":
                kernel = op.extra["weight"]
            else:
                kernel = np.full((1, 1, kh, kw), 1.0 if op.kind == "SumPool2d" else 1.0 / (kh * kw))
            conn = ConvolutionConnector(
                input_shape=op.in_shape, kernel_shape=(kh, kw), out_channels=op.out_shape[0],
                stride=op.extra["stride"], padding=(op.pads[0], op.pads[2]),
            )  # fmt: skip
            return conn, StaticSynapse(weight=kernel, delay=delay)
    matrix = (compose(chain)[0] if chain else sp.identity(n_pre, format="csr", dtype=np.float64)).tocoo()
    order = np.lexsort((matrix.row, matrix.col))
    pre, post, w = matrix.col[order], matrix.row[order], matrix.data[order]
    cols = [pre, post, w]
    if delays is not None and not uniform:
        cols.append(delays[pre] if side == "pre" else delays[post])
    return FromListConnector(conn_list=np.column_stack(cols) if pre.size else np.zeros((0, 2))), StaticSynapse(delay=delay)


def _recurrent(net: Network) -> list[str]:
    """Projections whose target reaches back to their source."""
    succ: dict[str, set[str]] = {}
    for p in net.projections.values():
        succ.setdefault(p.pre, set()).add(p.post)
    found = []
    for p in net.projections.values():
        seen, todo = set(), [p.post]
        while todo:
            node = todo.pop()
            if node == p.pre:
                found.append(p.name)
                break
            if node not in seen:
                seen.add(node)
                todo.extend(succ.get(node, ()))
    return found


def graph_to_network(graph: Any, *, name: str, dt: float, integration: str) -> NIRImport:
    """Build the IR network of a NIR graph (no metadata shortcut; see :func:`neurovpr.interop.nir.import_nir`)."""
    nodes, roles, edges = flatten_graph(graph)
    require_nodes(len(nodes), len(edges), f"NIR graph {name!r}", kinds=("nodes", "edges"))
    b = _Builder(nodes, roles, edges, dt, integration)
    b.infer_shapes()
    taken: set[str] = set()
    pop_names = {k: _ir_name(k, taken) for k, r in roles.items() if r in ("input", "neuron")}
    sizes = {k: int(np.prod(b.shapes[k], dtype=np.float64)) for k in pop_names}
    if sizes:
        largest = max(sizes, key=sizes.__getitem__)
        require_memory(
            16.0 * 8 * sum(sizes.values()),
            f"importing NIR graph: {sum(sizes.values())} neurons (node {largest!r} alone {sizes[largest]})",
        )
    bias = {k: np.zeros(sizes[k]) for k, r in roles.items() if r == "neuron"}
    projections: list[tuple[str, str, Any, Any, str | None]] = []
    outputs: dict[str, str] = {}
    for src in pop_names:
        for path in b.paths_from(src):
            dst, chain = path[-1], [b.ops[k] for k in path[1:-1]]
            core = [op for op in chain if op.kind not in ("Flatten", "pass")]
            weights = [op for op in core if op.kind != "Delay"]
            if roles[dst] == "output":
                if weights or core:
                    raise ValidationError(
                        f"NIR Output {dst!r} is fed by linear node(s) {[op.name for op in core]}, not by a neuron node."
                    )
                if outputs.get(dst, pop_names[src]) != pop_names[src]:
                    raise ValidationError(f"NIR Output {dst!r} is fed by several populations.")
                outputs[dst] = pop_names[src]
                continue
            where = f"NIR path {' -> '.join(path)}"
            pre_d = post_d = None
            lead = 0
            while lead < len(core) and core[lead].kind == "Delay":
                pre_d = core[lead].delay if pre_d is None else pre_d + core[lead].delay
                lead += 1
            trail = len(core)
            while trail > lead and core[trail - 1].kind == "Delay":
                post_d = core[trail - 1].delay if post_d is None else post_d + core[trail - 1].delay
                trail -= 1
            if any(op.kind == "Delay" for op in core[lead:trail]):
                raise ValidationError(f"{where} has a Delay between two weight nodes, which no neurovpr delay can express.")
            if pre_d is not None and post_d is not None:
                raise ValidationError(f"{where} delays both before and after its weights; neurovpr needs one side.")
            delays, side = _delays_ms(pre_d, post_d, dt, where, b.notes)
            linear = [op for op in chain if op.kind != "Delay"]
            if any(np.any(op.bias() != 0) for op in linear):
                bias[dst] += compose(linear)[1]
            if len(weights) > 1:
                b.notes.append(f"{where}: {len(weights)} linear nodes were multiplied into one explicit connection list.")
            conn, syn = _connector(weights, linear, sizes[src], delays, side)
            label = weights[0].name if len(weights) == 1 and _valid_name(weights[0].name) else None
            projections.append((pop_names[src], pop_names[dst], conn, syn, label))
    net = Network(name)
    for key, pop in pop_names.items():
        if roles[key] == "input":
            net.add(Population(name=pop, size=sizes[key], cell_type=SpikeSourceArray.from_lists([[]] * sizes[key])))
    for key, pop in pop_names.items():
        if roles[key] != "neuron":
            continue
        kind = type(nodes[key]).__name__
        where = f"NIR {kind} node {key!r}"
        cell, gain, exact = cell_from_node(nodes[key], kind, sizes[key], dt=dt, integration=integration, where=where)
        if np.any(bias[key] != 0):
            offset = gain * bias[key]
            cell = cell.replace(i_offset=float(offset[0]) if np.all(offset == offset[0]) else offset)
            if not exact:
                b.notes.append(f"{where}: its bias drives the membrane at once; in NIR it rises through the synapse (tau_syn).")
        v_init = 0.0 if np.any(np.asarray(cell.v_rest) != 0) else None  # NIR state starts at 0 (see mapping)
        net.add(Population(name=pop, size=sizes[key], cell_type=cell, v_init=v_init))
    proj_taken: set[str] = set()
    for pre, post, conn, syn, label in projections:
        use_label = label is not None and label not in proj_taken
        pname = _ir_name(label if use_label else f"{pre}->{post}", proj_taken)  # type: ignore[arg-type]
        net.add(Projection(name=pname, pre=pre, post=post, connector=conn, synapse=syn))
    loops = _recurrent(net)
    if loops:
        b.notes.append(
            f"Projections {', '.join(map(repr, loops))} close recurrent loops: each adds one step of latency "
            "compared with a peer that feeds a spike back at the next step, so the loop's dynamics differ."
        )
    inputs = {k: pop_names[k] for k, r in roles.items() if r == "input"}
    return NIRImport(
        network=net,
        inputs=MappingProxyType(inputs),
        outputs=MappingProxyType(outputs),
        notes=tuple(dict.fromkeys(b.notes)),
    )
