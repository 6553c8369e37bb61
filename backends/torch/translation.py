"""Translation of the IR into the tables the batched step runs on (plain numpy, no torch).

The neurons of every non-source population share one index space (populations in
insertion order), so the state of a batch is a few ``(batch, N)`` arrays. Each
population's exact-integration propagators come from the backend kit
(:mod:`neurovpr.backendkit.propagators`). Every population that sends spikes (sources
included) gets one fan-out table: its outgoing connections of all projections, sorted by
presynaptic neuron (CSR), each with its target in the neuron index space, weight, delay
in whole steps and receptor (0 excitatory, 1 inhibitory). A spike is delivered by
looking its connections up in that table, so sparse and convolutional projections and
per-connection delays all take the same event-driven path.

The connections of a projection that share one delay and fill at least
:data:`DENSE_FILL` of their ``pre x post`` block (all-to-all, dense random) are held
instead as one dense weight matrix (:class:`DenseBlock`): a spike adds one row of it,
and spikes of a source population become drive by one sparse-times-dense product
(:mod:`.drive`).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from neurovpr.backendkit.propagators import propagators
from neurovpr.backendkit.timing import delay_steps
from neurovpr.ir.cells import IF_cond_exp, IF_cond_exp_adaptive, IF_curr_exp_ca2_adaptive, euler_integrated
from neurovpr.ir.connectivity import Connections
from neurovpr.ir.network import Network

__all__ = ["NeuronGroup", "FanOut", "DenseBlock", "Layout", "build_layout", "DENSE_FILL", "DENSE_MAX_BYTES"]

#: A (projection, delay) block of connections is held dense when it fills at least this fraction of pre x post.
DENSE_FILL = 0.25
#: ... and its float64 matrix takes no more than this.
DENSE_MAX_BYTES = 64 * 2**20


@dataclass(frozen=True)
class NeuronGroup:
    """One non-source population: its columns ``[lo, hi)`` of the state and its propagators."""

    name: str
    lo: int
    hi: int
    conductance: bool
    adaptive: bool
    calcium: bool
    params: Mapping[str, np.ndarray]
    euler: bool = False  #: forward-Euler membrane steps (``integration="euler"``)


@dataclass(frozen=True)
class FanOut:
    """The outgoing connections of one population, CSR by presynaptic neuron."""

    ptr: np.ndarray
    post: np.ndarray
    weight: np.ndarray
    delay: np.ndarray
    receptor: np.ndarray


@dataclass(frozen=True)
class DenseBlock:
    """The connections of one projection with one delay, as a dense ``(pre size, hi - lo)`` weight matrix.

    ``weight[i, k]`` is the summed weight from presynaptic neuron ``i`` to neuron ``lo + k``
    of the index space (0 where there is no connection); ``synapses[i]`` counts the
    connections of row ``i`` (for the synaptic-event statistics).
    """

    pre: str
    lo: int
    hi: int
    delay: int
    receptor: int
    weight: np.ndarray
    synapses: np.ndarray


@dataclass(frozen=True)
class Layout:
    """Everything the batched step needs: neuron groups, fan-out tables, dense blocks, the delay ring."""

    n: int
    groups: tuple[NeuronGroup, ...]
    fanout: Mapping[str, FanOut]
    dense: tuple[DenseBlock, ...]
    ring: int


def build_layout(
    network: Network, connections: Mapping[str, Connections], weights: Mapping[str, np.ndarray], dt: float
) -> Layout:
    """Lay ``network`` out with its expanded ``connections`` and current ``weights`` (canonical order)."""
    groups: list[NeuronGroup] = []
    lo = 0
    for name, pop in network.populations.items():
        if pop.is_source:
            continue
        cell = pop.cell_type
        groups.append(
            NeuronGroup(
                name=name,
                lo=lo,
                hi=lo + pop.size,
                conductance=isinstance(cell, (IF_cond_exp, IF_cond_exp_adaptive)),
                adaptive=isinstance(cell, IF_cond_exp_adaptive),
                calcium=isinstance(cell, IF_curr_exp_ca2_adaptive),
                params=propagators(cell, pop.size, dt, pop.v_init),
                euler=euler_integrated(cell),
            )
        )
        lo += pop.size
    offset = {g.name: g.lo for g in groups}
    parts: dict[str, list[tuple[np.ndarray, ...]]] = {name: [] for name in network.populations}
    max_delay = 1
    dense: list[DenseBlock] = []
    for name, proj in network.projections.items():
        conns = connections[name]
        steps = delay_steps(conns.delay, dt)
        if steps.size:
            max_delay = max(max_delay, int(steps.max()))
        kind = 1 if proj.receptor_type == "inhibitory" else 0
        weight = np.asarray(weights[name], np.float64)
        n_pre, n_post = network.populations[proj.pre].size, network.populations[proj.post].size
        sparse = np.ones(len(conns), dtype=bool)
        for d in np.unique(steps):
            sel = steps == d
            count = int(sel.sum())
            if n_pre * n_post > count / DENSE_FILL or n_pre * n_post * 8 > DENSE_MAX_BYTES:
                continue
            matrix = np.zeros((n_pre, n_post))
            np.add.at(matrix, (conns.pre[sel], conns.post[sel]), weight[sel])
            first = offset[proj.post]
            synapses = np.bincount(conns.pre[sel], minlength=n_pre).astype(np.int64)
            dense.append(
                DenseBlock(
                    pre=proj.pre, lo=first, hi=first + n_post, delay=int(d), receptor=kind, weight=matrix, synapses=synapses
                )
            )
            sparse &= ~sel
        receptor = np.full(int(sparse.sum()), kind, dtype=np.int64)
        parts[proj.pre].append(
            (conns.pre[sparse], conns.post[sparse] + offset[proj.post], weight[sparse], steps[sparse], receptor)
        )
    fanout = {}
    for name, pieces in parts.items():
        if not pieces:
            continue
        pre, post, weight, delay, receptor = (np.concatenate(col) for col in zip(*pieces, strict=True))
        if pre.size == 0:
            continue
        order = np.argsort(pre, kind="stable")
        size = network.populations[name].size
        ptr = np.concatenate([[0], np.cumsum(np.bincount(pre, minlength=size))]).astype(np.int64)
        fanout[name] = FanOut(
            ptr=ptr,
            post=post[order].astype(np.int64),
            weight=weight[order],
            delay=delay[order].astype(np.int64),
            receptor=receptor[order],
        )
    # a spike stamped j arrives at j + d; neuron spikes are stamped one step ahead of the step computing them
    return Layout(n=lo, groups=tuple(groups), fanout=fanout, dense=tuple(dense), ring=max_delay + 2)
