"""Importing Rockpool's Xylo Audio 2 (SYNS61201) support without ``samna``.

``import rockpool.devices.xylo`` fails here: that package's ``__init__`` imports the Xylo
Audio 3 subpackage (``syns65302``), whose ``afe_samna_pdm.py`` imports ``samna``, SynSense's
chip-configuration library, which cannot be installed from the package index (its PyPI
releases are download stubs). The Xylo Audio 2 subpackage ``syns61201`` itself needs no
``samna`` for what neurovpr uses: the mapper with its design-rule checks
(``xylo_mapper.py``) and XyloSim (``xylo_sim.py``, backed by the C++ bit-accurate
simulator ``xylosim.v2``). :func:`import_xylo` imports those through
:func:`neurovpr.backendkit.vendor_imports.import_without_parent_init`, which skips the
``rockpool.devices.xylo`` package ``__init__``; a failure is reported with the module
and the error.

What needs ``samna`` and therefore cannot run here: ``config_from_specification`` and
``XyloSim.from_config`` (``XyloConfiguration`` is a samna type, and its validation is
samna's), and the hardware itself (``XyloSamna``).
"""

from __future__ import annotations

from types import SimpleNamespace

from neurovpr.backendkit.vendor_imports import import_without_parent_init

__all__ = ["ROCKPOOL_VERSION", "XYLOSIM_VERSION", "INSTALL_HINT", "import_xylo"]

#: The Rockpool release the checks and the backend are written and tested for.
ROCKPOOL_VERSION = "3.1.0"
#: The XyloSim release (C++ extension, built from source at install).
XYLOSIM_VERSION = "0.1.3"
INSTALL_HINT = "install it with `pip install -e \".[synsense]\"` (or `bash scripts/install_synsense.sh`)."


def import_xylo() -> SimpleNamespace:
    """Rockpool's Xylo Audio 2 modules: ``mapper`` (xylo_mapper), ``sim`` (xylo_sim), ``graph``, ``nn``.

    Raises
    ------
    neurovpr.errors.BackendUnavailableError
        If Rockpool or XyloSim is missing, or a module fails to import.
    """
    mods = import_without_parent_init(
        "rockpool.devices.xylo", ("syns61201.xylo_mapper", "syns61201.xylo_sim"), hint=INSTALL_HINT
    )
    import rockpool.graph as graph
    import rockpool.nn.combinators as combinators
    import rockpool.nn.modules as modules

    return SimpleNamespace(
        mapper=mods["syns61201.xylo_mapper"], sim=mods["syns61201.xylo_sim"], graph=graph, modules=modules,
        combinators=combinators,
    )
