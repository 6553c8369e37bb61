"""One step of the neurons of a batch: the membrane forms of docs/semantics.md as tensor operations.

Each function advances the ``(batch, neurons)`` state of one group of neurons (their
parameters per neuron) over one step, in place, and returns its spikes (boolean): exact
propagation of the membrane with the synaptic state at the start of the step, decay of the synaptic
state (values below :data:`FLUSH` set to 0, as the reference backend does), threshold,
reset, refractoriness and lockout (one step counter per neuron), the Ca2+ jump.
"""

from __future__ import annotations

import torch

__all__ = ["FLUSH", "conductance_step", "current_step"]

#: Synaptic currents (nA) and conductances (uS) below this are set to 0, as the reference backend does.
FLUSH = 1e-18


def _decay(x: torch.Tensor, factor: torch.Tensor) -> None:
    """``x *= factor`` in place, then values below :data:`FLUSH` in magnitude set to 0."""
    x.mul_(factor)
    x.masked_fill_(x.abs() < FLUSH, 0.0)


def _after_spikes(
    v: torch.Tensor, refr: torch.Tensor, v_new: torch.Tensor, refr_new: torch.Tensor, spikes: torch.Tensor,
    v_reset: torch.Tensor, refrac_total: torch.Tensor,
) -> None:  # fmt: skip
    v.copy_(torch.where(spikes, v_reset, v_new))
    refr.copy_(torch.where(spikes, refrac_total, refr_new))


def current_step(
    v: torch.Tensor, ie: torch.Tensor, ii: torch.Tensor, ica: torch.Tensor, refr: torch.Tensor,
    p: dict[str, torch.Tensor], refrac_total: torch.Tensor, calcium: bool,
) -> torch.Tensor:  # fmt: skip
    """Advance current-based neurons (``IF_curr_exp``, ``IF_curr_exp_ca2_adaptive``) one step; their spikes."""
    rest = p["v_rest"]
    moved = rest + (v - rest) * p["p22"] + ie * p["p21e"] - ii * p["p21i"] - ica * p["p21ca"] + p["i_offset"] * p["p20"]
    held = refr > 0
    v_new = torch.where(held, v, moved)
    refr_new = refr - held.to(refr.dtype)
    _decay(ie, p["p11e"])
    _decay(ii, p["p11i"])
    if calcium:
        _decay(ica, p["p11ca"])
    spikes = (v_new >= p["v_thresh"]) & (refr_new == 0)
    _after_spikes(v, refr, v_new, refr_new, spikes, p["v_reset"], refrac_total)
    if calcium:
        ica += spikes * p["i_alpha"]
    return spikes


def conductance_step(
    v: torch.Tensor, ie: torch.Tensor, ii: torch.Tensor, refr: torch.Tensor, theta: torch.Tensor,
    p: dict[str, torch.Tensor], refrac_total: torch.Tensor, dt: float,
) -> torch.Tensor:  # fmt: skip
    """Advance conductance-based neurons (``IF_cond_exp``, ``IF_cond_exp_adaptive``, threshold + ``theta``) one step."""
    rest = p["v_rest"]
    held = refr > p["lock"]
    # the same arithmetic, in the same order, as rest + (v - rest) * p22 + i_offset * p20 (leak),
    # v_inf = (gl * rest + ge * e_rev_e + gi * e_rev_i + i_offset) / gt and
    # v_inf + (v - v_inf) * exp(-dt * gt / cm) (moved), with fewer temporaries
    leak = torch.sub(v, rest).mul_(p["p22"]).add_(rest).add_(p["i_offset_p20"])
    ge = ie * p["fe"]
    gi = ii * p["fi"]
    gt = torch.add(p["gl"], ge).add_(gi)
    v_inf = torch.add(p["gl_rest"], ge.mul_(p["e_rev_e"])).add_(gi.mul_(p["e_rev_i"])).add_(p["i_offset"]).div_(gt)
    moved = torch.sub(v, v_inf).mul_(gt.mul_(-dt).div_(p["cm"]).exp_()).add_(v_inf)
    free = torch.where((ie == 0.0) & (ii == 0.0), leak, moved)
    v_new = torch.where(held, v, free)
    refr_new = refr - (refr > 0).to(refr.dtype)
    _decay(ie, p["p11e"])
    _decay(ii, p["p11i"])
    spikes = (v_new >= p["v_thresh"] + theta) & (refr_new == 0)
    _after_spikes(v, refr, v_new, refr_new, spikes, p["v_reset"], refrac_total)
    return spikes
