"""The backend registry: backends are found through the ``neurovpr.backends`` entry point.

Nothing in the core imports a backend module directly; a third-party package adds a
backend by declaring an entry point, without touching neurovpr.
"""

from __future__ import annotations

import importlib.metadata
from dataclasses import dataclass
from typing import Any

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


def _entry_points() -> list[importlib.metadata.EntryPoint]:
    return sorted(importlib.metadata.entry_points(group=ENTRY_POINT_GROUP), key=lambda ep: ep.name)


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
    return list(dict.fromkeys(ep.name for ep in _entry_points()))


def backend_info(name: str) -> BackendInfo:
    """Load the backend declared under ``name`` and report whether its simulator imports.

    Raises
    ------
    BackendUnavailableError
        If no backend has that name.
    """
    matches = [ep for ep in _entry_points() if ep.name == name]
    if not matches:
        known = ", ".join(declared_names()) or "none (is neurovpr installed?)"
        raise BackendUnavailableError(f"Unknown backend {name!r}; known backends: {known}.")
    return _info(matches[0])


def discover() -> dict[str, BackendInfo]:
    """Load every declared backend and report whether its simulator imports."""
    infos: dict[str, BackendInfo] = {}
    for ep in _entry_points():
        if ep.name not in infos:
            infos[ep.name] = _info(ep)
    return infos


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
    matches = [ep for ep in _entry_points() if ep.name == name]
    if not matches:
        known = ", ".join(declared_names()) or "none (is neurovpr installed?)"
        raise BackendUnavailableError(f"Unknown backend {name!r}; known backends: {known}.")
    try:
        backend = matches[0].load()
    except Exception as exc:
        raise BackendUnavailableError(f"Backend {name!r} failed to load: {type(exc).__name__}: {exc}.") from exc
    if not isinstance(backend, Backend):
        raise BackendUnavailableError(f"Backend {name!r} does not provide a neurovpr Backend.")
    return backend


def backend_infos() -> list[BackendInfo]:
    """All declared backends, sorted by name."""
    return list(discover().values())
