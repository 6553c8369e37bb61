"""Synapse types and plasticity rules as data, with PyNN's parameter names.

Weights are in uS for conductance-based targets and nA for current-based targets.
A weight is a number, a :class:`~neurovpr.ir.distributions.Distribution`, or an array:
1-D with one value per connection in the canonical connection order
(see :mod:`neurovpr.ir.connectivity`), or 2-D ``(n_pre, n_post)`` read at each
connection's ``[pre, post]``. For a :class:`~neurovpr.ir.connectors.ConvolutionConnector`
the weight is the kernel, shaped ``(out_channels, in_channels, kh, kw)``.
Delays are in ms; ``None`` means one simulation time step (PyNN's minimum delay). A delay of
exactly 0 is a *zero-delay* synapse (a neuron's spike acts from the next step, as Brian2's
zero delay does; see docs/semantics.md); backends that cannot run it refuse it by name
(``Capabilities.zero_delays``).

Sign convention: projections onto the ``inhibitory`` receptor and all projections
onto conductance-based neurons take non-negative weights (the receptor gives the
sign); onto the ``excitatory`` receptor of a current-based neuron a weight may be
negative (a signed current, as in converted convolutional networks).
"""

from __future__ import annotations

from dataclasses import KW_ONLY, dataclass, field
from typing import Any, Union

import numpy as np

from neurovpr.errors import ValidationError
from neurovpr.ir.distributions import Distribution
from neurovpr.ir.node import IRNode, freeze_array, param

__all__ = [
    "Synapse",
    "StaticSynapse",
    "SpikePairRule",
    "AdditiveWeightDependence",
    "MultiplicativeWeightDependence",
    "STDPMechanism",
    "DiehlCookSTDP",
    "WeightSpec",
    "DelaySpec",
    "SYNAPSE_TYPES",
]

_KW = {"frozen": True, "slots": True, "kw_only": True, "eq": False}
#: What a presynaptic arrival does under :class:`DiehlCookSTDP`: ``w -= eta_pre x_post`` or ``w += eta_pre x_post``.
PRE_TERMS = ("depress", "potentiate")
#: Where PyNN takes it by position (``STDPMechanism(SpikePairRule(...), ...)``, ``SpikePairRule(20.0, ...)``),
#: the first parameter may be given by position, the rest by keyword; ``StaticSynapse`` stays keyword-only
#: (PyNN's standard synapse types take ``**parameters``).
_FIRST_POSITIONAL = {"frozen": True, "slots": True, "eq": False}

WeightSpec = Union[float, Distribution, np.ndarray]
DelaySpec = Union[float, Distribution, np.ndarray, None]


def _check_value(owner: str, name: str, value: Any, *, allow_none: bool) -> Any:
    """Normalise a weight or delay spec: number, Distribution, array, or None."""
    if value is None:
        if allow_none:
            return None
        raise ValidationError(f"{owner}.{name} must be given.")
    if isinstance(value, Distribution):
        return value
    if isinstance(value, bool):
        raise ValidationError(f"{owner}.{name} must be a number, a distribution or an array, got {value!r}.")
    if isinstance(value, (int, float, np.integer, np.floating)):
        number = float(value)
        if not np.isfinite(number):
            raise ValidationError(f"{owner}.{name} must be finite, got {number!r}.")
        return number
    try:
        arr = freeze_array(value)
    except (TypeError, ValueError):
        raise ValidationError(
            f"{owner}.{name} must be a number, a distribution or an array, got {type(value).__name__}."
        ) from None
    if arr.ndim not in (1, 2, 4) or arr.size == 0:
        raise ValidationError(f"{owner}.{name} array must be 1-D, 2-D or 4-D and non-empty, got shape {arr.shape}.")
    if not np.all(np.isfinite(arr)):
        raise ValidationError(f"{owner}.{name} array contains NaN or infinite values.")
    return arr


class Synapse(IRNode):
    """Base of the synapse types: every synapse has a ``weight`` and a ``delay``."""

    __slots__ = ()

    #: True when the rule changes weights during a run with plasticity on.
    plastic = False

    def __post_init__(self) -> None:
        owner = type(self).__name__
        object.__setattr__(self, "weight", _check_value(owner, "weight", self.weight, allow_none=False))  # type: ignore[attr-defined]
        delay = _check_value(owner, "delay", self.delay, allow_none=True)  # type: ignore[attr-defined]
        if isinstance(delay, float) and delay < 0:
            raise ValidationError(f"{owner}.delay must be >= 0 ms, got {delay!r}.")
        if isinstance(delay, np.ndarray) and (delay.ndim == 4 or np.any(delay < 0)):
            raise ValidationError(f"{owner}.delay array must be 1-D or 2-D with every delay >= 0 ms.")
        object.__setattr__(self, "delay", delay)
        super().__post_init__()

    @property
    def weight_bounds(self) -> tuple[float, float] | None:
        """``(w_min, w_max)`` the rule keeps weights within, or ``None`` for static synapses."""
        return None


@dataclass(**_KW)
class StaticSynapse(Synapse):
    """A fixed-weight synapse."""

    weight: Any = 0.0
    delay: Any = None


@dataclass(**_FIRST_POSITIONAL)
class SpikePairRule(IRNode):
    """All-to-all spike-pair timing dependence with exponential windows.

    ``dw+ = A_plus * F+(w) * exp(-dt / tau_plus)`` for pre-before-post,
    ``dw- = A_minus * F-(w) * exp(dt / tau_minus)`` for post-before-pre, computed
    with one trace per synapse (pre) and per neuron (post), each incremented by 1.
    """

    tau_plus: float = param(20.0, unit="ms", low=0.0, low_open=True)
    _: KW_ONLY
    tau_minus: float = param(20.0, unit="ms", low=0.0, low_open=True)
    A_plus: float = param(0.01, low=0.0)
    A_minus: float = param(0.01, low=0.0)


@dataclass(**_FIRST_POSITIONAL)
class AdditiveWeightDependence(IRNode):
    """``F+(w) = w_max``, ``F-(w) = w_max`` (as PyNN, NEST and sPyNNaker), clipped to ``[w_min, w_max]``."""

    w_min: float = param(0.0)
    _: KW_ONLY
    w_max: float = param(1.0)

    def _validate(self) -> None:
        if not self.w_max >= self.w_min:
            raise ValidationError(f"{type(self).__name__}.w_max ({self.w_max!r}) must be >= w_min ({self.w_min!r}).")


@dataclass(**_FIRST_POSITIONAL)
class MultiplicativeWeightDependence(AdditiveWeightDependence):
    """``F+(w) = w_max - w``, ``F-(w) = w - w_min`` (soft bounds)."""


@dataclass(**_FIRST_POSITIONAL)
class STDPMechanism(Synapse):
    """PyNN's ``STDPMechanism``: a timing dependence and a weight dependence."""

    plastic = True

    timing_dependence: SpikePairRule = field(default_factory=SpikePairRule)
    _: KW_ONLY
    weight_dependence: AdditiveWeightDependence = field(default_factory=AdditiveWeightDependence)
    weight: Any = 0.0
    delay: Any = None

    def _validate(self) -> None:
        if not isinstance(self.timing_dependence, SpikePairRule):
            raise ValidationError(
                f"STDPMechanism.timing_dependence must be a SpikePairRule, got {type(self.timing_dependence).__name__}."
            )
        if not isinstance(self.weight_dependence, AdditiveWeightDependence):
            raise ValidationError(
                "STDPMechanism.weight_dependence must be an Additive- or MultiplicativeWeightDependence, "
                f"got {type(self.weight_dependence).__name__}."
            )
        _check_initial_weight(self, *self.weight_bounds)

    @property
    def weight_bounds(self) -> tuple[float, float]:
        return (self.weight_dependence.w_min, self.weight_dependence.w_max)


@dataclass(**_KW)
class DiehlCookSTDP(Synapse):
    """The learning rule of Diehl & Cook (2015) as used by the Modular SNN.

    Traces are *set* to 1 at a spike (nearest-spike interaction, as in Diehl &
    Cook's code) and decay exponentially. On a presynaptic spike arriving at the
    synapse: ``w -= eta_pre * x_post`` (``pre_term="depress"``, Diehl & Cook's rule)
    or ``w += eta_pre * x_post`` (``pre_term="potentiate"``, the Modular SNN authors'
    code, QVPR/VPRSNN ``non_modular_snn/snn_model.py``), then ``x_pre = 1``. On a
    postsynaptic spike: ``w += eta_post * (x_pre - x_tar) * (w_max - w) ** mu * y``,
    then ``x_post = 1``, where ``y = 1`` (the paper's equation) or, when ``tau_post2``
    is given, the value of a second postsynaptic trace just before this spike (the
    triplet form of Diehl & Cook's published code, used with ``mu = 0``). Weights
    stay within ``[0, w_max]``.
    """

    plastic = True

    weight: Any = 0.0
    delay: Any = None
    eta_pre: float = param(1e-4, low=0.0)
    eta_post: float = param(1e-2, low=0.0)
    x_tar: float = param(0.0, low=0.0, doc="target presynaptic trace at a postsynaptic spike")
    w_max: float = param(1.0, low=0.0, low_open=True)
    mu: float = param(1.0, low=0.0)
    tau_pre: float = param(20.0, unit="ms", low=0.0, low_open=True)
    tau_post: float = param(20.0, unit="ms", low=0.0, low_open=True)
    tau_post2: float | None = None
    pre_term: str = "depress"

    def _validate(self) -> None:
        if self.pre_term not in PRE_TERMS:
            raise ValidationError(
                f"DiehlCookSTDP.pre_term must be one of {', '.join(map(repr, PRE_TERMS))}, got {self.pre_term!r}."
            )
        if self.tau_post2 is not None:
            t2 = self.tau_post2
            if isinstance(t2, bool) or not isinstance(t2, (int, float, np.integer, np.floating)) or not t2 > 0:
                raise ValidationError(f"DiehlCookSTDP.tau_post2 must be None or > 0 ms, got {t2!r}.")
            object.__setattr__(self, "tau_post2", float(t2))
        _check_initial_weight(self, 0.0, self.w_max)

    @property
    def weight_bounds(self) -> tuple[float, float]:
        return (0.0, self.w_max)


def _check_initial_weight(syn: Synapse, w_min: float, w_max: float) -> None:
    weight = syn.weight  # type: ignore[attr-defined]
    if isinstance(weight, (float, np.ndarray)):
        arr = np.asarray(weight)
        if arr.min() < w_min or arr.max() > w_max:
            raise ValidationError(
                f"{type(syn).__name__}.weight must lie in [{w_min}, {w_max}], "
                f"got values in [{arr.min()!r}, {arr.max()!r}]."
            )


SYNAPSE_TYPES: dict[str, type[IRNode]] = {
    c.__name__: c
    for c in (
        StaticSynapse,
        STDPMechanism,
        DiehlCookSTDP,
        SpikePairRule,
        AdditiveWeightDependence,
        MultiplicativeWeightDependence,
    )
}
