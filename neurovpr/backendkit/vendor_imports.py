"""Importing one subpackage of a vendor package whose own ``__init__`` cannot run here.

SynSense's packages import their chip-configuration library ``samna`` in package
``__init__`` files that also import the parts neurovpr uses: ``rockpool.devices.xylo``
imports its Xylo Audio 3 subpackage, which imports ``samna`` unguarded, and
``sinabs.backend.dynapcnn`` imports ``DynapcnnNetwork`` and the chip configuration
builder, which import ``samna`` at module top. ``samna`` is not on the package index
(its PyPI releases are stubs that try to download the real package at import time), so
those ``__init__`` files fail, while the subpackages neurovpr needs (Rockpool's Xylo
Audio 2 mapper and XyloSim, Sinabs's layer-to-core mapping) import nothing from
``samna``.

:func:`import_without_parent_init` imports such a subpackage with its parent package
present in ``sys.modules`` as a bare package (its ``__path__`` only, its ``__init__``
not executed). The bare entry stays after the import, because the vendor's modules
import their siblings lazily, inside functions; a later ``import`` of the parent in the
same process then gives the bare package (with the subpackages imported so far) instead
of the ``samna`` error. Only the named parent is affected, and only when its own
``__init__`` has not run. Nothing in the vendor's files is changed.
"""

from __future__ import annotations

import importlib
import importlib.util
import sys
from pathlib import Path
from types import ModuleType

from neurovpr.errors import BackendUnavailableError

__all__ = ["import_without_parent_init"]


def import_without_parent_init(parent: str, modules: tuple[str, ...], *, hint: str) -> dict[str, ModuleType]:
    """Import ``parent.<m>`` for each ``m`` in ``modules`` without running ``parent/__init__.py``.

    Parameters
    ----------
    parent
        The dotted name of the package whose ``__init__`` is skipped (``"rockpool.devices.xylo"``).
        Its own parent packages are imported normally.
    modules
        Dotted names relative to ``parent`` (``"syns61201.xylo_mapper"``).
    hint
        What to install when the vendor package is missing (ends the error message).

    Returns
    -------
    dict
        Relative name -> imported module.

    Raises
    ------
    BackendUnavailableError
        If the parent package is not installed or a module fails to import (the message
        names the module and the error).
    """
    already = sys.modules.get(parent)
    grand, _, leaf = parent.rpartition(".")
    try:
        grand_mod = importlib.import_module(grand) if grand else None
        spec = importlib.util.find_spec(parent) if grand_mod is not None else None
    except Exception as exc:
        raise BackendUnavailableError(f"Cannot import {grand or parent}: {type(exc).__name__}: {exc}; {hint}") from exc
    if spec is None or not spec.submodule_search_locations:
        raise BackendUnavailableError(f"Package {parent} is not installed; {hint}")
    bare = ModuleType(parent, f"{parent} (bare package: its __init__ was not run)")
    bare.__path__ = list(spec.submodule_search_locations)
    bare.__package__ = parent
    bare.__spec__ = spec
    out: dict[str, ModuleType] = {}
    # Only when the parent has not been imported: a real package already imported (its __init__ ran) is used as is.
    if already is None:
        sys.modules[parent] = bare
        setattr(grand_mod, leaf, bare)
    for m in modules:
        try:
            out[m] = importlib.import_module(f"{parent}.{m}")
        except Exception as exc:
            where = Path(spec.submodule_search_locations[0]) / m.replace(".", "/")
            raise BackendUnavailableError(
                f"Cannot import {parent}.{m} ({where}) without its package __init__: "
                f"{type(exc).__name__}: {exc}; {hint}"
            ) from exc
    return out
