"""One backend under test, and the checks that make a case skip with an explicit reason."""

from __future__ import annotations

import functools
from collections.abc import Iterable
from dataclasses import dataclass

import pytest

import neurovpr as nv
from neurovpr.runtime.backend import Backend, Capabilities
from neurovpr.runtime.registry import BackendInfo, backend_info, declared_names

from .cases import CASES
from .tolerances import Tolerances, tolerances_for

__all__ = ["Target", "declared", "describe"]


@functools.cache
def declared() -> tuple[str, ...]:
    """Names of the declared backends (read once per test session)."""
    return tuple(declared_names())


@functools.cache
def describe(name: str) -> BackendInfo:
    """The registry's view of one declared backend (loaded once per test session)."""
    return backend_info(name)


@dataclass(frozen=True, slots=True)
class Target:
    """One backend under test."""

    name: str
    backend: Backend

    @property
    def capabilities(self) -> Capabilities:
        """What the backend declares it can run."""
        return self.backend.capabilities

    def tol(self, case: str) -> Tolerances:
        """The bounds this backend must meet in ``case`` (its declared overrides applied)."""
        return tolerances_for(self.capabilities, case)

    def require(
        self,
        case: str,
        network: nv.Network | None = None,
        *,
        recordables: Iterable[str] = (),
        heterogeneous_delays: bool = False,
    ) -> None:
        """Skip, naming the reason, unless the backend declares everything ``case`` needs."""
        assert case in CASES, f"unknown conformance case {case!r}"
        caps = self.capabilities
        if case in caps.unsupported:
            pytest.skip(f"{self.name} declares case {case!r} unsupported: {caps.unsupported[case]}")
        missing: list[str] = []
        if network is not None:
            missing += self.backend.unsupported_features(network)
            if not caps.learns and any(p.plastic for p in network.projections.values()):
                missing.append("on-line learning (plastic projections)")
        missing += [f"recording {var!r}" for var in recordables if var not in caps.recordables]
        if heterogeneous_delays and not caps.heterogeneous_delays:
            missing.append("heterogeneous delays within a projection")
        if missing:
            pytest.skip(f"{self.name} declares no support for: {'; '.join(missing)} (case {case!r})")

    def compile(
        self,
        network: nv.Network,
        *,
        case: str,
        dt: float,
        seed: int = 1,
        recordables: Iterable[str] = (),
        heterogeneous_delays: bool = False,
    ) -> nv.Simulation:
        """Compile ``network`` for this backend after checking it can run ``case``."""
        recordables = tuple(recordables)
        self.require(case, network, recordables=recordables, heterogeneous_delays=heterogeneous_delays)
        return nv.compile(network, backend=self.name, dt=dt, seed=seed)
