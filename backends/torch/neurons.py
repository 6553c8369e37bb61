"""One step of the neurons of a batch: the membrane forms of docs/semantics.md as tensor operations.

Each function advances the ``(batch, neurons)`` state of one group of neurons (their
parameters per neuron) over one step, in place, and returns its spikes (boolean): exact
propagation of the membrane with the synaptic state at the start of the step, decay of the synaptic
state (values below :data:`FLUSH` set to 0, as the reference backend does), refractoriness and
lockout (one step counter per neuron), threshold. What a spike does to its own neuron (reset,
refractory count, the Ca2+ jump) is left to the caller, which finds the few spiking neurons
anyway and sets them with :func:`reset_spiking` instead of a pass over the whole state.

The arithmetic of every value is the reference backend's, operation for operation (a sum
may have its two terms swapped, which changes no bit); what is chosen here is how little
each step costs on a CPU, where every tensor operation reads and writes the whole
``(batch, neurons)`` block (and allocating a new block for each result costs more than
reusing one):

- every intermediate is written into the group's :class:`Scratch` (allocated once per batch)
  or into the state itself, with ``out=`` and in-place operations;
- the flush is one ``hardshrink`` (it keeps ``x`` where ``|x|`` exceeds the largest number
  below :data:`FLUSH`, i.e. where ``|x| >= FLUSH``);
- a choice between two values per neuron (held or free membrane, with or without
  conductance) is ``torch.lerp`` with a weight of exactly 0 or 1, the condition written as
  0/1 values of the state's dtype (counters clamped, conductances compared): for finite
  values ``lerp`` returns one of the two exactly
  (its two formulas multiply the difference by an exact 0), and both it and a comparison
  that writes numbers are vectorised on this CPU build, where ``where`` and a comparison that
  writes booleans run as scalar loops, several times slower. Measured on the Modular SNN
  module (batch of 100, idle): ``lerp`` 9 % faster per step in float32, 2 % slower in float64,
  so float64 keeps ``where``, as does a group with a neuron without leak (whose membrane with
  conductances is ``0 / 0`` where there is none);
- the step counters are integers, counted down with a clamp;
- the reset touches the spiking neurons only (:func:`reset_spiking`).

The spikes returned live in the scratch: they are valid until the group's next step.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch

__all__ = ["FLUSH", "Scratch", "conductance_step", "current_step", "flush_below", "reset_spiking"]

#: Synaptic currents (nA) and conductances (uS) below this are set to 0, as the reference backend does.
FLUSH = 1e-18


def flush_below(dtype: torch.dtype) -> float:
    """The largest number of ``dtype`` below :data:`FLUSH` (in ``dtype``): ``|x|`` above it is ``|x| >= FLUSH``."""
    kind = np.float64 if dtype == torch.float64 else np.float32
    return float(np.nextafter(kind(FLUSH), kind(0.0)))


@dataclass
class Scratch:
    """The working memory of one group's step for a batch: four value blocks and two masks."""

    a: torch.Tensor
    b: torch.Tensor
    c: torch.Tensor
    d: torch.Tensor
    mask: torch.Tensor
    spikes: torch.Tensor

    @staticmethod
    def bytes_per(width: int) -> int:
        """Bytes per item and neuron for values of ``width`` bytes."""
        return 4 * width + 2

    @classmethod
    def of(cls, batch: int, n: int, dtype: torch.dtype, device: torch.device) -> Scratch:
        """Scratch for ``batch`` items of ``n`` neurons."""

        def block(kind: torch.dtype) -> torch.Tensor:
            return torch.empty((batch, n), dtype=kind, device=device)

        return cls(
            a=block(dtype), b=block(dtype), c=block(dtype), d=block(dtype), mask=block(torch.bool), spikes=block(torch.bool)
        )


def _decay(x: torch.Tensor, factor: torch.Tensor, below: float) -> None:
    """``x *= factor`` in place, then values below :data:`FLUSH` in magnitude set to 0 (``below``: :func:`flush_below`)."""
    x.mul_(factor)
    torch.hardshrink(x, below, out=x)


def _spikes(v: torch.Tensor, refr: torch.Tensor, threshold: torch.Tensor, s: Scratch) -> torch.Tensor:
    """Count the step counters down in place and find the spikes: at threshold with the counter at 0."""
    torch.sub(refr, 1, out=refr).clamp_min_(0)
    return torch.ge(v, threshold, out=s.spikes).logical_and_(torch.eq(refr, 0, out=s.mask))


def current_step(
    v: torch.Tensor, ie: torch.Tensor, ii: torch.Tensor, ica: torch.Tensor, refr: torch.Tensor,
    p: dict[str, torch.Tensor], calcium: bool, below: float, s: Scratch, lerp: bool,
) -> torch.Tensor:  # fmt: skip
    """Advance current-based neurons (``IF_curr_exp``, ``IF_curr_exp_ca2_adaptive``) one step; their spikes.

    ``below`` is :func:`flush_below` of the state's dtype; ``s`` the group's :class:`Scratch`;
    ``lerp``: choose between two membranes with ``torch.lerp`` rather than ``torch.where``.
    """
    # rest + (v - rest) * p22 + ie * p21e - ii * p21i - ica * p21ca + i_offset * p20, in that order
    moved = torch.sub(v, p["v_rest"], out=s.a).mul_(p["p22"]).add_(p["v_rest"])
    moved.add_(torch.mul(ie, p["p21e"], out=s.b)).sub_(torch.mul(ii, p["p21i"], out=s.b))
    moved.sub_(torch.mul(ica, p["p21ca"], out=s.b)).add_(p["i_offset_x_p20"])
    if lerp:  # held (counter > 0): v, else moved
        torch.lerp(moved, v, s.c.copy_(refr).clamp_(max=1.0), out=v)
    else:
        torch.where(torch.gt(refr, 0, out=s.mask), v, moved, out=v)
    _decay(ie, p["p11e"], below)
    _decay(ii, p["p11i"], below)
    if calcium:
        _decay(ica, p["p11ca"], below)
    return _spikes(v, refr, p["v_thresh"], s)


def conductance_step(
    v: torch.Tensor, ie: torch.Tensor, ii: torch.Tensor, refr: torch.Tensor,
    p: dict[str, torch.Tensor], dt: float, below: float, s: Scratch, lerp: bool, *, euler: bool = False,
) -> torch.Tensor:  # fmt: skip
    """Advance conductance-based neurons (``IF_cond_exp``, ``IF_cond_exp_adaptive``) one step.

    Their threshold is ``p["v_thresh_theta"]``: ``v_thresh`` plus the adaptive threshold's
    fixed (learned) value. ``below`` is :func:`flush_below` of the state's dtype; ``s`` the
    group's :class:`Scratch`; ``lerp``: choose between two membranes with ``torch.lerp``
    rather than ``torch.where`` (only where every neuron of the group has a leak, ``gl > 0``,
    so that the membrane with conductances is finite everywhere); ``euler``: the group takes
    forward-Euler steps (``integration="euler"``: ``1 - dt gt / cm`` for ``exp(-dt gt / cm)``,
    the other factors from :func:`neurovpr.backendkit.propagators.propagators`).
    """
    # leak = rest + (v - rest) * p22 + i_offset * p20;
    # v_inf = (gl * rest + ge * e_rev_e + gi * e_rev_i + i_offset) / gt with gt = gl + ge + gi, ge = ie * fe, gi = ii * fi;
    # moved = v_inf + (v - v_inf) * exp(-dt * gt / cm); the leak alone where there is no conductance
    ge = torch.mul(ie, p["fe"], out=s.a)
    gi = torch.mul(ii, p["fi"], out=s.b)
    gt = torch.add(ge, p["gl"], out=s.c).add_(gi)
    v_inf = ge.mul_(p["e_rev_e"]).add_(p["gl_rest"]).add_(gi.mul_(p["e_rev_i"])).add_(p["i_offset"]).div_(gt)
    factor = gt.mul_(-dt).div_(p["cm"])
    factor = factor.add_(1.0) if euler else factor.exp_()
    moved = torch.sub(v, v_inf, out=s.b).mul_(factor).add_(v_inf)
    leak = torch.sub(v, p["v_rest"], out=s.c).mul_(p["p22"]).add_(p["v_rest"]).add_(p["i_offset_p20"])
    if lerp:  # 1 where either conductance is not 0: moved, else the leak; held (counter past the lockout): v
        some = torch.maximum(torch.ne(ie, 0.0, out=s.d), torch.ne(ii, 0.0, out=s.a), out=s.d)
        free = torch.lerp(leak, moved, some, out=s.c)
        torch.lerp(free, v, torch.sub(refr, p["lock_steps"], out=s.d).clamp_(0.0, 1.0), out=v)
    else:
        free = torch.where(torch.logical_or(ie, ii, out=s.mask), moved, leak, out=s.c)
        torch.where(torch.gt(refr, p["lock_steps"], out=s.mask), v, free, out=v)
    _decay(ie, p["p11e"], below)
    _decay(ii, p["p11i"], below)
    return _spikes(v, refr, p["v_thresh_theta"], s)


def reset_spiking(
    v: torch.Tensor, refr: torch.Tensor, ica: torch.Tensor | None, flat: torch.Tensor, local: torch.Tensor,
    p: dict[str, torch.Tensor], refrac_total: torch.Tensor,
) -> None:  # fmt: skip
    """Reset the neurons that spiked: ``v`` to ``v_reset``, the counter to refractory + lockout steps, ``ica`` up by ``i_alpha``.

    ``flat`` indexes the whole (contiguous) ``(batch, N)`` state flattened (``item x N + column``),
    ``local`` the same neurons in the group's parameters; ``ica`` is ``None`` for a group without
    Ca2+ current.
    """
    v.view(-1).index_copy_(0, flat, torch.index_select(p["v_reset"], 0, local))
    refr.view(-1).index_copy_(0, flat, torch.index_select(refrac_total, 0, local))
    if ica is not None:
        ica.view(-1).index_add_(0, flat, torch.index_select(p["i_alpha"], 0, local))
