"""Plugins found by entry points: one loader for backends, models and hardware architectures.

Every kind of plugin (``neurovpr.backends``, ``neurovpr.models``,
``neurovpr.architectures``) is looked up the same way: the entry points of the group,
the first one per name in name order, loaded on demand and checked to be of the
expected type, with a one-sentence error naming the plugin when it is unknown, fails to
import, or is of the wrong type. Each caller keeps its own error types.
"""

from __future__ import annotations

import importlib.metadata
from typing import Any

from neurovpr.errors import NeurovprError

__all__ = ["declared", "declared_names", "load_declared"]


def declared(group: str) -> dict[str, importlib.metadata.EntryPoint]:
    """The entry points of ``group`` by name (the first one of each name, in name order); nothing is loaded."""
    found: dict[str, importlib.metadata.EntryPoint] = {}
    for ep in sorted(importlib.metadata.entry_points(group=group), key=lambda ep: ep.name):
        found.setdefault(ep.name, ep)
    return found


def declared_names(group: str) -> list[str]:
    """Names declared in ``group``, sorted (nothing is loaded)."""
    return list(declared(group))


def load_declared(
    group: str,
    name: str,
    kind: type,
    *,
    what: str,
    unknown: type[NeurovprError],
    broken: type[NeurovprError],
) -> Any:
    """Load the plugin ``name`` of ``group`` and check that it is a ``kind``.

    Parameters
    ----------
    group
        The entry-point group (``"neurovpr.backends"``...).
    name
        The plugin's name.
    kind
        The type the entry point must load.
    what
        The plugin's kind in words, for messages (``"backend"``, ``"model"``).
    unknown, broken
        The error raised when no plugin has that name (the message lists the known
        ones), and when it fails to import or loads something that is not a ``kind``.
    """
    points = declared(group)
    if not isinstance(name, str) or name not in points:
        known = ", ".join(points) or "none (is neurovpr installed?)"
        raise unknown(f"Unknown {what} {name!r}; known {what}s: {known}.")
    try:
        plugin = points[name].load()
    except Exception as exc:
        raise broken(f"{what.capitalize()} {name!r} failed to load: {type(exc).__name__}: {exc}.") from exc
    if not isinstance(plugin, kind):
        raise broken(
            f"{what.capitalize()} {name!r} (entry point {points[name].value}) is a {type(plugin).__name__}, "
            f"not a neurovpr {kind.__name__}."
        )
    return plugin
