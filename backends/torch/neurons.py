"""One step of the neurons of a batch: the membrane forms of docs/semantics.md as tensor operations.

Each function advances the ``(batch, neurons)`` state of one group of neurons (their
parameters per neuron) over one step, in place, and returns the spikes (0/1, in the dtype
of the step counters: a compiled kernel stores them much faster than booleans): exact propagation
of the membrane with the synaptic state at the start of the step, decay of the synaptic
state (values below :data:`FLUSH` set to 0, as the reference backend does), threshold,
reset, refractoriness and lockout (one step counter per neuron), the Ca2+ jump.

:func:`deliver_rows` is the source drive's delivery of scattered synapses (:mod:`.drive`), the
other per-element loop of a step. :class:`NeuronSteps` holds the functions a simulation calls: these, or the same functions
compiled by ``torch.compile`` (TorchInductor: the tens of element-wise operations of a step
fused into one loop over the state, a C++ kernel on a CPU and a Triton kernel on a GPU). The
arithmetic is the same; a compiled kernel may contract a multiplication and an addition into
one rounding (FMA) and computes ``exp`` with its own vector routine, so its state can differ
from the eager one in the last bit, as the eager one differs from the reference backend's.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable

import torch

from neurovpr.errors import BackendUnavailableError

__all__ = ["AUTO_FUSE_WORK", "FLUSH", "NeuronSteps", "conductance_step", "current_step", "deliver_rows"]

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
    return spikes.to(refr.dtype)


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
    free = torch.where(ie == 0.0, torch.where(ii == 0.0, leak, moved), moved)
    v_new = torch.where(held, v, free)
    refr_new = refr - (refr > 0).to(refr.dtype)
    _decay(ie, p["p11e"])
    _decay(ii, p["p11i"])
    spikes = (v_new >= p["v_thresh"] + theta) & (refr_new == 0)
    _after_spikes(v, refr, v_new, refr_new, spikes, p["v_reset"], refrac_total)
    return spikes.to(refr.dtype)


def deliver_rows(flat: torch.Tensor, offset: torch.Tensor, weight: torch.Tensor, who: torch.Tensor, at: torch.Tensor) -> None:
    """Add row ``who[s]`` of ``weight`` at ``at[s] + offset[who[s]]`` of ``flat`` for every spike ``s``, in order."""
    index = offset[who]
    index += at[:, None]
    flat.index_add_(0, index.view(-1), weight[who].view(-1))


#: With ``fuse=None`` (automatic) a batch is run fused when its neurons x steps reach this:
#: compiling takes seconds once per shape and process, and pays off from about there on.
AUTO_FUSE_WORK = 10**8

_EAGER = {"current": current_step, "conductance": conductance_step, "deliver": deliver_rows}
_LABEL = {"current": "current-based neuron step", "conductance": "conductance-based neuron step",
          "deliver": "source drive's delivery"}  # fmt: skip


class NeuronSteps:
    """The per-element loops a simulation calls: eager, or fused by ``torch.compile``.

    ``fuse``: ``True`` always fused, ``False`` never, ``None`` (automatic) fused for the
    batches the simulation marks as large (:meth:`choose`, :data:`AUTO_FUSE_WORK`).
    Compilation happens at the first fused call with a new shape (seconds to tens of seconds;
    TorchInductor caches kernels on disk across processes). When it fails (for example no C++
    compiler for the CPU kernel), ``fuse=True`` raises a
    :class:`~neurovpr.errors.BackendUnavailableError` naming the cause; the automatic choice
    warns once and goes on eagerly, with the same results.
    """

    def __init__(self, fuse: bool | None) -> None:
        self.fuse = fuse
        self.fused = bool(fuse)
        self._compiled: dict[str, Callable[..., torch.Tensor | None]] = {}
        self._failed = False

    def choose(self, work: int) -> None:
        """Run fused or eagerly from now on, for a batch of ``work`` neurons x steps."""
        self.fused = self.fuse if self.fuse is not None else (work >= AUTO_FUSE_WORK and not self._failed)

    def deliver(self, *args: object) -> None:
        """:func:`deliver_rows` (the source drive's scattered synapses), fused when chosen (one loop, no temporaries)."""
        self._call("deliver", args)

    def current(self, *args: object) -> torch.Tensor:
        """:func:`current_step`, fused when chosen."""
        return self._call("current", args)

    def conductance(self, *args: object) -> torch.Tensor:
        """:func:`conductance_step`, fused when chosen."""
        return self._call("conductance", args)

    def _call(self, name: str, args: tuple[object, ...]) -> torch.Tensor | None:
        if not self.fused:
            return _EAGER[name](*args)
        fn = self._compiled.get(name)
        if fn is None:
            fn = self._compiled[name] = torch.compile(_EAGER[name], dynamic=False)
        try:
            return fn(*args)
        except Exception as exc:  # torch.compile wraps compiler failures in several exception types
            cause = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
            if self.fuse:
                raise BackendUnavailableError(
                    f"torch backend: fuse=True could not compile the {_LABEL[name]} ({cause[:200]}); use fuse=False."
                ) from exc
            warnings.warn(
                f"torch backend: could not compile the {_LABEL[name]} ({cause[:200]}); running without fuse.",
                RuntimeWarning,
                stacklevel=3,
            )
            self._failed, self.fused = True, False
            return _EAGER[name](*args)
