"""Sinabs's rules for putting a convolutional network onto SynSense Speck / DYNAP-CNN.

Speck has nine cores; each holds one layer: a convolution (a dense layer is a convolution
whose kernel covers its whole input, Sinabs's ``convert_linear_to_conv``) feeding
integrate-and-fire neurons. Sinabs's ``DynapcnnLayer.memory_summary``
(``sinabs/backend/dynapcnn/dynapcnn_layer.py``) gives the memory a layer needs::

    kernel = c * 2 ** (ceil(log2(kh * kw)) + ceil(log2(f)))
    neuron = f * 2 ** (ceil(log2(out_h)) + ceil(log2(out_w)))
    bias   = f if the layer has a bias else 0

(``c`` input channels, ``f`` output channels); a layer fits a core when all three are
within that core's memories (``mapping.LayerConstraints.fits``), and layers are assigned
to cores by the maximum flow of ``mapping.get_valid_mapping``: a bipartite flow network
source -> layers -> the cores each fits -> sink, augmented along shortest paths
(Edmonds-Karp) with the edges in layer and core order, so that the assignment is the one
Sinabs makes. The per-core memories come from the hwspec's ``[speck]`` table (Sinabs's
``chips/dynapcnn.py get_constraints``).

In the IR, a layer is a neuron population fed by one ``ConvolutionConnector`` or
``AllToAllConnector`` projection; a population's ``(c, h, w)`` shape comes from the
convolutions it feeds or is fed by (else ``(n, 1, 1)``); a population with a nonzero
``i_offset`` has a bias per output channel. Spike sources are the sensor input (Speck's DVS
or the host), using no core.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

import numpy as np

from neurovpr.ir.connectors import AllToAllConnector, ConvolutionConnector
from neurovpr.ir.network import Network

from .architectures import Architecture
from .cores import CoreSlice, Partition, Violation
from .hwspec import HwSpec, spec_field

__all__ = ["SpeckRules", "SpeckLayer", "speck_layers", "assign_cores", "partition_speck", "population_shapes", "SPECK"]

_MEMORIES = ("kernel_memory", "neuron_memory", "bias_memory")


@dataclass(frozen=True, slots=True, kw_only=True)
class SpeckRules:
    """``[speck]``: per-core kernel, neuron and bias memories (entries), and the square-kernel rule."""

    kernel_memory: tuple[int, ...] = spec_field("int_list")
    neuron_memory: tuple[int, ...] = spec_field("int_list")
    bias_memory: tuple[int, ...] = spec_field("int_list")
    square_kernels: bool = spec_field("bool")

    def core_memories(self, core: int) -> dict[str, int]:
        """The three memories of ``core``."""
        return {"kernel_memory": self.kernel_memory[core], "neuron_memory": self.neuron_memory[core],
                "bias_memory": self.bias_memory[core]}


@dataclass(frozen=True, slots=True, kw_only=True)
class SpeckLayer:
    """One layer (population) as Sinabs sizes it: its kernel shape and the memory it needs."""

    population: str
    projection: str
    kernel: tuple[int, int, int, int]
    out_hw: tuple[int, int]
    memory: dict[str, int]


def _log2_ceil(n: int) -> int:
    return math.ceil(math.log2(n)) if n > 1 else 0


def population_shapes(network: Network) -> dict[str, tuple[int, int, int]]:
    """``(c, h, w)`` of every population: from the convolutions it feeds or is fed by, else ``(n, 1, 1)``."""
    shapes: dict[str, tuple[int, int, int]] = {}
    for proj in network.projections.values():
        if isinstance(proj.connector, ConvolutionConnector):
            shapes.setdefault(proj.pre, proj.connector.input_shape)
            shapes.setdefault(proj.post, proj.connector.output_shape)
    for name, pop in network.populations.items():
        shapes.setdefault(name, (pop.size, 1, 1))
    return shapes


def speck_layers(network: Network) -> tuple[list[SpeckLayer], list[Violation]]:
    """The layers of ``network`` with their memory (``DynapcnnLayer.memory_summary``), and what cannot be a layer."""
    shapes = population_shapes(network)
    incoming: dict[str, list] = {}
    for proj in network.projections.values():
        incoming.setdefault(proj.post, []).append(proj)
    layers: list[SpeckLayer] = []
    problems: list[Violation] = []
    for name, pop in network.populations.items():
        if pop.is_source or name not in incoming:
            continue
        projs = incoming[name]
        if len(projs) > 1:
            problems.append(Violation(
                limit="inputs per layer", where=name, value=len(projs), maximum=1,
                message=(f"Population {name!r} receives {len(projs)} projections; a Speck core holds one "
                         "convolution per layer."),
            ))
        proj = projs[0]
        conn = proj.connector
        if isinstance(conn, ConvolutionConnector):
            kernel = (conn.out_channels, conn.input_shape[0], *conn.kernel_shape)
            out_hw = conn.output_hw
        elif isinstance(conn, AllToAllConnector):
            c, h, w = shapes[proj.pre]
            kernel, out_hw = (pop.size, c, h, w), (1, 1)
        else:
            continue  # reported by the common connector check
        f, c, kh, kw = kernel
        bias = np.asarray(getattr(pop.cell_type, "i_offset", 0.0))
        memory = {
            "kernel_memory": c * 2 ** (_log2_ceil(kh * kw) + _log2_ceil(f)),
            "neuron_memory": f * 2 ** (_log2_ceil(out_hw[0]) + _log2_ceil(out_hw[1])),
            "bias_memory": f if np.any(bias != 0) else 0,
        }
        layers.append(SpeckLayer(population=name, projection=proj.name, kernel=kernel, out_hw=out_hw, memory=memory))
    return layers, problems


def _augment(cap: list[dict[int, int]], order: list[list[int]], source: int, sink: int) -> bool:
    """One shortest augmenting path (breadth first, edges in insertion order); True if one was found."""
    pred: list[int | None] = [None] * len(cap)
    seen = [False] * len(cap)
    seen[source] = True
    queue = deque([source])
    while queue:
        node = queue.popleft()
        for nxt in order[node]:
            if not seen[nxt] and cap[node][nxt] > 0:
                seen[nxt] = True
                pred[nxt] = node
                queue.append(nxt)
    if not seen[sink]:
        return False
    node = sink
    while node != source:
        prev = pred[node]
        assert prev is not None
        cap[prev][node] -= 1
        cap[node][prev] += 1
        node = prev
    return True


def assign_cores(candidates: list[list[int]], n_cores: int) -> list[int | None]:
    """Layer -> core by maximum bipartite flow (Edmonds-Karp), as ``get_valid_mapping`` computes it.

    ``candidates[i]`` are the cores layer ``i`` fits, ascending. Nodes: source 0, layers
    ``1..L``, cores ``L+1..L+C``, sink; edges are added source -> layers, layers -> cores,
    cores -> sink, each with its reverse, and searched in that order. Returns the core of
    each layer, ``None`` for a layer left without one.
    """
    n_layers = len(candidates)
    sink = n_layers + n_cores + 1
    cap: list[dict[int, int]] = [{} for _ in range(sink + 1)]
    order: list[list[int]] = [[] for _ in range(sink + 1)]

    def edge(a: int, b: int) -> None:
        cap[a][b] = 1
        cap[b].setdefault(a, 0)
        order[a].append(b)
        order[b].append(a)

    for i in range(n_layers):
        edge(0, i + 1)
    for i, cores in enumerate(candidates):
        for core in cores:
            edge(i + 1, n_layers + 1 + core)
    for core in range(n_cores):
        edge(n_layers + 1 + core, sink)
    while _augment(cap, order, 0, sink):
        pass
    out: list[int | None] = []
    for i in range(n_layers):
        used = [c for c in candidates[i] if cap[i + 1][n_layers + 1 + c] == 0]
        out.append(used[0] if used else None)
    return out


def partition_speck(network: Network, spec: HwSpec, *, seed: int = 0) -> Partition:
    """Assign the layers of ``network`` to Speck's cores with Sinabs's rules (see the module docstring)."""
    rules = spec.rules
    assert isinstance(rules, SpeckRules), "the speck partitioner needs [speck]"
    n_cores = len(rules.kernel_memory)
    layers, violations = speck_layers(network)
    for layer in layers:
        _, _, kh, kw = layer.kernel
        if rules.square_kernels and kh != kw:
            violations.append(Violation(
                limit="square kernel", where=layer.projection, value=kh, maximum=kw,
                message=f"Projection {layer.projection!r}: kernel {kh}x{kw} is not square; {spec.name} kernels are square.",
            ))
    candidates = [
        [c for c in range(n_cores) if all(0 <= layer.memory[m] <= rules.core_memories(c)[m] for m in _MEMORIES)]
        for layer in layers
    ]
    assigned = assign_cores(candidates, n_cores)
    cores: list[CoreSlice] = []
    for layer, core, cands in zip(layers, assigned, candidates, strict=True):
        limits = rules.core_memories(core) if core is not None else {
            m: max(getattr(rules, m)) for m in _MEMORIES}
        cores.append(CoreSlice(population=layer.population, lo=0, hi=network.populations[layer.population].size,
                               kind="neurons", location=None if core is None else (core,), usage=dict(layer.memory),
                               limits=limits))
        if cands:
            continue
        largest = {m: max(getattr(rules, m)) for m in _MEMORIES}
        over = [m for m in _MEMORIES if layer.memory[m] > largest[m]]
        if over:
            for m in over:
                violations.append(Violation(
                    limit=m.replace("_", " "), where=layer.population, value=layer.memory[m], maximum=largest[m],
                    message=(f"Layer {layer.population!r} needs {layer.memory[m]} entries of {m.replace('_', ' ')}, "
                             f"more than the largest {spec.name} core's {largest[m]}."),
                ))
        else:
            need = ", ".join(f"{m.replace('_', ' ')} {layer.memory[m]}" for m in _MEMORIES)
            violations.append(Violation(
                limit="core memory", where=layer.population, value=layer.memory["kernel_memory"],
                maximum=largest["kernel_memory"],
                message=f"Layer {layer.population!r} needs {need}; no single {spec.name} core has all three.",
            ))
    unplaced = [layer.population for layer, core, cands in zip(layers, assigned, candidates, strict=True)
                if core is None and cands]
    if len(layers) > n_cores:
        violations.append(Violation(
            limit="cores", where=network.name, value=len(layers), maximum=n_cores,
            message=f"Network {network.name!r} has {len(layers)} layers but {spec.name} has {n_cores} cores (one layer each).",
        ))
    elif unplaced:
        violations.append(Violation(
            limit="cores", where=network.name, value=len(layers), maximum=n_cores,
            message=(f"Network {network.name!r}: no assignment of its {len(layers)} layers to the {n_cores} "
                     f"{spec.name} cores leaves a fitting core for {', '.join(repr(p) for p in unplaced)}."),
        ))
    notes = (
        "One layer per core; `location` is the core Sinabs's get_valid_mapping assigns (maximum flow).",
        "Memory per layer follows Sinabs's DynapcnnLayer.memory_summary (entries, powers of two).",
    )
    return Partition(hardware=spec.name, cores=tuple(cores), chips=1, violations=tuple(violations),
                     host=tuple(n for n, p in network.populations.items() if p.is_source), notes=notes)


#: Sinabs's DYNAP-CNN / Speck rules, for hwspecs with ``partitioner = "speck"`` (entry point ``neurovpr.architectures``).
SPECK = Architecture(name="speck", table="speck", rules=SpeckRules, partition=partition_speck)
