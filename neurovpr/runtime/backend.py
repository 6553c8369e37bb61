"""What a backend is: its capability declaration and the interface the registry calls.

A backend package exposes one :class:`Backend` instance through the
``neurovpr.backends`` entry point. The instance is cheap to import (it names its
simulator but does not import it); :meth:`Backend.compile` imports the simulator.
Building blocks for both live in :mod:`neurovpr.backendkit`.
"""

from __future__ import annotations

import importlib
import importlib.metadata
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import TYPE_CHECKING, Any, Mapping

from neurovpr.errors import BackendUnavailableError, UnsupportedFeatureError, ValidationError
from neurovpr.ir.cells import euler_integrated

if TYPE_CHECKING:
    from neurovpr.hardware.check import HardwareTarget
    from neurovpr.ir.network import Network
    from neurovpr.runtime.simulation import Simulation

__all__ = [
    "Capabilities", "Backend", "ToleranceOverride", "ZERO_DELAY", "EULER_INTEGRATION", "capability_problems",
    "unsupported_error",
]  # fmt: skip

#: The feature name of a zero-delay synapse in refusals and in ``Capabilities.reasons``.
ZERO_DELAY = "zero delay"
#: The feature name of a conductance-based cell with ``integration="euler"`` in refusals and ``Capabilities.reasons``.
EULER_INTEGRATION = "euler integration"


def unsupported_error(backend: str, problems: list[str]) -> UnsupportedFeatureError | None:
    """The refusal naming the first of ``problems`` and how many more there are (``None`` when empty)."""
    if not problems:
        return None
    more = f" (and {len(problems) - 1} more)" if len(problems) > 1 else ""
    return UnsupportedFeatureError(f"Backend {backend!r} cannot run {problems[0]}{more}.")


def capability_problems(capabilities: Capabilities, network: Network) -> list[str]:
    """Every IR type of ``network`` missing from ``capabilities``, each with its reason when one is declared."""
    problems: list[str] = []

    def refuse(kind: str, what: str, where: str) -> None:
        reason = capabilities.reasons.get(what)
        problems.append(f"{kind} {what} ({where})" + (f": {reason}" if reason else ""))

    for pop in network.populations.values():
        kind = type(pop.cell_type).__name__
        if kind not in capabilities.cell_types:
            refuse("cell type", kind, f"population {pop.name!r}")
        elif euler_integrated(pop.cell_type) and not capabilities.euler_integration:
            reason = capabilities.reasons.get(EULER_INTEGRATION)
            problems.append(
                f"forward-Euler integration ({kind}(integration='euler'), population {pop.name!r})"
                + (f": {reason}" if reason else "")
            )
    for proj in network.projections.values():
        conn = type(proj.connector).__name__
        syn = type(proj.synapse).__name__
        if conn not in capabilities.connectors:
            refuse("connector", conn, f"projection {proj.name!r}")
        if syn not in capabilities.synapses:
            refuse("synapse", syn, f"projection {proj.name!r}")
        if not capabilities.zero_delays and proj.zero_delay:
            reason = capabilities.reasons.get(ZERO_DELAY)
            problems.append(f"a zero delay (projection {proj.name!r})" + (f": {reason}" if reason else ""))
    return problems


@dataclass(frozen=True, slots=True, kw_only=True)
class ToleranceOverride:
    """Looser conformance bounds for one case, and why the backend needs them.

    Attributes
    ----------
    changes
        Bound name -> value (the fields of ``neurovpr.conformance.tolerances.Tolerances``).
    reason
        Why the backend's numerics legitimately differ there.
    """

    changes: Mapping[str, float] = field(default_factory=dict)
    reason: str = ""


@dataclass(frozen=True, slots=True, kw_only=True)
class Capabilities:
    """What a backend can run.

    Attributes
    ----------
    cell_types, connectors, synapses
        Names of the IR types it compiles.
    learns
        Whether plastic synapses learn on-line.
    runs
        Whether ``Simulation.run`` produces activity (``False`` for mapping-only targets).
    run_refusal
        The sentence ``run`` raises when ``runs`` is false.
    heterogeneous_delays
        Whether delays may differ between the synapses of one projection.
    zero_delays
        Whether it runs zero-delay synapses (``delay=0``; docs/semantics.md); a backend
        without them refuses such a projection, with ``reasons["zero delay"]`` when given.
    euler_integration
        Whether it runs conductance-based cells with ``integration="euler"`` (forward-Euler
        steps, docs/semantics.md); a backend without refuses them, with
        ``reasons["euler integration"]`` when given.
    arithmetic
        The chip arithmetics it computes in with ``hardware=``: values of a hwspec's
        ``[formats].arithmetic`` (``"loihi1"``, ``"loihi2"``, ``"spinnaker"``).
    recordables
        State variables it can record.
    reasons
        IR type name -> why the backend cannot run it (added to the refusal).
    unsupported
        Conformance cases it cannot run, each with the reason.
    tolerances
        Conformance cases whose bounds it loosens, each with the reason.
    """

    cell_types: frozenset[str]
    connectors: frozenset[str]
    synapses: frozenset[str]
    learns: bool
    runs: bool = True
    run_refusal: str = ""
    heterogeneous_delays: bool = True
    zero_delays: bool = False
    euler_integration: bool = False
    arithmetic: frozenset[str] = frozenset()
    recordables: frozenset[str] = frozenset({"v"})
    reasons: Mapping[str, str] = field(default_factory=lambda: MappingProxyType({}))
    unsupported: Mapping[str, str] = field(default_factory=lambda: MappingProxyType({}))
    tolerances: Mapping[str, ToleranceOverride] = field(default_factory=lambda: MappingProxyType({}))

    def as_dict(self) -> dict[str, Any]:
        """A JSON-ready description."""
        return {
            "cell_types": sorted(self.cell_types),
            "connectors": sorted(self.connectors),
            "synapses": sorted(self.synapses),
            "learns": self.learns,
            "runs": self.runs,
            "run_refusal": self.run_refusal or None,
            "heterogeneous_delays": self.heterogeneous_delays,
            "zero_delays": self.zero_delays,
            "euler_integration": self.euler_integration,
            "arithmetic": sorted(self.arithmetic),
            "recordables": sorted(self.recordables),
            "reasons": dict(self.reasons),
            "unsupported": dict(self.unsupported),
            "tolerances": {case: {"changes": dict(o.changes), "reason": o.reason} for case, o in self.tolerances.items()},
        }


class Backend:
    """Base class of a backend declaration.

    Subclasses set the class attributes and implement :meth:`_compile`; they may add
    refusals that depend on parameter values in :meth:`network_problems`.
    """

    #: The name used with ``backend=`` and ``--backend``.
    name: str = ""
    #: One line describing what runs.
    description: str = ""
    #: Import names of the simulator packages it needs.
    requires: tuple[str, ...] = ()
    #: The distribution whose version is reported.
    version_of: str = "neurovpr"
    #: The optional-dependency extra that installs it (``pip install neurovpr[EXTRA]``).
    extra: str = ""
    capabilities: Capabilities
    #: Options ``compile`` accepts, with their defaults (passed to :meth:`_compile`).
    options: Mapping[str, Any] = MappingProxyType({})

    def unavailable_reason(self) -> str | None:
        """``None`` when the simulator imports, otherwise why not (with the extra to install)."""
        for module in self.requires:
            try:
                importlib.import_module(module)
            except Exception as exc:
                hint = f"; install it with: pip install 'neurovpr[{self.extra}]'" if self.extra else ""
                return f"cannot import {module} ({type(exc).__name__}: {exc}){hint}"
        return None

    def version(self) -> str | None:
        """Version of the simulator package, or ``None`` if not installed."""
        try:
            return importlib.metadata.version(self.version_of)
        except importlib.metadata.PackageNotFoundError:
            return None

    def unsupported_features(self, network: Network) -> list[str]:
        """Describe every feature of ``network`` this backend cannot compile.

        First the IR types missing from the capability table (:func:`capability_problems`);
        when every type is supported, :meth:`network_problems`.
        """
        return capability_problems(self.capabilities, network) or self.network_problems(network)

    def network_problems(self, network: Network) -> list[str]:
        """Parameter values of ``network`` the backend cannot express (its types are all supported).

        Each entry names the feature, the object and the value; none by default.
        """
        return []

    def check_network(self, network: Network) -> None:
        """Raise :class:`UnsupportedFeatureError` naming the first unsupported feature."""
        error = unsupported_error(self.name, self.unsupported_features(network))
        if error is not None:
            raise error

    def compile(
        self,
        network: Network,
        *,
        dt: float,
        seed: int,
        hardware: HardwareTarget | None = None,
        **options: Any,
    ) -> Simulation:
        """Check availability, features and options, then build a :class:`~neurovpr.runtime.simulation.Simulation`.

        ``hardware`` is the target ``nv.compile(..., hardware=...)`` made: the hwspec and
        the one partition of ``network`` on it (already known to fit).
        """
        reason = self.unavailable_reason()
        if reason is not None:
            raise BackendUnavailableError(f"Backend {self.name!r} is not available: {reason}.")
        self.check_network(network)
        if hardware is not None:
            arithmetic = hardware.spec.formats.arithmetic
            if arithmetic not in self.capabilities.arithmetic:
                supported = ", ".join(sorted(self.capabilities.arithmetic)) or "none"
                kind = f"the {arithmetic} arithmetic" if arithmetic else "an arithmetic ([formats].arithmetic is not set)"
                raise UnsupportedFeatureError(
                    f"Backend {self.name!r} cannot emulate hardware {hardware.name!r}: its hwspec declares {kind}, "
                    f"the backend computes in: {supported}."
                )
        unknown = sorted(set(options) - set(self.options))
        if unknown:
            known = ", ".join(sorted(self.options)) or "none"
            raise ValidationError(f"Backend {self.name!r} has no option {unknown[0]!r} (options: {known}).")
        return self._compile(network, dt=dt, seed=seed, hardware=hardware, **{**self.options, **options})

    def _compile(
        self, network: Network, *, dt: float, seed: int, hardware: HardwareTarget | None, **options: Any
    ) -> Simulation:
        raise NotImplementedError
