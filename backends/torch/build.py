"""The batched step: the state of ``B`` independent items and one step of docs/semantics.md on all of them.

Order within step ``j`` (the reference backend's, backends/reference/kernels.py):

1. sources emit their spikes stamped ``j`` into the delay ring;
2. the ring's slot ``j`` (with what sources deliver as drive, :mod:`.drive`, added to it) is
   added to the synaptic currents/conductances and cleared;
3. each group of consecutive populations of one membrane form: one step of
   :mod:`.neurons` (exact propagation, decays, threshold, reset, refractoriness and lockout,
   the Ca2+ jump), or with the option ``fuse`` 2 and 3 as one compiled kernel per group
   (:mod:`.fused`); each population's spikes are stamped ``j + 1`` and scheduled into the ring.

A spike is scheduled by looking up its population's fan-out table
(:class:`.translation.FanOut`; look-ups by ``index_select``, which copies faster than indexing
with a tensor) and adding every connection's weight at
``(receptor, (stamp + delay) % ring, item, target)`` with one ``scatter_add_`` (on a CPU the
sums and order of ``index_add_``, faster): the work is
proportional to the spikes, as in an event-driven simulator, and the same code serves
every connector. A projection's dense blocks (:class:`.translation.DenseBlock`) are
delivered by adding the spiking neurons' rows of the weight matrix into the ring slot
(one ``index_put_``); source populations' dense blocks are delivered ahead of the step
loop as drive (:mod:`.drive`). A population with no spike in the batch at a step delivers
nothing. Adaptive thresholds are held at their learned values (inference).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import torch

from neurovpr.resources import require_memory

from .fused import Kernels, kernels, pack
from .neurons import FLUSH, Scratch, conductance_step, current_step, flush_below, reset_spiking
from .translation import DenseBlock, Layout, NeuronGroup

__all__ = ["Compiled", "BatchState", "Dense", "FLUSH", "spiking"]


@dataclass
class _Group:
    """Consecutive populations of one membrane form (current or conductance), advanced by one set of tensor operations.

    ``members`` are the populations' names and ``[lo, hi)`` columns; the parameters are
    per neuron, so a population's arithmetic is the same alone or merged with others.
    """

    lo: int
    hi: int
    members: tuple[tuple[str, int, int], ...]
    conductance: bool
    calcium: bool
    finite: bool  #: every neuron has a leak (gl > 0), or the group is current-based
    euler: bool  #: forward-Euler membrane steps (``integration="euler"``; never merged with exact ones)
    p: dict[str, torch.Tensor]
    refrac_total: torch.Tensor
    packed: torch.Tensor | None = None  #: the parameters as the fused step reads them (option fuse)


@dataclass
class _Fan:
    ptr: torch.Tensor
    deg: torch.Tensor
    post: torch.Tensor
    weight: torch.Tensor
    delay: torch.Tensor
    receptor: torch.Tensor


@dataclass
class Dense:
    """A :class:`.translation.DenseBlock` on the device."""

    lo: int
    hi: int
    delay: int
    receptor: int
    weight: torch.Tensor
    synapses: np.ndarray

    @classmethod
    def of(cls, block: DenseBlock, device: torch.device, dtype: torch.dtype) -> Dense:
        """The block's matrix as a tensor."""
        weight = torch.as_tensor(np.ascontiguousarray(block.weight), dtype=dtype, device=device)
        return cls(lo=block.lo, hi=block.hi, delay=block.delay, receptor=block.receptor, weight=weight, synapses=block.synapses)


class Compiled:
    """A :class:`.translation.Layout` as tensors on one device.

    Parameters
    ----------
    layout
        The tables.
    theta
        ``(N,)`` adaptive thresholds (0 for neurons without one).
    device, dtype
        Where and in which precision the state is computed.
    dt
        The time step (ms).
    fuse
        Advance each group with one compiled kernel (:mod:`.fused`) instead of :mod:`.neurons`.
    """

    def __init__(
        self, layout: Layout, theta: np.ndarray, *, device: torch.device, dtype: torch.dtype, dt: float, fuse: bool = False
    ) -> None:
        self.n = layout.n
        self.ring = layout.ring
        self.device = device
        self.dtype = dtype

        def t(a: np.ndarray, kind: torch.dtype | None = None) -> torch.Tensor:
            return torch.as_tensor(np.ascontiguousarray(a), dtype=kind or dtype, device=device)

        runs: list[list[NeuronGroup]] = []
        for g in layout.groups:
            last = runs[-1][-1] if runs else None
            if last is not None and (last.conductance, last.euler) == (g.conductance, g.euler) and last.hi == g.lo:
                runs[-1].append(g)
            else:
                runs.append([g])
        self.groups = [self._group(run, t) for run in runs]
        self.fan = {
            name: _Fan(
                ptr=t(f.ptr[:-1], torch.int64),
                deg=t(np.diff(f.ptr), torch.int64),
                post=t(f.post, torch.int64),
                weight=t(f.weight),
                delay=t(f.delay, torch.int64),
                receptor=t(f.receptor, torch.int64),
            )
            for name, f in layout.fanout.items()
        }
        self.dense: dict[str, list[Dense]] = {}
        for block in layout.dense:
            self.dense.setdefault(block.pre, []).append(Dense.of(block, device, dtype))
        self.theta = t(theta)
        for g in self.groups:  # inference: the adaptive thresholds are fixed, so each threshold is summed once
            if g.conductance:
                g.p["v_thresh_theta"] = g.p["v_thresh"] + self.theta[g.lo : g.hi]
            if fuse:  # the fused step's counters are values of the state's dtype (whole numbers, exact)
                g.p["lock_steps_f"] = g.p["lock_steps"].to(dtype)
                g.p["refrac_total_f"] = g.refrac_total.to(dtype)
                g.packed = pack(g.p, g.conductance)
        self.below = flush_below(dtype)
        #: the compiled steps (option fuse), or None: the eager steps of .neurons
        self.kernels: Kernels | None = kernels(dt, self.below) if fuse else None
        #: choose between membranes with torch.lerp (faster in float32 on a CPU; see .neurons)
        self.lerp = dtype == torch.float32
        cat = lambda key: np.concatenate([g.params[key] for g in layout.groups]) if layout.groups else np.zeros(0)  # noqa: E731
        self.v_init = t(cat("v_init"))
        self.ica_init = t(cat("i_ca_init"))

    @staticmethod
    def _group(run: list[NeuronGroup], t) -> _Group:
        keys = set.intersection(*(set(g.params) for g in run))
        params = {key: np.concatenate([g.params[key] for g in run]) for key in keys}
        p = {name: t(values) for name, values in params.items()}
        p["i_offset_p20"] = t(params["i_offset"] * params["p20"])
        p["i_offset_x_p20"] = p["i_offset"] * p["p20"]  # in the state's dtype, as the current step once computed it
        conductance = run[0].conductance
        if conductance:
            p["gl_rest"] = t(params["gl"] * params["v_rest"])
        total = t(params["refrac"] + params["lock"], torch.int32)
        p["lock_steps"] = t(params["lock"], torch.int32)
        return _Group(
            lo=run[0].lo, hi=run[-1].hi, members=tuple((g.name, g.lo, g.hi) for g in run), conductance=conductance,
            calcium=any(g.calcium for g in run), finite=bool(np.all(params["gl"] > 0)) if conductance else True, p=p,
            refrac_total=total, euler=run[0].euler,
        )  # fmt: skip


class BatchState:
    """The dynamic state of ``batch`` items of a :class:`Compiled` network, from the reset state.

    Parameters
    ----------
    net
        The compiled network.
    batch
        Number of independent items.
    dt
        Time step (ms).
    """

    def __init__(self, net: Compiled, batch: int, dt: float, *, lead: int = 1, extra_bytes: int = 0) -> None:
        self.net = net
        self.batch = batch
        self.dt = dt
        # source spikes may be scheduled up to `lead` steps ahead of the step being computed
        self.ring = net.ring + lead - 1
        n, dev, dtype = net.n, net.device, net.dtype
        width = 8 if dtype == torch.float64 else 4
        # delay ring, v, isyn, ica, refr, counts, the groups' scratch; extra_bytes: the caller's (the source drive)
        need = batch * n * (2 * self.ring * width + 4 * width + 4 + 8 + Scratch.bytes_per(width)) + extra_bytes
        need += 8 * sum(fan.post.numel() for fan in net.fan.values())  # the fixed part of each connection's ring index
        what = f"torch backend: a batch of {batch} items of {n} neurons with a {self.ring}-step delay ring"
        if dev.type == "cuda":  # the state lives in the device's memory
            free, _ = torch.cuda.mem_get_info(dev)
            require_memory(need, what, f" on {dev} (lower the compile option batch_size)", limit=(free, f"free on {dev}"))
        else:
            require_memory(need, what, " (lower the compile option batch_size)")
        self.v = net.v_init.expand(batch, n).clone()
        self.isyn = torch.zeros((2, batch, n), dtype=dtype, device=dev)
        self.ica = net.ica_init.expand(batch, n).clone()
        # the fused step (.fused) counts in the state's dtype, the eager one in integers
        self.refr = torch.zeros((batch, n), dtype=dtype if net.kernels else torch.int32, device=dev)
        self.buf = torch.zeros(2 * self.ring * batch * n, dtype=dtype, device=dev)
        self.counts = torch.zeros((batch, n), dtype=dtype if net.kernels else torch.int64, device=dev)
        self.scratch = [Scratch.of(batch, g.hi - g.lo, dtype, dev) for g in net.groups]
        self._ones = torch.ones(0, dtype=torch.int64, device=dev)
        self._targets: dict[str, torch.Tensor] = {}
        self._range = torch.arange(0, device=dev)
        self.synaptic_events = 0

    def variable(self, name: str) -> torch.Tensor:
        """The ``(batch, N)`` state of a recordable variable (``theta`` is the learned, fixed threshold)."""
        if name == "v":
            return self.v
        if name in ("isyn_exc", "gsyn_exc"):
            return self.isyn[0]
        if name in ("isyn_inh", "gsyn_inh"):
            return self.isyn[1]
        if name == "i_ca2":
            return self.ica
        return self.net.theta.expand(self.batch, self.net.n)

    def emit(
        self, population: str, item: torch.Tensor, neuron: torch.Tensor, stamp: int | torch.Tensor, *, dense: bool = True
    ) -> None:
        """Schedule spikes of ``population`` (one per ``(item, neuron)`` pair, repeats allowed) stamped ``stamp``.

        ``stamp`` is one step for all, or one per spike (no more than the state's ``lead`` steps ahead).
        ``dense=False`` leaves out the population's dense blocks (delivered as :mod:`.drive`).
        """
        if item.numel() == 0:
            return
        for block in self.net.dense.get(population, ()) if dense else ():
            self.emit_dense(block, item, neuron, stamp)
        fan = self.net.fan.get(population)
        if fan is None:
            return
        deg = torch.index_select(fan.deg, 0, neuron)
        total = int(deg.sum())
        if total == 0:
            return
        self.synaptic_events += total
        first = torch.cumsum(deg, 0) - deg
        conn = torch.repeat_interleave(torch.index_select(fan.ptr, 0, neuron) - first, deg, output_size=total)
        conn += self._iota(total)
        rows = torch.repeat_interleave(item, deg, output_size=total)
        if isinstance(stamp, torch.Tensor):
            stamp = torch.repeat_interleave(stamp, deg, output_size=total)
        # ((receptor * ring + slot) * batch + row) * N + post, the receptor and post part looked up per connection
        slot = torch.remainder(torch.index_select(fan.delay, 0, conn) + stamp, self.ring)
        flat = slot.mul_(self.batch * self.net.n).add_(rows.mul_(self.net.n))
        flat += torch.index_select(self._target(population, fan), 0, conn)
        self.buf.scatter_add_(0, flat, torch.index_select(fan.weight, 0, conn))  # index_add_'s sums and order, faster

    def _target(self, population: str, fan: _Fan) -> torch.Tensor:
        """Per connection of ``population``'s fan-out, the fixed part of its ring index.

        That is ``receptor x ring x batch x N + post`` (kept for the batch).
        """
        if population not in self._targets:
            self._targets[population] = fan.receptor * (self.ring * self.batch * self.net.n) + fan.post
        return self._targets[population]

    def _ones_of(self, total: int) -> torch.Tensor:
        """``total`` ones (int64; a view of one block kept for the batch)."""
        self._ones = _at_least(self._ones, total, lambda n: torch.ones(n, dtype=torch.int64, device=self._ones.device))
        return self._ones[:total]

    def _iota(self, total: int) -> torch.Tensor:
        """``0 .. total - 1`` (a view of one range kept for the batch)."""
        self._range = _at_least(self._range, total, lambda n: torch.arange(n, device=self._range.device))
        return self._range[:total]

    def emit_dense(
        self, block: Dense, item: torch.Tensor, neuron: torch.Tensor, stamp: int | torch.Tensor, *, count: bool = True
    ) -> None:
        """Schedule spikes through a dense block: each adds its row of the weight matrix (see :meth:`emit`).

        ``count=False``: the spikes are already counted in the synaptic-event statistics.
        """
        if count:
            self.synaptic_events += int(block.synapses[neuron.cpu().numpy()].sum())
        ring = self.buf.view(2, self.ring, self.batch, self.net.n)[block.receptor, :, :, block.lo : block.hi]
        rows = torch.index_select(block.weight, 0, neuron)
        if isinstance(stamp, torch.Tensor):
            ring.index_put_((torch.remainder(stamp + block.delay, self.ring), item), rows, accumulate=True)
        else:
            ring[(stamp + block.delay) % self.ring].index_put_((item,), rows, accumulate=True)

    def slot(self, j: int) -> torch.Tensor:
        """The ``(2, batch, N)`` arrivals at step ``j`` (the delay ring's slot; receptor first)."""
        return self.buf.view(2, self.ring, self.batch, self.net.n)[:, j % self.ring]

    def update(self, j: int) -> list[tuple[str, torch.Tensor]]:
        """Add the arrivals of step ``j`` (:meth:`slot`, then cleared) and advance every population over the step.

        Returns each population's ``(batch, size)`` spikes (scheduled, counted): views of the
        groups' scratch (or of the fused step's output), valid until the next step.
        """
        fused = self.net.kernels
        slot = self.slot(j)
        if fused is None:  # the fused step adds and clears the slot itself
            self.isyn += slot
            slot.zero_()
        out = []
        for g, scratch in zip(self.net.groups, self.scratch, strict=True):
            if fused is not None:
                spikes = self._fused(g, fused, slot)
            else:
                spikes = self._conductance(g, scratch) if g.conductance else self._current(g, scratch)
            ica = self.ica if g.calcium else None
            for name, lo, hi in g.members:
                own = spikes[:, lo - g.lo : hi - g.lo]
                item, neuron = spiking(own)
                if item.numel():
                    if fused is None:  # the eager step leaves the reset and the spike count to its caller
                        flat = item * self.net.n + lo + neuron
                        reset_spiking(self.v, self.refr, ica, flat, neuron + (lo - g.lo), g.p, g.refrac_total)
                        self.counts.view(-1).index_add_(0, flat, self._ones_of(flat.numel()))
                    self.emit(name, item, neuron, j + 1)
                out.append((name, own))
        return out

    def _fused(self, g: _Group, k: Kernels, slot: torch.Tensor) -> torch.Tensor:
        """One compiled step of group ``g`` (:mod:`.fused`: arrivals, step, reset and spike count); its spikes."""
        sl = slice(g.lo, g.hi)
        v, refr, counts = self.v[:, sl], self.refr[:, sl], self.counts[:, sl]
        ie, ii = self.isyn[0, :, sl], self.isyn[1, :, sl]
        arrive_e, arrive_i = slot[0, :, sl], slot[1, :, sl]
        if g.conductance:
            return k.conductance(v, ie, ii, arrive_e, arrive_i, refr, counts, g.packed, g.euler)
        return k.current(v, ie, ii, arrive_e, arrive_i, self.ica[:, sl], refr, counts, g.packed, g.calcium)

    def _current(self, g: _Group, scratch: Scratch) -> torch.Tensor:
        sl = slice(g.lo, g.hi)
        v, ie, ii, ica, refr = self.v[:, sl], self.isyn[0, :, sl], self.isyn[1, :, sl], self.ica[:, sl], self.refr[:, sl]
        return current_step(v, ie, ii, ica, refr, g.p, g.calcium, self.net.below, scratch, self.net.lerp)

    def _conductance(self, g: _Group, scratch: Scratch) -> torch.Tensor:
        sl = slice(g.lo, g.hi)
        v, ie, ii, refr = self.v[:, sl], self.isyn[0, :, sl], self.isyn[1, :, sl], self.refr[:, sl]
        return conductance_step(v, ie, ii, refr, g.p, self.dt, self.net.below, scratch, self.net.lerp and g.finite, euler=g.euler)


def spiking(spikes: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """The ``(item, neuron)`` pairs where ``spikes`` (``(batch, n)``, boolean or 0/1) is set, in ``torch.nonzero``'s order.

    Found in two levels, the items with a spike (a sum per item), then the neurons in those
    items' rows only: spikes are rare in a step, and ``torch.nonzero`` over the whole block
    costs several times a sum on a CPU (Modular SNN module, batch of 100: about 100 us
    against 30 us).
    """
    items = torch.nonzero(spikes.sum(1)).view(-1)
    rows, neurons = torch.nonzero(torch.index_select(spikes, 0, items), as_tuple=True)
    return torch.index_select(items, 0, rows), neurons


def _at_least(block: torch.Tensor, total: int, make: Callable[[int], torch.Tensor]) -> torch.Tensor:
    """``block``, or a new one from ``make(size)`` when it holds fewer than ``total`` values (at least doubling)."""
    return block if block.numel() >= total else make(max(total, 2 * block.numel()))
