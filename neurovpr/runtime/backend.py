"""What a backend is: its capability declaration and the interface the registry calls.

A backend package exposes one :class:`Backend` instance through the
``neurovpr.backends`` entry point. The instance is cheap to import (it names its
simulator but does not import it); :meth:`Backend.compile` imports the simulator.
"""

from __future__ import annotations

import importlib
import importlib.metadata
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import TYPE_CHECKING, Any, Mapping

from neurovpr.errors import BackendUnavailableError, UnsupportedFeatureError

if TYPE_CHECKING:
    from neurovpr.ir.network import Network
    from neurovpr.runtime.simulation import Simulation

__all__ = ["Capabilities", "Backend"]


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
    hardware
        Names of hwspecs whose number formats the backend can emulate.
    recordables
        State variables it can record.
    unsupported
        Conformance cases it cannot run, each with the reason.
    """

    cell_types: frozenset[str]
    connectors: frozenset[str]
    synapses: frozenset[str]
    learns: bool
    runs: bool = True
    run_refusal: str = ""
    heterogeneous_delays: bool = True
    hardware: frozenset[str] = frozenset()
    recordables: frozenset[str] = frozenset({"v"})
    unsupported: Mapping[str, str] = field(default_factory=lambda: MappingProxyType({}))

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
            "hardware": sorted(self.hardware),
            "recordables": sorted(self.recordables),
            "unsupported": dict(self.unsupported),
        }


class Backend:
    """Base class of a backend declaration.

    Subclasses set the class attributes and implement :meth:`_compile`.
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
        """Describe every feature of ``network`` this backend cannot compile."""
        caps = self.capabilities
        problems: list[str] = []
        for pop in network.populations.values():
            kind = type(pop.cell_type).__name__
            if kind not in caps.cell_types:
                problems.append(f"cell type {kind} (population {pop.name!r})")
        for proj in network.projections.values():
            conn = type(proj.connector).__name__
            syn = type(proj.synapse).__name__
            if conn not in caps.connectors:
                problems.append(f"connector {conn} (projection {proj.name!r})")
            if syn not in caps.synapses:
                problems.append(f"synapse {syn} (projection {proj.name!r})")
        return problems

    def check_network(self, network: Network) -> None:
        """Raise :class:`UnsupportedFeatureError` naming the first unsupported feature."""
        problems = self.unsupported_features(network)
        if problems:
            more = f" (and {len(problems) - 1} more)" if len(problems) > 1 else ""
            raise UnsupportedFeatureError(f"Backend {self.name!r} cannot run {problems[0]}{more}.")

    def compile(
        self,
        network: Network,
        *,
        dt: float,
        seed: int,
        hardware: Any = None,
        **options: Any,
    ) -> Simulation:
        """Check availability and features, then build a :class:`~neurovpr.runtime.simulation.Simulation`."""
        reason = self.unavailable_reason()
        if reason is not None:
            raise BackendUnavailableError(f"Backend {self.name!r} is not available: {reason}.")
        self.check_network(network)
        if hardware is not None and hardware.name not in self.capabilities.hardware:
            supported = ", ".join(sorted(self.capabilities.hardware)) or "none"
            raise UnsupportedFeatureError(
                f"Backend {self.name!r} cannot emulate hardware {hardware.name!r} (it emulates: {supported})."
            )
        return self._compile(network, dt=dt, seed=seed, hardware=hardware, **options)

    def _compile(self, network: Network, *, dt: float, seed: int, hardware: Any, **options: Any) -> Simulation:
        raise NotImplementedError
