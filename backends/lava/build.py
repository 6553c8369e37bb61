"""Build functions: a neurovpr network as Lava processes.

A neuron population becomes a ``LIF`` (or ``LIFRefractory``) process whose spikes
leave through an ``Extractor``; a spike source an ``Injector`` into which the
simulation sends one spike vector per step (Lava's channels carry one message per
step, where setting a ``Var`` moves one element at a time). A projection becomes:

- a convolution with one delay and one weight scale: a
  :class:`~.connections.DelayConv` (Lava's ``Conv`` with the delay), from a spike
  source or a neuron population alike;
- otherwise one process per distinct delay: ``Dense``/``Sparse`` where the delay is
  the one step these give (a spike source's one-step delay: its spikes are replayed
  one step after their stamp), else ``DelayDense``/``DelaySparse`` (a neuron's
  ``K``-step delay is ``delays = K``: see :mod:`.translation`).

Lava compiles only the processes connected to the one it runs, so separate parts of
a network are tied to one silent hub neuron through zero-weight ``Dense`` processes.

Lava itself is reached through :func:`.compat.import_lava` (which applies the
Python 3.11 fix first).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import scipy.sparse

from neurovpr.backendkit.loihi2 import weight_integers
from neurovpr.backendkit.timing import delay_steps
from neurovpr.hardware.hwspec import load_hwspec
from neurovpr.ir.connectivity import Connections
from neurovpr.ir.connectors import ConvolutionConnector
from neurovpr.ir.network import Network, Projection

from . import resets
from .compat import import_lava
from .translation import LavaLIF, lava_lif, weight_scale

__all__ = ["LavaNetwork", "build_network", "receptors_by_population"]

#: Above this fraction of connected pairs a projection is a ``DelayDense``.
_DENSE_FRACTION = 0.25


@dataclass
class LavaNetwork:
    """The Lava processes standing for each IR element."""

    fixed: bool
    buffer_steps: int
    formats: Any = None
    params: dict[str, LavaLIF] = field(default_factory=dict)
    lifs: dict[str, Any] = field(default_factory=dict)
    extractors: dict[str, Any] = field(default_factory=dict)
    injectors: dict[str, Any] = field(default_factory=dict)
    synapses: dict[str, list[Any]] = field(default_factory=dict)
    kinds: dict[str, str] = field(default_factory=dict)
    resettable: list[Any] = field(default_factory=list)
    links: list[Any] = field(default_factory=list)

    @property
    def anchor(self) -> Any:
        """The process the runtime is created from (every process is connected to it)."""
        return next(iter(self.lifs.values()))

    def run_config(self) -> Any:
        """``Loihi2SimCfg`` selecting ``fixed_pt`` or ``floating_pt`` models.

        Lava's injector and extractor models carry no tag, so they are named explicitly,
        as are the models of the backend's resettable processes (:mod:`.resets`).
        """
        lava = import_lava()
        from lava.proc.io.extractor import PyLoihiExtractorModel
        from lava.proc.io.injector import PyLoihiInjectorModel

        models: dict[Any, Any] = {lava.Injector: PyLoihiInjectorModel, lava.Extractor: PyLoihiExtractorModel}
        # Lava looks an exception up by process instance before searching for models by class
        # (it finds none for the backend's own processes): each is named explicitly
        by_class = resets.model_map(self.fixed)
        for process in self.resettable:
            models[process] = by_class[type(process)]
        return lava.Loihi2SimCfg(select_tag="fixed_pt" if self.fixed else "floating_pt", exception_proc_model_map=models)


def receptors_by_population(network: Network) -> dict[str, frozenset[str]]:
    """The receptor types of each population's incoming projections."""
    found: dict[str, set[str]] = {name: set() for name in network.populations}
    for proj in network.projections.values():
        found[proj.post].add(proj.receptor_type)
    return {name: frozenset(kinds) for name, kinds in found.items()}


def _lif_process(params: LavaLIF, size: int, fixed: bool) -> Any:
    if fixed:
        kwargs: dict[str, Any] = {
            "shape": (size,),
            "u": np.zeros(size, dtype=np.int64),
            "v": params.integers.v_init,
            "du": params.integers.du,
            "dv": params.integers.dv,
            "vth": params.integers.vth_man,
            "bias_mant": params.integers.bias_man,
            "bias_exp": params.integers.bias_exp,
        }
    else:
        kwargs = {
            "shape": (size,),
            "u": np.zeros(size),
            "v": params.compartment.v_init.copy(),
            "du": params.du,
            "dv": params.dv,
            "vth": params.vth,
            "bias_mant": params.bias.copy(),
            "bias_exp": np.zeros(size),
        }
    if params.refractory_steps > 0:
        return resets.ResettableLIFRefractory(refractory_period=params.refractory_steps, **kwargs)
    return resets.ResettableLIF(**kwargs)


def _fixed_weights(
    lava: Any, values: np.ndarray, fmt: Any, *, like: np.ndarray | None = None
) -> tuple[np.ndarray, dict[str, Any]]:
    """One synapse process's integer weights and the Lava arguments of its format (exponent, bits, sign mode)."""
    quant = weight_integers(values, fmt, like=like)
    sign = getattr(lava.SignMode, quant.sign_mode.upper())
    return quant.mantissa, {"weight_exp": quant.exp, "num_weight_bits": fmt.weight_bits, "sign_mode": sign}


def _uniform_scale(scale: np.ndarray) -> bool:
    return bool(scale.size == 0 or np.all(scale == scale[0]))


def _conv_process(
    proj: Projection, conn: ConvolutionConnector, kernel: np.ndarray, used: np.ndarray, *, delay: int, fmt: Any
) -> Any:
    """A (resettable) :class:`~.connections.DelayConv` for a convolution whose kernel and connection values are scaled.

    ``used`` are the values the expanded connections carry (what the ``DelaySparse``
    path quantises): a fixed-point kernel (``fmt``, the ``loihi2`` hwspec's ``[formats]``, when
    fixed) gets their exponent and sign mode.
    """
    extra: dict[str, Any] = {}
    if fmt is not None:
        kernel, extra = _fixed_weights(import_lava(), kernel, fmt, like=used)
    (c, h, w), (sh, sw), (ph, pw) = conn.input_shape, conn.stride, conn.padding
    # Lava convolves (flipped kernel) in (x, y, channel) order; neurovpr correlates in (channel, y, x)
    weight = np.ascontiguousarray(kernel[:, :, ::-1, ::-1].transpose(0, 3, 2, 1))
    return resets.ResettableDelayConv(
        weight=weight, input_shape=(w, h, c), padding=(pw, ph), stride=(sw, sh), delays=delay, name=proj.name, **extra
    )


def _matrix_process(
    lava: Any,
    pre: np.ndarray,
    post: np.ndarray,
    values: np.ndarray,
    shape: tuple[int, int],
    *,
    delay: int,
    fmt: Any,
    v_post: float,
    name: str,
) -> Any:
    """``Dense``/``Sparse`` for ``delay == 0`` (one step, their own timing), else ``DelayDense``/``DelaySparse``.

    Each is the resettable version of :mod:`.resets`; ``fmt`` (the ``loihi2`` hwspec's
    ``[formats]``) makes its weights fixed point, ``None`` keeps them float.
    """
    fixed = fmt is not None
    matrix = scipy.sparse.coo_matrix((values, (post, pre)), shape=shape).tocsr()
    matrix.sum_duplicates()
    kwargs: dict[str, Any] = {"name": name}
    if fixed:
        mantissa, extra = _fixed_weights(lava, matrix.data * v_post, fmt)
        matrix.data = mantissa.astype(np.float64)
        kwargs.update(extra)
    if matrix.nnz > _DENSE_FRACTION * shape[0] * shape[1]:
        dense = matrix.toarray().astype(np.int64) if fixed else matrix.toarray()
        if delay == 0:
            return resets.ResettableDense(weights=dense, **kwargs)
        return resets.ResettableDelayDense(weights=dense, delays=delay, **kwargs)
    if fixed:
        matrix = matrix.astype(np.int64)
    if delay == 0:
        return resets.ResettableSparse(weights=matrix, **kwargs)
    # delays on the weights' pattern (an integer would make Lava fill a matrix of every pair)
    delays = matrix.copy().astype(int)
    delays.data[:] = delay
    return resets.ResettableDelaySparse(weights=matrix, delays=delays, **kwargs)


def _build_projection(
    lava: Any, built: LavaNetwork, network: Network, proj: Projection, conns: Connections, weights: np.ndarray, dt: float
) -> None:
    params = built.params[proj.post]
    scale = weight_scale(params, proj.receptor_type, dt)
    from_source = network.populations[proj.pre].is_source
    pre_port = built.injectors[proj.pre].out_port if from_source else built.lifs[proj.pre].s_out
    post_lif = built.lifs[proj.post]
    n_pre, n_post = network.populations[proj.pre].size, network.populations[proj.post].size
    steps = delay_steps(conns.delay, dt)
    # a spike source's spikes are replayed one step after their stamp: one step less in the synapse
    extra = (steps - 1) if from_source else steps
    made: list[Any] = []
    conn = proj.connector
    v_post = params.integers.vth_man if built.fixed else 1.0
    if isinstance(conn, ConvolutionConnector) and steps.size and np.all(steps == steps[0]) and _uniform_scale(scale):
        kernel = np.asarray(proj.synapse.weight, dtype=np.float64) * scale[0] * v_post
        used = weights * scale[conns.post] * v_post
        process = _conv_process(proj, conn, kernel, used, delay=int(extra[0]), fmt=built.formats)
        pre_port.reshape(conn.input_shape).transpose([2, 1, 0]).connect(process.s_in)
        process.a_out.transpose([2, 1, 0]).reshape((n_post,)).connect(post_lif.a_in)
        built.synapses[proj.name] = [process]
        built.resettable.append(process)
        built.kinds[proj.name] = process.kind
        return
    for k in np.unique(extra):
        sel = extra == k
        values = weights[sel] * scale[conns.post[sel]]
        process = _matrix_process(
            lava,
            conns.pre[sel],
            conns.post[sel],
            values,
            (n_post, n_pre),
            delay=int(k),
            fmt=built.formats,
            v_post=params.integers.vth_man,
            name=proj.name,
        )
        pre_port.connect(process.s_in)
        process.a_out.connect(post_lif.a_in)
        built.resettable.append(process)
        made.append(process)
    built.synapses[proj.name] = made
    built.kinds[proj.name] = made[0].kind if made else "none"


def _components(network: Network) -> list[list[str]]:
    """Groups of neuron populations joined by projections (spike sources join their targets)."""
    parent = {name: name for name in network.populations}

    def find(x: str) -> str:
        while parent[x] != x:
            parent[x] = parent[parent[x]]
            x = parent[x]
        return x

    for proj in network.projections.values():
        parent[find(proj.pre)] = find(proj.post)
    groups: dict[str, list[str]] = {}
    for name, pop in network.populations.items():
        if not pop.is_source:
            groups.setdefault(find(name), []).append(name)
    return list(groups.values())


def build_network(
    network: Network,
    connections: Mapping[str, Connections],
    weights: Mapping[str, np.ndarray],
    *,
    dt: float,
    fixed: bool,
    buffer_steps: int,
) -> LavaNetwork:
    """Build the Lava processes of ``network`` (which has at least one neuron population).

    Parameters
    ----------
    network
        The (checked) network.
    connections, weights
        Each projection's expanded connections and current weights (canonical order).
    dt
        Time step (ms).
    fixed
        Use Loihi 2's fixed-point formats (``fixed_pt`` models).
    buffer_steps
        Capacity (in steps) of the injector and extractor channels: the most steps
        one Lava run call may take.
    """
    lava = import_lava()
    fmt = load_hwspec("loihi2").formats
    built = LavaNetwork(fixed=fixed, buffer_steps=buffer_steps, formats=fmt if fixed else None)
    receptors = receptors_by_population(network)
    for name, pop in network.populations.items():
        if pop.is_source:
            if any(p.pre == name for p in network.projections.values()):
                built.injectors[name] = lava.Injector(shape=(pop.size,), buffer_size=buffer_steps)
            continue
        params = lava_lif(pop, dt, fmt, receptors[name])
        built.params[name] = params
        lif = _lif_process(params, pop.size, fixed)
        built.resettable.append(lif)
        extractor = lava.Extractor(shape=(pop.size,), buffer_size=buffer_steps)
        lif.s_out.connect(extractor.in_port)
        built.lifs[name], built.extractors[name] = lif, extractor
    for proj in network.projections.values():
        _build_projection(lava, built, network, proj, connections[proj.name], weights[proj.name], dt)
    groups = _components(network)
    if len(groups) > 1:
        hub = lava.LIF(shape=(1,), vth=2**16, du=0, dv=0, name="neurovpr:hub")
        for group in groups:
            first = built.lifs[group[0]]
            link = lava.Dense(weights=np.zeros((1, first.s_out.shape[0]), dtype=np.int64 if fixed else np.float64))
            first.s_out.connect(link.s_in)
            link.a_out.connect(hub.a_in)
            built.links.append(link)
        built.links.append(hub)
    return built
