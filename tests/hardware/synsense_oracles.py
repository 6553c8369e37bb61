"""Rockpool's and Sinabs's own mapping of a neurovpr network: the oracles of the Xylo and Speck checkers.

Xylo: a chain network (inputs -> hidden populations, each optionally recurrent -> output)
is rebuilt as the equivalent Rockpool network (``LinearTorch`` weights and ``LIFTorch``
neurons in a ``Sequential``, the same weights) and mapped with Rockpool's Xylo Audio 2
mapper (``rockpool.devices.xylo.syns61201.mapper``, design-rule checks included; its
``DRCWarning`` for more than 16 inputs counts as a refusal). The mapped weights, as
integers, are then given to ``XyloSim.from_specification``, whose C++ ``XyloSynapse``
refuses a weight outside int8.

Speck: each layer of the network is rebuilt as Sinabs's ``DynapcnnLayer`` (a torch
``Conv2d``, or ``Linear`` for a dense layer, with an ``IAFSqueeze``), its memory taken
from ``memory_summary`` and the layers assigned to cores by ``get_valid_mapping`` with the
per-core constraints read from Sinabs's own ``chips/dynapcnn.py`` (``get_constraints``;
that module imports samna, so its literal lists are read from the source file).
"""

from __future__ import annotations

import ast
import importlib.util
import itertools
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

import neurovpr as nv
from neurovpr.hardware.speck import speck_layers


@dataclass
class XyloOracle:
    """What Rockpool says: refused (and why, as neurovpr's limit name) or the hardware ids per population."""

    refused: str | None
    first_id: dict[str, int]
    message: str = ""


_ROCKPOOL_LIMITS = (
    ("up to 16 input channels", "input channels"),
    ("up to 8 output channels", "output neurons"),
    ("HW resources for output neurons", "output neurons"),
    ("HW resources for hidden neurons", "hidden neurons"),
    ("Output neurons may not be recurrent", "recurrent output"),
)


def _chain(network: nv.Network) -> list[str]:
    """Population names in chain order (source first); the oracle networks are chains."""
    order = [next(n for n, p in network.populations.items() if p.is_source)]
    while True:
        nxt = [p.post for p in network.projections.values() if p.pre == order[-1] and p.post != p.pre]
        if not nxt:
            return order
        order.append(nxt[0])


def _dense(network: nv.Network, proj) -> np.ndarray:
    conns = nv.expand(network, proj, dt=1.0, seed=0)
    w = np.zeros((network.populations[proj.pre].size, network.populations[proj.post].size))
    np.add.at(w, (conns.pre, conns.post), conns.weight)
    return w


def rockpool_xylo(network: nv.Network) -> XyloOracle:
    """Map ``network`` (a chain) with Rockpool's Xylo Audio 2 mapper, then XyloSim (see the module docstring)."""
    import torch

    from neurovpr.backends.xylo.compat import import_xylo

    x = import_xylo()
    mods = x.modules
    order = _chain(network)
    by_pair = {(p.pre, p.post): p for p in network.projections.values()}
    layers = []
    for pre, post in itertools.pairwise(order):
        w = _dense(network, by_pair[(pre, post)])
        layers.append(mods.LinearTorch(w.shape, weight=torch.tensor(w, dtype=torch.float32), has_bias=False))
        rec = by_pair.get((post, post))
        kwargs = {"dt": 1e-3, "tau_mem": 0.008, "tau_syn": 0.004, "threshold": 10.0}
        if rec is not None:
            kwargs.update(has_rec=True, w_rec=torch.tensor(_dense(network, rec), dtype=torch.float32))
        layers.append(mods.LIFTorch(w.shape[1], **kwargs))
    graph = x.combinators.Sequential(*layers).as_graph()
    with warnings.catch_warnings():
        warnings.simplefilter("error", x.mapper.DRCWarning)
        try:
            spec = x.mapper.mapper(graph)
        except x.mapper.DRCError as exc:
            text = f"{exc} {exc.__cause__ or ''} {getattr(exc.__cause__, '__cause__', '') or ''}"
            limit = next((name for key, name in _ROCKPOOL_LIMITS if key in text), "unknown: " + text)
            return XyloOracle(refused=limit, first_id={}, message=text)
    neurons = x.graph.find_modules_of_subclass(spec["mapped_graph"], x.graph.GenericNeurons)
    first_id = {name: int(m.hw_ids[0]) for name, m in zip(order[1:], neurons, strict=True)}
    first_id[order[0]] = 0
    ints = {k: np.asarray(spec[k]).astype(int) for k in ("weights_in", "weights_out", "weights_rec")}
    try:
        x.sim.XyloSim.from_specification(**ints, dt=1e-3)
    except TypeError as exc:
        return XyloOracle(refused="weight range", first_id=first_id, message=str(exc))
    return XyloOracle(refused=None, first_id=first_id)


def xylo_chain(n_in: int, hidden: list[int], n_out: int, *, recurrent: tuple[int, ...] = (), w_max: int = 20,
               out_recurrent: bool = False, extreme: float | None = None, seed: int = 0) -> nv.Network:
    """Inputs -> hidden populations (``recurrent`` ones with a self-projection) -> outputs, integer weights."""
    rng = np.random.default_rng(seed)
    net = nv.Network(f"xylo_{n_in}_{'_'.join(map(str, hidden))}_{n_out}")
    net.add_population("in", n_in, nv.SpikeSourceArray(spike_times=[]))
    sizes = [("in", n_in)] + [(f"h{i}", n) for i, n in enumerate(hidden)] + [("out", n_out)]
    cell = nv.IF_curr_exp(tau_m=8.0, tau_syn_E=4.0, tau_syn_I=4.0, v_rest=0.0, v_reset=0.0, v_thresh=10.0)
    for name, n in sizes[1:]:
        net.add_population(name, n, cell)
    for k, ((pre, n_pre), (post, n_post)) in enumerate(itertools.pairwise(sizes)):
        w = rng.integers(-w_max, w_max + 1, size=(n_pre, n_post)).astype(float)
        if extreme is not None and k == 0:
            w[0, 0] = extreme
        net.connect(pre, post, nv.AllToAllConnector(), nv.StaticSynapse(weight=w))
    for i in recurrent:
        n = hidden[i]
        w = rng.integers(-w_max, w_max + 1, size=(n, n)).astype(float)
        net.connect(f"h{i}", f"h{i}", nv.AllToAllConnector(allow_self_connections=True), nv.StaticSynapse(weight=w),
                    name=f"h{i}_rec")
    if out_recurrent:
        w = rng.integers(-w_max, w_max + 1, size=(n_out, n_out)).astype(float)
        net.connect("out", "out", nv.AllToAllConnector(allow_self_connections=True), nv.StaticSynapse(weight=w),
                    name="out_rec")
    return net


@dataclass
class SpeckOracle:
    """What Sinabs says: per layer its memory, the assignment (``None`` if refused) and the cores each fits."""

    memory: dict[str, dict[str, int]]
    candidates: dict[str, list[int]]
    assignment: dict[str, int] | None


def _int_list(node: ast.AST) -> list[int]:
    """A literal list of integer products (``[16 * 1024, ...]`` or ``[1024] * 9``), read without executing it."""
    if isinstance(node, ast.List):
        return [_int(e) for e in node.elts]
    if isinstance(node, ast.BinOp) and isinstance(node.op, ast.Mult):
        return _int_list(node.left) * _int(node.right)
    raise ValueError(f"not a literal integer list: {ast.dump(node)}")


def _int(node: ast.AST) -> int:
    if isinstance(node, ast.Constant) and type(node.value) is int:
        return node.value
    if isinstance(node, ast.BinOp) and isinstance(node.op, ast.Mult):
        return _int(node.left) * _int(node.right)
    raise ValueError(f"not a literal integer: {ast.dump(node)}")


def sinabs_constraints() -> list[tuple[int, int, int]]:
    """(kernel, neuron, bias) memory per core, read from Sinabs's ``chips/dynapcnn.py get_constraints``."""
    spec = importlib.util.find_spec("sinabs")
    assert spec is not None and spec.origin is not None
    source = Path(spec.origin).parent / "backend" / "dynapcnn" / "chips" / "dynapcnn.py"
    tree = ast.parse(source.read_text())
    func = next(n for n in ast.walk(tree) if isinstance(n, ast.FunctionDef) and n.name == "get_constraints")
    values = {
        node.targets[0].id: _int_list(node.value)
        for node in ast.walk(func)
        if isinstance(node, ast.Assign) and isinstance(node.targets[0], ast.Name)
        and node.targets[0].id.endswith("_memory_size")
    }
    return list(zip(values["weight_memory_size"], values["neurons_memory_size"], values["bias_memory_size"],
                    strict=True))


def sinabs_speck(network: nv.Network) -> SpeckOracle:
    """Sinabs's DynapcnnLayer memory and get_valid_mapping for the layers of ``network``."""
    import torch

    from neurovpr.backends.speck.compat import import_dynapcnn

    d = import_dynapcnn()
    layers, _ = speck_layers(network)
    built = {}
    for i, layer in enumerate(layers):
        proj = network.projections[layer.projection]
        conn = proj.connector
        bias = layer.memory["bias_memory"] > 0
        f, c, kh, kw = layer.kernel
        if isinstance(conn, nv.ConvolutionConnector):
            conv = torch.nn.Conv2d(c, f, (kh, kw), stride=conn.stride, padding=conn.padding, bias=bias)
            in_shape = conn.input_shape
        else:
            conv = torch.nn.Linear(c * kh * kw, f, bias=bias)
            in_shape = (c, kh, kw)
        spk = d.layers.IAFSqueeze(batch_size=1)
        built[layer.population] = (i, d.layer.DynapcnnLayer(conv, spk, in_shape, pool=[[1, 1]], discretize=False))
    constraints = [d.mapping.LayerConstraints(*c) for c in sinabs_constraints()]
    memory = {name: {f"{k}_memory": int(v) for k, v in lyr.memory_summary().items()} for name, (_, lyr) in built.items()}
    candidates = {name: d.mapping.find_chip_layers(lyr, constraints) for name, (_, lyr) in built.items()}
    try:
        mapping = d.mapping.get_valid_mapping({i: lyr for i, lyr in built.values()}, constraints)
    except ValueError:
        return SpeckOracle(memory=memory, candidates=candidates, assignment=None)
    names = {i: name for name, (i, _) in built.items()}
    return SpeckOracle(memory=memory, candidates=candidates, assignment={names[i]: c for i, c in mapping.items()})
