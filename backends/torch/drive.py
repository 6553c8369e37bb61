"""Source drive: what the dense blocks of source populations deliver, computed ahead of the step loop.

The spikes of source populations (spike arrays, and Poisson trains drawn by the backend
kit) are known before a run starts. For a dense block (:class:`.build.Dense`) of a
source, the arrivals of a chunk of steps are one product ``S @ W``: ``S`` is the sparse
``(steps x items, presynaptic neurons)`` matrix of spike counts shifted by the block's
delay, ``W`` the block's weight matrix. The step loop then adds one slice of the chunk
to the synaptic state per step. Chunks are sized so the drive stays within
:data:`CHUNK_BYTES`. Spikes whose arrival falls after the run are scheduled into the delay
ring, so state that carries over to the next ``run`` receives them as before.
"""

from __future__ import annotations

import warnings

import numpy as np
import torch

from .build import BatchState, Compiled, Dense

__all__ = ["SourceDrive", "CHUNK_BYTES"]

#: The most memory the drive of one chunk of steps takes (its chunk shrinks to fit, down to one step).
CHUNK_BYTES = 32 * 2**20


class SourceDrive:
    """The drive of every source's dense blocks over steps ``first .. first + n_steps - 1`` of a batch.

    Parameters
    ----------
    net
        The compiled network.
    events
        Per source population, its spikes ``(steps, items, neurons)`` sorted by step (items
        ascending within a step).
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
        self.blocks = [(events[name], block) for name in events for block in net.dense.get(name, ())]
        self.spans: dict[int, tuple[int, int]] = {}
        for _, block in self.blocks:
            lo, hi = self.spans.get(block.receptor, (block.lo, block.hi))
            self.spans[block.receptor] = (min(lo, block.lo), max(hi, block.hi))
        width = sum(hi - lo for lo, hi in self.spans.values())
        widest = max((block.hi - block.lo for _, block in self.blocks), default=0)
        itemsize = torch.empty(0, dtype=net.dtype).element_size()
        per_step = batch * (width + widest) * itemsize  # the drive and one block's product
        self.chunk = max(1, min(n_steps, CHUNK_BYTES // max(per_step, 1)))
        #: bytes the drive allocates at most
        self.bytes = self.chunk * per_step if self.blocks else 0
        self.synaptic_events = sum(int(block.synapses[ev[2]].sum()) for ev, block in self.blocks)
        self._start = first
        self._drive: dict[int, torch.Tensor] = {}

    def add(self, isyn: torch.Tensor, j: int) -> None:
        """Add the drive arriving at step ``j`` to ``isyn`` (``(2, batch, N)``); steps come in order."""
        if not self.blocks:
            return
        if not self._drive or j >= self._start + self.chunk:
            self._load(j)
        k = j - self._start
        for receptor, (lo, hi) in self.spans.items():
            isyn[receptor, :, lo:hi] += self._drive[receptor][k]

    def schedule_tail(self, state: BatchState) -> None:
        """Schedule into ``state``'s delay ring the spikes arriving after the run."""
        end = self.first + self.n_steps
        dev = self.net.device
        for (steps, item, neurons), block in self.blocks:
            late = steps + block.delay >= end
            if late.any():
                item_t, neuron_t, stamp_t = (torch.as_tensor(a[late], device=dev) for a in (item, neurons, steps))
                state.emit_dense(block, item_t, neuron_t, stamp_t, count=False)

    def _load(self, start: int) -> None:
        """Compute the drive of arrival steps ``start .. start + chunk - 1``."""
        self._start = start
        steps_here = min(self.chunk, self.first + self.n_steps - start)
        dev, dtype, b = self.net.device, self.net.dtype, self.batch
        self._drive = {r: torch.zeros((steps_here, b, hi - lo), dtype=dtype, device=dev) for r, (lo, hi) in self.spans.items()}
        for (steps, item, neurons), block in self.blocks:
            a, z = np.searchsorted(steps, [start - block.delay, start + steps_here - block.delay], side="left")
            if z <= a:
                continue
            product = _product(steps[a:z] + block.delay - start, item[a:z], neurons[a:z], steps_here * b, b, block)
            lo_r = self.spans[block.receptor][0]
            self._drive[block.receptor][:, :, block.lo - lo_r : block.hi - lo_r] += product.view(steps_here, b, -1)


def _product(step: np.ndarray, item: np.ndarray, neuron: np.ndarray, rows: int, batch: int, block: Dense) -> torch.Tensor:
    """``S @ W`` with ``S[step * batch + item, neuron]`` the number of spikes there."""
    row = step * batch + item
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
