"""The backend registry: backends are found through the ``neurovpr.backends`` entry point.

Nothing in the core imports a backend module directly; a third-party package adds a
backend by declaring an entry point, without touching neurovpr.
"""

from __future__ import annotations

import importlib.metadata
from dataclasses import dataclass
from typing import Any

from neurovpr import entrypoints
from neurovpr.errors import BackendUnavailableError
from neurovpr.runtime.backend import Backend

__all__ = ["BackendInfo", "ENTRY_POINT_GROUP", "discover", "declared_names", "backend_info", "get_backend", "backend_infos"]

ENTRY_POINT_GROUP = "neurovpr.backends"


@dataclass(frozen=True, slots=True)
class BackendInfo:
    """One row of ``neurovpr backends``: a backend and whether it can be used here."""

    name: str
    available: bool
    version: str | None
    description: str
    reason: str | None
    backend: Backend | None

    def as_dict(self) -> dict[str, Any]:
        """A JSON-ready description."""
        caps = self.backend.capabilities.as_dict() if self.backend is not None else None
        return {
            "name": self.name,
            "available": self.available,
            "version": self.version,
            "description": self.description,
            "reason": self.reason,
            "extra": self.backend.extra if self.backend is not None else None,
            "capabilities": caps,
        }


def _info(ep: importlib.metadata.EntryPoint) -> BackendInfo:
    try:
        backend = ep.load()
    except Exception as exc:
        return BackendInfo(ep.name, False, None, "", f"entry point {ep.value} failed to load: {exc}", None)
    if not isinstance(backend, Backend):
        reason = f"entry point {ep.value} is a {type(backend).__name__}, not a neurovpr Backend"
        return BackendInfo(ep.name, False, None, "", reason, None)
    reason = backend.unavailable_reason()
    return BackendInfo(
        ep.name,
        reason is None,
        backend.version() if reason is None else None,
        backend.description,
        reason,
        backend,
    )


def declared_names() -> list[str]:
    """Names of every declared backend, sorted (nothing is loaded)."""
    return entrypoints.declared_names(ENTRY_POINT_GROUP)


def backend_info(name: str) -> BackendInfo:
    """Load the backend declared under ``name`` and report whether its simulator imports.

    Raises
    ------
    BackendUnavailableError
        If no backend has that name.
    """
    points = entrypoints.declared(ENTRY_POINT_GROUP)
    if name not in points:
        known = ", ".join(points) or "none (is neurovpr installed?)"
        raise BackendUnavailableError(f"Unknown backend {name!r}; known backends: {known}.")
    return _info(points[name])


def discover() -> dict[str, BackendInfo]:
    """Load every declared backend and report whether its simulator imports."""
    return {name: _info(ep) for name, ep in entrypoints.declared(ENTRY_POINT_GROUP).items()}


def get_backend(name: str) -> Backend:
    """The backend declared under ``name``.

    Raises
    ------
    BackendUnavailableError
        If no backend has that name (the message lists the known ones) or its
        entry point cannot be loaded.
    """
    if not isinstance(name, str):
        raise BackendUnavailableError(f"Backend name must be a string, got {name!r}.")
    return entrypoints.load_declared(
        ENTRY_POINT_GROUP, name, Backend, what="backend", unknown=BackendUnavailableError, broken=BackendUnavailableError
    )


def backend_infos() -> list[BackendInfo]:
    """All declared backends, sorted by name."""
    return list(discover().values())
