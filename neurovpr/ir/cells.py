"""Cell types: neuron models and spike sources, with PyNN's names, defaults and units.

Units follow PyNN: ms, mV, nA, nF, uS, Hz. Every numeric parameter is either one
number for the whole population or a 1-D array with one value per neuron.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import InitVar, dataclass, field
from typing import Any, ClassVar

import numpy as np

from neurovpr.errors import ValidationError
from neurovpr.ir.node import IRNode, freeze_array, param

__all__ = [
    "CellType",
    "NeuronType",
    "SourceType",
    "IF_curr_exp",
    "IF_cond_exp",
    "IF_cond_exp_adaptive",
    "IF_curr_exp_ca2_adaptive",
    "SoftLIF",
    "SpikeSourcePoisson",
    "SpikeSourceArray",
    "CELL_TYPES",
    "INTEGRATIONS",
    "NO_LEAK",
    "euler_integrated",
]

#: ``tau_m`` of a membrane without leak (ms): ``exp(-dt / NO_LEAK)`` is exactly 1 for any step.
#: ``inf`` is refused, so a typing mistake cannot simulate as NaN; write ``tau_m=nv.NO_LEAK``.
NO_LEAK = 1e30
_NO_LEAK_HINT = "for a membrane without leak write tau_m=nv.NO_LEAK"
#: How a conductance-based cell advances over one step (``integration``; docs/semantics.md, "Neurons").
INTEGRATIONS = ("exact", "euler")

_KW = {"frozen": True, "slots": True, "kw_only": True, "eq": False}


class CellType(IRNode):
    """Base of every cell type."""

    __slots__ = ()
    #: True for spike sources, which have no membrane and receive no projections.
    is_source: ClassVar[bool] = False
    #: True when synaptic input is a conductance (uS) rather than a current (nA).
    conductance_based: ClassVar[bool] = False
    #: Names of the state variables a backend can record for this type.
    recordable: ClassVar[tuple[str, ...]] = ()

    def for_size(self, n: int) -> CellType:
        """The cell type as ``n`` neurons hold it (values shared by every neuron spelled out where needed)."""
        return self

    def array_sizes(self) -> dict[str, int]:
        """Return ``{field: length}`` for every field given as a per-neuron array."""
        return {
            name: value.size
            for name in self.__dataclass_fields__  # type: ignore[attr-defined]
            if isinstance(value := getattr(self, name), np.ndarray) and value.ndim == 1
        }


@dataclass(**_KW)
class NeuronType(CellType):
    """Base of the integrate-and-fire neuron models: the parameters they all share.

    PyNN's names, defaults and units; each model adds its own (reversal potentials,
    adaptation) after these.
    """

    recordable = ("v", "isyn_exc", "isyn_inh")

    cm: float = param(1.0, unit="nF", low=0.0, low_open=True, array=True)
    tau_m: float = param(20.0, unit="ms", low=0.0, low_open=True, array=True, hint=_NO_LEAK_HINT)
    tau_refrac: float = param(0.1, unit="ms", low=0.0, array=True)
    tau_syn_E: float = param(5.0, unit="ms", low=0.0, low_open=True, array=True)
    tau_syn_I: float = param(5.0, unit="ms", low=0.0, low_open=True, array=True)
    v_rest: float = param(-65.0, unit="mV", array=True)
    v_reset: float = param(-65.0, unit="mV", array=True)
    v_thresh: float = param(-50.0, unit="mV", array=True, infinite="never fires")
    i_offset: float = param(0.0, unit="nA", array=True)

    def _validate(self) -> None:
        if np.any(np.asarray(self.v_reset) >= np.asarray(self.v_thresh)):
            raise ValidationError(
                f"{type(self).__name__}.v_reset ({self.v_reset!r} mV) must be below v_thresh ({self.v_thresh!r} mV)."
            )


class SourceType(CellType):
    """Base of the spike sources."""

    __slots__ = ()
    is_source = True


@dataclass(**_KW)
class IF_curr_exp(NeuronType):  # noqa: N801 - PyNN's name
    """Leaky integrate-and-fire neuron with exponentially decaying current synapses.

    ``cm dv/dt = cm (v_rest - v) / tau_m + I_E - I_I + i_offset``, ``dI_X/dt = -I_X / tau_syn_X``;
    a spike when ``v >= v_thresh``, then ``v = v_reset`` for ``tau_refrac``.
    """


@dataclass(**_KW)
class IF_cond_exp(NeuronType):  # noqa: N801 - PyNN's name
    """Leaky integrate-and-fire neuron with exponentially decaying conductance synapses.

    ``cm dv/dt = cm (v_rest - v) / tau_m + g_E (e_rev_E - v) + g_I (e_rev_I - v) + i_offset``.

    ``integration`` is how a step advances the neuron (docs/semantics.md, "Neurons"):
    ``"exact"`` (default) decays the conductances exactly and moves the membrane exactly with
    the step's mean conductances; ``"euler"`` is the forward-Euler step of the same equations
    from the values at the step's start (Brian2's ``method='euler'``, with which Diehl &
    Cook's and the Modular SNN authors' code run): ``v += dt / cm (cm / tau_m (v_rest - v)
    + g_E (e_rev_E - v) + g_I (e_rev_I - v) + i_offset)``, ``g_X *= 1 - dt / tau_syn_X``.
    It needs a step shorter than every time constant of the cell, and a backend that
    declares ``Capabilities.euler_integration``.
    """

    conductance_based = True
    recordable = ("v", "gsyn_exc", "gsyn_inh")

    e_rev_E: float = param(0.0, unit="mV", array=True)
    e_rev_I: float = param(-70.0, unit="mV", array=True)
    integration: str = "exact"

    def _validate(self) -> None:
        NeuronType._validate(self)
        _check_integration(self)


def euler_integrated(cell: object) -> bool:
    """Whether ``cell`` takes forward-Euler steps (``IF_cond_exp`` or ``IF_cond_exp_adaptive`` with ``integration="euler"``)."""
    return isinstance(cell, (IF_cond_exp, IF_cond_exp_adaptive)) and cell.integration == "euler"


def _check_integration(cell: IF_cond_exp | IF_cond_exp_adaptive) -> None:
    if cell.integration not in INTEGRATIONS:
        raise ValidationError(
            f"{type(cell).__name__}.integration must be one of {', '.join(map(repr, INTEGRATIONS))}, got {cell.integration!r}."
        )


@dataclass(**_KW)
class IF_cond_exp_adaptive(NeuronType):  # noqa: N801 - PyNN-style name
    """Diehl & Cook (2015) excitatory neuron: ``IF_cond_exp`` with an adaptive threshold.

    The threshold is ``v_thresh + theta``; ``theta`` grows by ``theta_plus`` at every
    spike and decays to 0 with ``tau_theta``. ``theta_init`` is its starting value
    (a learned quantity: saving a trained simulation stores it here).

    ``tau_lockout`` is a spike lockout separate from the membrane clamp: after a spike
    the membrane is held at ``v_reset`` for ``tau_refrac`` and integrates normally after
    that, but the neuron cannot fire again until ``max(tau_refrac, tau_lockout)`` has
    passed since its spike (the Modular SNN authors' code clamps for 5 ms and locks out
    for 50 ms). The default 0 leaves ``tau_refrac`` alone in charge, as in ``IF_cond_exp``.

    ``integration`` is as in ``IF_cond_exp``; with ``"euler"`` ``theta`` too decays by
    ``1 - dt / tau_theta`` per step.
    """

    conductance_based = True
    recordable = ("v", "gsyn_exc", "gsyn_inh", "theta")

    tau_lockout: float = param(
        0.0, unit="ms", low=0.0, array=True, doc="time after a spike before the next may come (membrane free after tau_refrac)"
    )
    e_rev_E: float = param(0.0, unit="mV", array=True)
    e_rev_I: float = param(-70.0, unit="mV", array=True)
    theta_plus: float = param(0.05, unit="mV", low=0.0, array=True)
    tau_theta: float = param(1e7, unit="ms", low=0.0, low_open=True, array=True)
    theta_init: float = param(0.0, unit="mV", array=True)
    integration: str = "exact"

    def _validate(self) -> None:
        NeuronType._validate(self)
        _check_integration(self)


@dataclass(**_KW)
class IF_curr_exp_ca2_adaptive(NeuronType):  # noqa: N801 - sPyNNaker's name
    """sPyNNaker's ``IFCurrExpCa2Adaptive`` (Liu & Wang 2001): ``IF_curr_exp`` plus a
    calcium-activated after-hyperpolarisation current.

    ``dI_ca2/dt = -I_ca2 / tau_ca2``, ``I_ca2 += i_alpha`` at each spike, and ``-I_ca2``
    is added to the membrane current. ``i_ca2`` is its initial value.
    """

    recordable = ("v", "isyn_exc", "isyn_inh", "i_ca2")

    tau_ca2: float = param(50.0, unit="ms", low=0.0, low_open=True, array=True)
    i_ca2: float = param(0.0, unit="nA", array=True)
    i_alpha: float = param(0.1, unit="nA", array=True)


@dataclass(**_KW)
class SoftLIF(CellType):
    """Rate-approximated LIF (Hunsberger & Eliasmith 2015), for gradient training only.

    ``r(j) = amplitude / (tau_ref + tau_rc * log(1 + 1 / p(j - 1)))`` with the smooth
    ``p(x) = sigma * log(1 + exp(x / sigma))``. No spiking backend runs it; a trained
    network is converted to spiking LIF populations before simulation.
    """

    tau_rc: float = param(20.0, unit="ms", low=0.0, low_open=True)
    tau_ref: float = param(2.0, unit="ms", low=0.0)
    sigma: float = param(0.02, low=0.0, low_open=True, doc="softplus smoothing (gamma)")
    amplitude: float = param(1.0, low=0.0, low_open=True)


@dataclass(**_KW)
class SpikeSourcePoisson(SourceType):
    """Independent Poisson spike trains, one per neuron.

    ``rate`` may be one rate for all neurons or one per neuron; it can be replaced
    at every ``Simulation.run`` through ``inputs=``.
    """

    rate: float = param(0.0, unit="Hz", low=0.0, array=True)
    start: float = param(0.0, unit="ms", low=0.0)
    duration: float = param(math.inf, unit="ms", low=0.0, infinite="for ever")


def _spike_trains(spike_times: Any) -> tuple[list[np.ndarray], bool]:
    """PyNN's ``spike_times``: one sequence of numbers (shared by every neuron) or one sequence per neuron.

    Returns the trains and whether the one train is shared.
    """
    if isinstance(spike_times, (str, bytes)) or not isinstance(spike_times, (Sequence, np.ndarray)):
        raise ValidationError(
            f"SpikeSourceArray.spike_times must be a sequence of times (ms) or one sequence per neuron, "
            f"got {type(spike_times).__name__}."
        )
    items = list(spike_times)
    nested = [isinstance(x, (Sequence, np.ndarray)) and not isinstance(x, (str, bytes)) for x in items]
    if items and all(nested):
        trains = [np.asarray(x) for x in items]
        shared = False
    elif any(nested):
        raise ValidationError("SpikeSourceArray.spike_times mixes numbers and sequences; give one or the other.")
    else:
        trains, shared = [np.asarray(items)], True
    for i, train in enumerate(trains):
        if train.ndim != 1 or (train.size and not np.issubdtype(train.dtype, np.number)):
            where = "" if shared else f" of neuron {i}"
            raise ValidationError(f"SpikeSourceArray.spike_times{where} must be a flat sequence of numbers (ms).")
    return trains, shared


def _flatten(trains: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    lengths = [t.size for t in trains]
    offsets = np.concatenate([[0], np.cumsum(lengths)]).astype(np.int64)
    flat = np.concatenate([t.astype(np.float64) for t in trains]) if any(lengths) else np.zeros(0)
    return flat, offsets


@dataclass(**_KW)
class SpikeSourceArray(SourceType):
    """Explicit spike times, as PyNN's ``SpikeSourceArray(spike_times=...)``.

    ``spike_times`` is either one sorted sequence of times (ms), which every neuron of
    the population fires (PyNN: a parameter given once is homogeneous), or one sorted
    sequence per neuron (``[[...], [...]]``). The spike trains are stored as a flat
    ``times`` array and CSR ``offsets`` (neuron ``i`` fires at
    ``times[offsets[i]:offsets[i+1]]``); :meth:`from_lists` and :meth:`from_events`
    build them too. A shared train (``shared`` is true) becomes one train per neuron
    when the source is given to a population (:meth:`for_size`).
    """

    spike_times: InitVar[Any] = None
    times: np.ndarray = field(default_factory=lambda: np.zeros(0), metadata={"unit": "ms"})
    offsets: np.ndarray = field(default_factory=lambda: np.zeros(1, dtype=np.int64))
    #: True when one spike train is shared by every neuron (``spike_times`` was one sequence of numbers).
    shared: bool = field(default=False, init=False)

    def __post_init__(self, spike_times: Any) -> None:  # arrays may legitimately be empty here
        name = type(self).__name__
        if spike_times is not None:
            if np.size(self.times) or np.size(self.offsets) != 1:
                raise ValidationError(f"{name}: give spike_times, or times and offsets, not both.")
            trains, shared = _spike_trains(spike_times)
            flat, offsets = _flatten(trains)
            object.__setattr__(self, "times", flat)
            object.__setattr__(self, "offsets", offsets)
            object.__setattr__(self, "shared", shared)
        times = freeze_array(self.times)
        offsets = freeze_array(self.offsets, dtype=np.int64)
        object.__setattr__(self, "times", times)
        object.__setattr__(self, "offsets", offsets)
        if times.ndim != 1 or offsets.ndim != 1 or offsets.size < 1:
            raise ValidationError(f"{name}.offsets must be a 1-D CSR offset array of length n+1.")
        if offsets[0] != 0 or offsets[-1] != times.size or np.any(np.diff(offsets) < 0):
            raise ValidationError(
                f"{name}.offsets must rise from 0 to len(times)={times.size}, got {offsets.tolist()[:8]}."
            )
        if times.size and (not np.all(np.isfinite(times)) or times.min() < 0):
            bad = int(np.flatnonzero(~np.isfinite(times) | (times < 0))[0])
            raise ValidationError(
                f"{name}.times must be finite and >= 0 ms, got {times[bad]!r} at index {bad}."
            )
        for i in range(offsets.size - 1):
            seg = times[offsets[i] : offsets[i + 1]]
            if seg.size > 1 and np.any(np.diff(seg) < 0):
                raise ValidationError(f"{name}: spike times of neuron {i} are not sorted.")

    @property
    def n_neurons(self) -> int:
        """Number of spike trains held (1 for a shared train)."""
        return int(self.offsets.size - 1)

    def for_size(self, n: int) -> SpikeSourceArray:
        """The source for ``n`` neurons: a shared train repeated for each; any other source unchanged."""
        if not self.shared:
            return self
        return SpikeSourceArray(times=np.tile(self.times, n), offsets=np.arange(n + 1, dtype=np.int64) * self.times.size)

    @classmethod
    def from_lists(cls, spike_times: list[list[float]] | list[np.ndarray]) -> SpikeSourceArray:
        """Build from one sequence of spike times (ms) per neuron."""
        flat, offsets = _flatten([np.asarray(s, dtype=float) for s in spike_times])
        return cls(times=flat, offsets=offsets)

    @classmethod
    def from_events(cls, times_ms: np.ndarray, neurons: np.ndarray, n_neurons: int) -> SpikeSourceArray:
        """Build from parallel arrays of spike times (ms) and neuron indices."""
        times_ms = np.asarray(times_ms, dtype=float)
        neurons = np.asarray(neurons, dtype=np.int64)
        if times_ms.shape != neurons.shape or times_ms.ndim != 1:
            raise ValidationError("SpikeSourceArray.from_events needs two 1-D arrays of equal length.")
        if neurons.size and (neurons.min() < 0 or neurons.max() >= n_neurons):
            raise ValidationError(
                f"SpikeSourceArray.from_events: neuron index {int(neurons.max())} is outside 0..{n_neurons - 1}."
            )
        order = np.lexsort((times_ms, neurons))
        counts = np.bincount(neurons, minlength=n_neurons)
        offsets = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
        return cls(times=times_ms[order], offsets=offsets)

    def array_sizes(self) -> dict[str, int]:
        """Per-neuron spike trains give the population size through ``offsets`` (a shared train fits any size)."""
        return {} if self.shared else {"spike_times": self.n_neurons}


#: Every cell type, by name (save/load, registries and capability tables use it).
CELL_TYPES: dict[str, type[CellType]] = {
    cls.__name__: cls
    for cls in (
        IF_curr_exp,
        IF_cond_exp,
        IF_cond_exp_adaptive,
        IF_curr_exp_ca2_adaptive,
        SoftLIF,
        SpikeSourcePoisson,
        SpikeSourceArray,
    )
}
