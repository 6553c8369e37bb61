"""The neurons' step as one kernel per group, compiled by ``torch.compile`` (option ``fuse=True``).

:mod:`.neurons` advances a group with some twenty tensor operations, each a pass over the
``(batch, neurons)`` state; here the same arithmetic, operation for operation, is written
as one function of whole tensors that TorchInductor compiles to one loop (vectorised C++
on a CPU, a Triton kernel on CUDA), which also adds (and clears) the step's slot of the
delay ring, resets the neurons that spiked and counts their spikes, so that the caller only
finds the spiking neurons to schedule what they deliver. What differs from :mod:`.neurons`:

- step counters, spikes (0/1) and spike counts are values of the state's dtype, not
  integers and booleans: the compiled CPU loop stores booleans and compares integers
  several times slower than it handles floating-point values (measured on the Modular SNN
  module: a comparison stored as booleans about 20 times slower than the whole step
  stored as numbers); counters are whole numbers of steps, exact in float32 up to 2**24;
- ``exp`` is the compiled code's own (SLEEF on a CPU), not torch's eager kernel: it agrees
  with the reference backend's ``exp`` more often than eager torch does (float64: all but
  about 0.3 % of values, against about 5 % that differ in the last bit eagerly), so the
  membranes are as close to the reference's as those of :mod:`.neurons` or closer.

Each compiled function is specialised to the step ``dt`` and flush bound it closes over; a
new batch size or group width compiles once more (dynamo's automatic dynamic shapes make
the second one shape-generic).
"""

from __future__ import annotations

import os
import sys
from collections.abc import Callable
from dataclasses import dataclass

import torch

from neurovpr.errors import BackendUnavailableError

T = torch.Tensor

__all__ = ["CONDUCTANCE", "CURRENT", "Kernels", "kernels", "pack"]

#: The per-neuron parameters of each kernel, in the order of the rows of its packed ``(parameters, n)`` table.
CONDUCTANCE = (
    "fe", "fi", "gl", "gl_rest", "e_rev_e", "e_rev_i", "i_offset", "cm", "v_rest", "p22", "i_offset_p20",
    "lock_steps_f", "v_thresh_theta", "v_reset", "refrac_total_f", "p11e", "p11i",
)  # fmt: skip
CURRENT = (
    "v_rest", "p22", "p21e", "p21i", "p21ca", "i_offset_x_p20", "v_thresh", "v_reset", "refrac_total_f", "p11e",
    "p11i", "p11ca", "i_alpha",
)  # fmt: skip


def pack(p: dict[str, torch.Tensor], conductance: bool) -> torch.Tensor:
    """A group's parameters as the ``(parameters, n)`` table its kernel reads (one tensor: one guard, one check per call)."""
    return torch.stack([p[key] for key in (CONDUCTANCE if conductance else CURRENT)])


@dataclass(frozen=True)
class Kernels:
    """The compiled steps of a group: ``conductance(v, ie, ii, arrive_e, arrive_i, refr, counts, packed, euler)`` and
    ``current(v, ie, ii, arrive_e, arrive_i, ica, refr, counts, packed, calcium)``.

    Both add the step's arrivals (``arrive_e``, ``arrive_i``: the group's columns of the delay
    ring's slot, which they clear) to the synaptic state, advance the given ``(batch, n)``
    views in place, and return the spikes as 0/1 values; ``packed`` is the group's :func:`pack`.
    """

    conductance: Callable[..., torch.Tensor]
    current: Callable[..., torch.Tensor]


def kernels(dt: float, below: float) -> Kernels:
    """The steps for time step ``dt`` (ms) and flush bound ``below`` (:func:`.neurons.flush_below`), compiled on first call."""

    def flush(x: torch.Tensor) -> torch.Tensor:
        return torch.where(x.abs() > below, x, 0.0)

    def arrived(x: torch.Tensor, arrivals: torch.Tensor) -> torch.Tensor:
        """``x`` plus the step's arrivals, whose ring slot is cleared."""
        total = x + arrivals
        arrivals.copy_(torch.zeros_like(arrivals))
        return total

    def fire(v: torch.Tensor, refr: torch.Tensor, threshold: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        counter = (refr - 1.0).clamp_min(0.0)
        # chosen values, not a cast of (v >= threshold) & (counter == 0): the compiled CPU loop is faster so
        spikes = torch.where(v >= threshold, torch.where(counter == 0.0, 1.0, 0.0), 0.0)
        return spikes.to(v.dtype), counter

    def conductance(v: T, ie_state: T, ii_state: T, arrive_e: T, arrive_i: T, refr: T, counts: T, packed: T, euler: bool) -> T:
        # the arrivals of the step, then the arithmetic of .neurons.conductance_step, in its order
        p = dict(zip(CONDUCTANCE, packed.unbind(0), strict=True))
        ie, ii = arrived(ie_state, arrive_e), arrived(ii_state, arrive_i)
        ge = ie * p["fe"]
        gi = ii * p["fi"]
        gt = ge + p["gl"] + gi
        v_inf = (ge * p["e_rev_e"] + p["gl_rest"] + gi * p["e_rev_i"] + p["i_offset"]) / gt
        factor = gt * -dt / p["cm"] + 1.0 if euler else torch.exp(gt * -dt / p["cm"])
        moved = (v - v_inf) * factor + v_inf
        leak = (v - p["v_rest"]) * p["p22"] + p["v_rest"] + p["i_offset_p20"]
        free = torch.where(ie != 0.0, moved, torch.where(ii != 0.0, moved, leak))
        held = torch.where(refr > p["lock_steps_f"], v, free)
        spikes, counter = fire(held, refr, p["v_thresh_theta"])
        v.copy_(torch.where(spikes != 0.0, p["v_reset"], held))
        refr.copy_(torch.where(spikes != 0.0, p["refrac_total_f"], counter))
        ie_state.copy_(flush(ie * p["p11e"]))
        ii_state.copy_(flush(ii * p["p11i"]))
        counts.add_(spikes)
        return spikes

    def current(
        v: T, ie_state: T, ii_state: T, arrive_e: T, arrive_i: T, ica: T, refr: T, counts: T, packed: T, calcium: bool
    ) -> T:
        # the arrivals of the step, then the arithmetic of .neurons.current_step, in its order
        p = dict(zip(CURRENT, packed.unbind(0), strict=True))
        ie, ii = arrived(ie_state, arrive_e), arrived(ii_state, arrive_i)
        moved = (v - p["v_rest"]) * p["p22"] + p["v_rest"] + ie * p["p21e"] - ii * p["p21i"] - ica * p["p21ca"]
        moved = moved + p["i_offset_x_p20"]
        held = torch.where(refr > 0.0, v, moved)
        spikes, counter = fire(held, refr, p["v_thresh"])
        v.copy_(torch.where(spikes != 0.0, p["v_reset"], held))
        refr.copy_(torch.where(spikes != 0.0, p["refrac_total_f"], counter))
        ie_state.copy_(flush(ie * p["p11e"]))
        ii_state.copy_(flush(ii * p["p11i"]))
        if calcium:
            decayed = flush(ica * p["p11ca"])
            ica.copy_(torch.where(spikes != 0.0, decayed + p["i_alpha"], decayed))
        counts.add_(spikes)
        return spikes

    return Kernels(
        conductance=_guarded(torch.compile(conductance, fullgraph=True)),
        current=_guarded(torch.compile(current, fullgraph=True)),
    )


def _guarded(step: Callable[..., T]) -> Callable[..., T]:
    """``step``, its compiled code loaded privately, and a failure of ``torch.compile`` itself said in one sentence.

    TorchInductor loads each compiled kernel as a Python extension module, with the process's
    ``dlopen`` flags. PyNEST sets ``RTLD_GLOBAL`` for the rest of the process when it is
    imported (the ``pynn`` backend on NEST); kernels loaded that way export their functions
    to every library loaded after them, and a later kernel of another shape whose C function
    has the same name (it is named after its operations) then calls the earlier one: wrong
    sizes, writes past the end of the state (``free(): corrupted unsorted chunks``). So the
    flag is cleared while a step runs (and compiles and loads), and restored after.
    """

    def call(*args: object) -> T:
        flags = sys.getdlopenflags()
        if flags & os.RTLD_GLOBAL:
            sys.setdlopenflags(flags & ~os.RTLD_GLOBAL)
        try:
            return step(*args)
        except torch._dynamo.exc.BackendCompilerFailed as err:
            reason = str(err.inner_exception).strip().splitlines()[0][:200] if str(err.inner_exception).strip() else ""
            raise BackendUnavailableError(
                f"torch backend: the option fuse needs torch.compile, which failed here "
                f"({type(err.inner_exception).__name__}: {reason}); use fuse=False."
            ) from err
        finally:
            if flags & os.RTLD_GLOBAL:
                sys.setdlopenflags(flags)

    return call
