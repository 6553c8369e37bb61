"""Source drive: what source populations deliver to their targets, computed ahead of the step loop.

The spikes of source populations (spike arrays, and Poisson trains drawn by the backend
kit) are known before a run starts, so their arrivals are computed a chunk of source steps
at a time, with a few large operations, into a window of the coming steps (``chunk`` plus
the longest source delay): per item, rows are arrival steps, columns the target columns of
each receptor. The step loop adds one step's rows to that step's arrivals (the delay ring's slot).

- A dense block (:class:`.build.Dense`: one delay, a dense weight matrix) adds ``S @ W``,
  with ``S`` the sparse ``(arrival step x item, presynaptic neuron)`` matrix of spike counts.
- A source's fan-out table whose rows pad to a rectangle without doubling it (all-to-all
  with per-synapse delays, convolutions) is padded once to ``(pre, degree)`` tables of
  weight and of column offset (``delay x row length + column``); a chunk's spikes are then
  delivered by one gather of their rows and one ``scatter_add_``.
- Other fan-out tables stay on the delay ring (:meth:`.build.BatchState.emit`).

The window aims to stay within :data:`WINDOW_BYTES`, but its chunk is never shorter than the
longest source delay (the window is then twice that delay), and it is counted in the batch's
memory check. What is still in the window when
the run ends (arrivals after its last step) is added to the delay ring, so state that
carries over to the next ``run`` receives it.
"""

from __future__ import annotations

import warnings

import numpy as np
import torch

from .build import BatchState, Compiled, Dense

__all__ = ["SourceDrive", "WINDOW_BYTES"]

#: The memory the window of coming steps aims to stay within (it takes at least twice the longest source delay).
WINDOW_BYTES = 64 * 2**20
#: The most (spike, connection) pairs delivered by one ``scatter_add_`` (bounds its temporaries).
_PAIRS = 2**21


class _Padded:
    """A source's fan-out table padded to ``(pre, degree)``: weights (0 in the padding) and column offsets."""

    def __init__(self, net: Compiled, name: str, columns: dict[int, tuple[int, int]]) -> None:
        fan = net.fan[name]
        degree = int(fan.deg.max()) if fan.deg.numel() else 0
        slot = torch.arange(degree, device=net.device)
        conn = fan.ptr[:, None] + slot[None, :]
        valid = slot[None, :] < fan.deg[:, None]
        conn = torch.where(valid, conn, 0)
        col = torch.zeros_like(conn)
        for receptor, (lo, start) in columns.items():
            col = torch.where(fan.receptor[conn] == receptor, fan.post[conn] - lo + start, col)
        self.weight = torch.where(valid, fan.weight[conn], 0.0)
        self.col = torch.where(valid, col, 0)
        self.delay = torch.where(valid, fan.delay[conn], 0)
        self.degree = degree
        self.deg = fan.deg.cpu().numpy()
        self.offset: torch.Tensor | None = None

    def offsets(self, row: int, kind: torch.dtype) -> torch.Tensor:
        """``(pre, degree)`` offsets of the targets in the window from the spike's own row: ``delay x row + column``."""
        if self.offset is None:
            self.offset = (self.delay * row + self.col).to(kind)
        return self.offset


def _paddable(net: Compiled, name: str) -> bool:
    fan = net.fan.get(name)
    if fan is None or fan.deg.numel() == 0:
        return False
    return fan.deg.numel() * int(fan.deg.max()) <= 2 * int(fan.deg.sum())


class SourceDrive:
    """The drive of the source populations over steps ``first .. first + n_steps - 1`` of a batch.

    Parameters
    ----------
    net
        The compiled network.
    events
        Per source population, its spikes ``(steps, items, neurons)`` sorted by step.
    batch
        Items in the batch.
    first, n_steps
        The steps of the run.
    """

    def __init__(
        self,
        net: Compiled,
        events: dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]],
        batch: int,
        first: int,
        n_steps: int,
    ) -> None:
        self.net, self.batch, self.first, self.n_steps = net, batch, first, n_steps
        self.events = events
        self.blocks = [(name, block) for name in events for block in net.dense.get(name, ())]
        #: sources whose every connection is delivered here (none of theirs goes through the ring)
        self.whole = {name for name in events if _paddable(net, name)}
        lo_hi: dict[int, tuple[int, int]] = {}
        reach = 1
        for _, block in self.blocks:
            lo_hi[block.receptor] = _union(lo_hi.get(block.receptor), block.lo, block.hi)
            reach = max(reach, block.delay)
        for name in self.whole:
            fan = net.fan[name]
            reach = max(reach, int(fan.delay.max()))
            for r in torch.unique(fan.receptor).tolist():
                post = fan.post[fan.receptor == r]
                lo_hi[r] = _union(lo_hi.get(r), int(post.min()), int(post.max()) + 1)
        #: per receptor: its first target neuron, its last + 1, and its first column in the window
        self.spans: dict[int, tuple[int, int, int]] = {}
        width = 0
        for r in sorted(lo_hi):
            lo, hi = lo_hi[r]
            self.spans[r] = (lo, hi, width)
            width += hi - lo
        self.width = width
        self.padded = {name: _Padded(net, name, {r: (lo, c) for r, (lo, _, c) in self.spans.items()}) for name in self.whole}
        itemsize = torch.empty(0, dtype=net.dtype).element_size()
        row = batch * width * itemsize
        self.reach = reach
        # at least `reach` steps: each move of the window copies its last `reach` rows to the front, which a
        # shorter chunk would repeat every few steps (a batch of 256 float64 items: every step, about 15x slower)
        self.chunk = max(1, min(n_steps, max(WINDOW_BYTES // max(row, 1) - reach, reach)))
        widest = max((block.hi - block.lo for _, block in self.blocks), default=0)
        product = (self.chunk + reach) * batch * widest * itemsize
        pairs = _PAIRS * (8 + itemsize) if self.whole else 0
        #: bytes the drive allocates at most (window and the copy of its tail, one block's product, one delivery's temporaries)
        self.bytes = (self.chunk + 2 * reach) * row + product + pairs if width else 0
        self.synaptic_events = sum(int(block.synapses[events[name][2]].sum()) for name, block in self.blocks)
        self.synaptic_events += sum(int(self.padded[name].deg[events[name][2]].sum()) for name in self.whole)
        self._window: torch.Tensor | None = None
        self._pairs: tuple[torch.Tensor, torch.Tensor] | None = None
        self._start = first

    def add(self, arrivals: torch.Tensor, j: int) -> None:
        """Add the drive arriving at step ``j`` to ``arrivals`` (``(2, batch, N)``: the ring's slot ``j``); steps in order."""
        if not self.width:
            return
        if self._window is None or j >= self._start + self.chunk:
            self._advance(j)
        row = self._window[:, j - self._start]
        for r, (lo, hi, col) in self.spans.items():
            arrivals[r, :, lo:hi] += row[:, col : col + hi - lo]

    def finish(self, state: BatchState) -> None:
        """Add the arrivals after the run's last step (still in the window) to ``state``'s delay ring."""
        if self._window is None:
            return
        end = self.first + self.n_steps
        ring = state.buf.view(2, state.ring, self.batch, self.net.n)
        for k in range(end - self._start, self._window.shape[1]):
            for r, (lo, hi, col) in self.spans.items():
                ring[r, (self._start + k) % state.ring, :, lo:hi] += self._window[:, k, col : col + hi - lo]

    def _advance(self, start: int) -> None:
        """Move the window to start at step ``start`` and deliver the source spikes of ``start .. start + chunk - 1``.

        The window is ``(item, step, column)``: the arrivals of one item's spikes stay within
        its own rows, and a chunk's spikes are delivered item after item (cache locality).
        """
        size, b = self.chunk + self.reach, self.batch
        if self._window is None:
            self._window = torch.zeros((b, size, self.width), dtype=self.net.dtype, device=self.net.device)
        else:  # arrivals of earlier chunks' spikes that are still to come move to the front
            keep = size - (start - self._start)
            tail = self._window[:, size - keep :]
            # the tail and the front do not overlap when the chunk is at least the reach: one copy, no temporary
            self._window[:, :keep].copy_(tail if 2 * keep <= size else tail.clone())
            self._window[:, keep:].zero_()
        self._start = start
        window = self._window
        for name, (steps, item, neurons) in self.events.items():
            a, z = np.searchsorted(steps, [start, start + self.chunk], side="left")
            if z <= a:
                continue
            order = np.argsort(item[a:z], kind="stable")
            base = item[a:z][order] * size + steps[a:z][order] - start  # the spike's row if it arrived at its own step
            who = neurons[a:z][order]
            for block in self.net.dense.get(name, ()):
                span = self.spans[block.receptor]
                product = _product(base + block.delay, who, b * size, block)
                col = span[2] + block.lo - span[0]
                window[:, :, col : col + block.hi - block.lo] += product.view(b, size, -1)
            if name in self.whole:
                self._scatter(window.view(-1), self.padded[name], base, who)

    def _scatter(self, flat: torch.Tensor, pad: _Padded, base: np.ndarray, neurons: np.ndarray) -> None:
        """Add every connection of the given spikes into the window (at most :data:`_PAIRS` at a time).

        The spikes' rows of the padded tables are gathered with ``index_select`` (a copy of whole
        rows, about 2.5 times faster here than indexing with a tensor) into buffers kept for the run,
        and added with ``scatter_add_``: on a CPU the same sums in the same order as
        ``index_add_`` (bit for bit), about 2.5 times faster per connection here.
        """
        dev = self.net.device
        offset = pad.offsets(self.width, torch.int64)  # scatter_add_ takes int64 indices
        step = max(1, _PAIRS // max(pad.degree, 1))
        if self._pairs is None or self._pairs[0].numel() < step * pad.degree:
            # the rows gathered for one scatter_add_, allocated once (not mapped and faulted in at every call)
            size = step * pad.degree
            self._pairs = (torch.empty(size, dtype=torch.int64, device=dev), torch.empty(size, dtype=flat.dtype, device=dev))
        for k in range(0, base.size, step):
            at = torch.as_tensor(base[k : k + step] * self.width, device=dev, dtype=torch.int64)
            who = torch.as_tensor(neurons[k : k + step], device=dev)
            rows = (who.numel(), pad.degree)
            index = torch.index_select(offset, 0, who, out=self._pairs[0][: who.numel() * pad.degree].view(rows))
            index += at[:, None]
            weight = torch.index_select(pad.weight, 0, who, out=self._pairs[1][: who.numel() * pad.degree].view(rows))
            flat.scatter_add_(0, index.view(-1), weight.view(-1))


def _union(span: tuple[int, int] | None, lo: int, hi: int) -> tuple[int, int]:
    return (lo, hi) if span is None else (min(span[0], lo), max(span[1], hi))


def _product(row: np.ndarray, neuron: np.ndarray, rows: int, block: Dense) -> torch.Tensor:
    """``S @ W`` with ``S[row, neuron]`` the number of spikes there."""
    order = np.lexsort((neuron, row))
    row, col = row[order], neuron[order]
    crow = np.searchsorted(row, np.arange(rows + 1), side="left")
    w = block.weight
    with warnings.catch_warnings():  # torch calls its sparse CSR layout "beta"; its product with a dense matrix is used here
        warnings.filterwarnings("ignore", message="Sparse CSR tensor support is in beta", category=UserWarning)
        s = torch.sparse_csr_tensor(
            torch.as_tensor(crow, device=w.device),
            torch.as_tensor(col, device=w.device),
            torch.ones(col.size, dtype=w.dtype, device=w.device),
            size=(rows, w.shape[0]),
            check_invariants=False,
        )
        return s @ w
