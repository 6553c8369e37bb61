"""The ``torch`` backend: many independent items simulated at once as batched tensor steps.

A network is compiled to PyTorch tensors with a batch dimension of independent items
(``Simulation.run_batch``: images presented one per item, each from the reset state) and
advanced step by step on a CPU or a CUDA GPU, with the reference backend's semantics
(docs/semantics.md): exact subthreshold integration, the same cell types (with the spike
lockout), every connector, per-connection delays, Poisson sources drawn with the backend
kit's seeding, array sources. Inference only: plasticity is off (see :mod:`.capabilities`).
Source spikes are known before a run, so what they deliver is computed ahead of the step
loop a chunk of steps at a time (:mod:`.drive`); spikes of neurons go through a delay ring
(:mod:`.build`).

Options of ``nv.compile(..., backend="torch", ...)``:

- ``device``: ``"cpu"``, ``"cuda"`` or ``"cuda:N"``; default ``"cuda"`` when
  ``torch.cuda.is_available()``, else ``"cpu"``.
- ``dtype``: ``"float64"`` (default) or ``"float32"``. In float64 the state differs from
  the reference backend's only by the order of summation of synaptic inputs and the last
  bit of ``exp`` (about 1e-15 relative), so spikes are the same unless a membrane ends a
  step within about 1e-12 mV of its threshold. float32 (for speed on a GPU) rounds the
  membrane to about 1e-6 relative (some 1e-5 mV): spikes near threshold may move by a step
  or appear/disappear, so counts agree statistically, not spike for spike.
- ``batch_size``: items simulated at once (default 256); larger batches amortise the
  per-step overhead and need about ``(2 * ring + 10) * batch_size * neurons`` values of memory,
  plus the source drive's window of coming steps (about 64 MiB; more when the batch's
  values over twice the longest source delay need more); both are checked against the memory limit before a batch.
- ``threads``: torch's intra-op CPU threads while this simulation runs (default 1: the
  per-step tensors are small, and on a shared or busy CPU more threads mostly wait for each
  other); ``None`` leaves torch's setting.
- ``fuse``: ``True`` compiles each group's neuron step (the step's arrivals, exact
  propagation, threshold, reset, refractoriness, spike counts) into one kernel with
  ``torch.compile`` (:mod:`.fused`; TorchInductor: a C++ compiler on a CPU, Triton on
  CUDA) instead of some twenty eager tensor operations per step; default ``False``. The
  first batch of a new shape compiles (about 5-15 s on a 2-core CPU; compiled kernels are
  cached on disk across processes), so it pays on long evaluations: the Modular SNN query
  phase runs about 1.5x faster than eager on a CPU. Same arithmetic; ``exp`` is the
  compiled code's own (closer to the reference backend's than eager torch's), so the
  float64 statement above holds as it is.

Importing this package does not import torch.
"""

from __future__ import annotations

from types import MappingProxyType
from typing import Any

from neurovpr.hardware.check import HardwareTarget
from neurovpr.ir.network import Network
from neurovpr.runtime.backend import Backend
from neurovpr.runtime.simulation import Simulation

from .capabilities import CAPABILITIES

__all__ = ["TorchBackend", "BACKEND"]


class TorchBackend(Backend):
    """Declaration of the ``torch`` backend."""

    name = "torch"
    description = "PyTorch batched simulation of independent items on CPU or CUDA (exact integration; inference)"
    requires = ("torch",)
    version_of = "torch"
    extra = "torch"
    capabilities = CAPABILITIES
    options = MappingProxyType({"device": None, "dtype": "float64", "batch_size": 256, "threads": 1, "fuse": False})

    def _compile(self, network: Network, *, dt: float, seed: int, hardware: HardwareTarget | None, **options: Any) -> Simulation:
        # torch is imported when a network is compiled, not with the declaration
        from .simulation import TorchSimulation

        return TorchSimulation(network, dt=dt, seed=seed, hardware=hardware, **options)


BACKEND = TorchBackend()
