"""What a partition is: populations cut into per-core slices, and the limits they break.

These types are shared by every architecture's partitioner (:mod:`.loihi`,
:mod:`.spinnaker`, ...) and by :mod:`.partition`, which dispatches to them, so they sit
below both.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from neurovpr.ir.connectivity import Connections, expand
from neurovpr.ir.network import Network, Projection

if TYPE_CHECKING:
    from .hwspec import HwSpec

__all__ = ["CoreSlice", "Violation", "Partition", "expand_on_chip"]

_KW = {"frozen": True, "slots": True, "kw_only": True}


@dataclass(**_KW)
class CoreSlice:
    """The neurons of one population that one core holds, and what they use there.

    Attributes
    ----------
    population : str
        Population name (a delay-extension core is labelled ``"<pre>:delays"``).
    lo, hi : int
        The slice ``[lo, hi)`` of the population's neurons.
    kind : str
        ``"neurons"``, ``"sources"`` (spike sources on a core) or ``"delays"``.
    chip : int
        Index of the chip the core is on (0-based, in placement order).
    location : tuple of int or None
        ``(x, y, p)`` of the core where the target has coordinates (SpiNNaker).
    usage : dict
        Resource name -> amount used on this core (``neurons``, ``input_axons``,
        ``output_axons``, ``synapse_bits``, ``synaptic_matrix_bytes``).
    limits : dict
        Resource name -> per-core maximum (resources without a per-core limit are absent).
    """

    population: str
    lo: int
    hi: int
    kind: str
    chip: int = 0
    location: tuple[int, ...] | None = None
    usage: dict[str, int] = field(default_factory=dict)
    limits: dict[str, int] = field(default_factory=dict)

    @property
    def neurons(self) -> int:
        """Neurons on this core."""
        return self.hi - self.lo

    def utilisation(self) -> dict[str, float]:
        """Fraction of each per-core limit used."""
        return {k: self.usage.get(k, 0) / v for k, v in self.limits.items() if v > 0}

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready description."""
        out: dict[str, Any] = {
            "population": self.population,
            "lo_atom": self.lo,
            "hi_atom": self.hi - 1,
            "kind": self.kind,
            "chip": self.chip,
            "usage": dict(self.usage),
            "utilisation": {k: round(v, 6) for k, v in self.utilisation().items()},
        }
        if self.location is not None:
            out["location"] = list(self.location)
        return out


@dataclass(**_KW)
class Violation:
    """One broken limit: what, where, how much, and the limit.

    ``message`` is one sentence naming the object, the quantity and the limit.
    """

    limit: str
    where: str
    value: float
    maximum: float
    message: str

    @property
    def excess(self) -> float:
        """By how much the value exceeds the limit."""
        return self.value - self.maximum

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready description."""
        return {
            "limit": self.limit,
            "where": self.where,
            "value": self.value,
            "maximum": self.maximum,
            "excess": self.excess,
            "message": self.message,
        }


@dataclass(**_KW)
class Partition:
    """The result of splitting a network onto one hardware target.

    Attributes
    ----------
    hardware : str
        The hwspec name.
    cores : tuple of CoreSlice
        Every core the network occupies, in placement order.
    chips : int
        Chips needed (or used, for a placed SpiNNaker network).
    violations : tuple of Violation
        Every limit broken.
    host : tuple of str
        Populations served from the host rather than from a core (Loihi spike sources).
    notes : tuple of str
        Modelling choices worth knowing when reading the numbers.
    """

    hardware: str
    cores: tuple[CoreSlice, ...]
    chips: int
    violations: tuple[Violation, ...]
    host: tuple[str, ...] = ()
    notes: tuple[str, ...] = ()

    @property
    def fits(self) -> bool:
        """True when no limit is broken."""
        return not self.violations

    def cores_of(self, population: str) -> list[CoreSlice]:
        """The cores holding ``population`` (delay-extension cores excluded)."""
        return [c for c in self.cores if c.population == population]


def expand_on_chip(network: Network, proj: Projection, spec: HwSpec, seed: int) -> Connections:
    """Expand a projection with the hardware time step (``None`` delays become one step).

    Delays shorter than the hardware step are kept as given (the chips round them up to
    one step, see :func:`neurovpr.backendkit.timing.delay_steps`) instead of being refused as :func:`expand` would.
    """
    step = spec.timing.time_step_ms
    tiny = step * 1e-6
    conns = expand(network, proj, dt=tiny, seed=seed)
    delay = np.where(conns.delay <= tiny * (1 + 1e-9), step, conns.delay)
    return Connections(pre=conns.pre, post=conns.post, weight=conns.weight, delay=delay)
