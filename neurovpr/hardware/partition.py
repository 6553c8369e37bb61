"""What a partition is: populations cut into per-core slices, and the limits they break.

:func:`partition` dispatches to the vendor rules named by the hwspec
(:mod:`neurovpr.hardware.loihi` for NengoLoihi's block splitting,
:mod:`neurovpr.hardware.spinnaker` for sPyNNaker's slicing and PACMAN's placement) and
adds the checks common to every target: neuron models, plasticity rules, connectors
and delays the chip cannot host are reported as :class:`Violation` objects, never raised.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from neurovpr.ir.connectivity import Connections, expand
from neurovpr.ir.network import Network, Projection

from .hwspec import HwSpec

__all__ = ["CoreSlice", "Violation", "Partition", "partition", "feature_violations", "expand_on_chip"]

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


def delay_steps(conns: Connections, time_step_ms: float) -> np.ndarray:
    """Delays of ``conns`` in whole hardware time steps (at least 1, rounded to nearest)."""
    return np.maximum(1, np.rint(conns.delay / time_step_ms)).astype(np.int64)


def expand_on_chip(network: Network, proj: Projection, spec: HwSpec, seed: int) -> Connections:
    """Expand a projection with the hardware time step (``None`` delays become one step).

    Delays shorter than the hardware step are kept as given (the chips round them up to
    one step, see :func:`delay_steps`) instead of being refused as :func:`expand` would.
    """
    step = spec.timing.time_step_ms
    tiny = step * 1e-6
    conns = expand(network, proj, dt=tiny, seed=seed)
    delay = np.where(conns.delay <= tiny * (1 + 1e-9), step, conns.delay)
    return Connections(pre=conns.pre, post=conns.post, weight=conns.weight, delay=delay)


def _max_delay_ms(proj: Projection, network: Network, spec: HwSpec, seed: int) -> float:
    """The longest delay of a projection in ms, expanding it only when the spec is random."""
    from neurovpr.ir.connectors import FromListConnector

    delay = proj.synapse.delay
    listed = isinstance(proj.connector, FromListConnector) and proj.connector.conn_list.shape[1] == 4
    if not listed:
        if delay is None:
            return spec.timing.time_step_ms
        if isinstance(delay, float):
            return delay
        if isinstance(delay, np.ndarray):
            return float(delay.max())
    conns = expand_on_chip(network, proj, spec, seed)
    return float(conns.delay.max()) if len(conns) else spec.timing.time_step_ms


def feature_violations(network: Network, spec: HwSpec, seed: int = 0) -> list[Violation]:
    """Neuron models, plasticity rules, connectors and delays the target cannot host."""
    out: list[Violation] = []
    feats = spec.features
    for pop in network.populations.values():
        model = type(pop.cell_type).__name__
        if not pop.is_source and model not in feats.neuron_models:
            out.append(
                Violation(
                    limit="neuron model",
                    where=pop.name,
                    value=1,
                    maximum=0,
                    message=(
                        f"Population {pop.name!r}: neuron model {model} is not available on {spec.name} "
                        f"(it hosts {', '.join(feats.neuron_models) or 'none'})."
                    ),
                )
            )
    for proj in network.projections.values():
        rule = type(proj.synapse).__name__
        if proj.plastic and rule not in feats.plasticity:
            out.append(
                Violation(
                    limit="plasticity rule",
                    where=proj.name,
                    value=1,
                    maximum=0,
                    message=(
                        f"Projection {proj.name!r}: plasticity rule {rule} is not available on {spec.name} "
                        f"(it runs {', '.join(feats.plasticity) or 'none'})."
                    ),
                )
            )
        conn = type(proj.connector).__name__
        if conn not in feats.connectors:
            out.append(
                Violation(
                    limit="connector",
                    where=proj.name,
                    value=1,
                    maximum=0,
                    message=f"Projection {proj.name!r}: connector {conn} cannot be mapped to {spec.name}.",
                )
            )
        steps = math.floor(_max_delay_ms(proj, network, spec, seed) / spec.timing.time_step_ms + 0.5)
        if steps > spec.timing.max_delay_steps:
            out.append(
                Violation(
                    limit="delay",
                    where=proj.name,
                    value=steps,
                    maximum=spec.timing.max_delay_steps,
                    message=(
                        f"Projection {proj.name!r}: delay of {steps} steps exceeds the maximum of "
                        f"{spec.timing.max_delay_steps} steps on {spec.name} (step {spec.timing.time_step_ms:g} ms)."
                    ),
                )
            )
    return out


def partition(network: Network, spec: HwSpec, *, seed: int = 0) -> Partition:
    """Split ``network`` onto the target described by ``spec``.

    Parameters
    ----------
    network
        The network to place.
    spec
        The hardware target.
    seed
        Seed for random connectors without their own seed (as in ``nv.compile``).

    Returns
    -------
    Partition
        Per-core slices, the chip count and every violated limit.
    """
    notes: tuple[str, ...] = ()
    if spec.partitioner == "loihi":
        from .loihi import partition_loihi

        result = partition_loihi(network, spec, seed=seed)
    else:
        from .spinnaker import partition_spinnaker, spynnaker_timing

        asked = spec.timing.time_step_ms
        spec = spynnaker_timing(spec)  # sPyNNaker's whole-microsecond step, for its rules and the delays below
        result = partition_spinnaker(network, spec, seed=seed)
        if spec.timing.time_step_ms != asked:
            notes = (f"sPyNNaker runs whole microseconds: the {asked:g} ms step runs as {spec.timing.time_step_ms:g} ms.",)
    # The vendor rules bound delays exactly per projection where they can (SpiNNaker):
    # keep only one delay violation per projection.
    exact = {v.where for v in result.violations if v.limit == "delay"}
    extra = [v for v in feature_violations(network, spec, seed) if not (v.limit == "delay" and v.where in exact)]
    return Partition(
        hardware=result.hardware,
        cores=result.cores,
        chips=result.chips,
        violations=tuple(extra) + result.violations,
        host=result.host,
        notes=notes + result.notes,
    )
