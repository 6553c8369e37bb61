"""Importing Sinabs's DYNAP-CNN / Speck mapping without ``samna``.

``import sinabs.backend.dynapcnn`` fails here: that package's ``__init__`` imports
``DynapcnnNetwork`` (``dynapcnn_network.py``), the chip configuration builder
(``config_builder.py``, ``chips/speck2f.py``) and ``specksim.py``, which import ``samna``,
SynSense's chip-configuration library, at module top; ``samna`` cannot be installed from
the package index (its PyPI releases are download stubs). The modules neurovpr uses need
no ``samna``: ``mapping.py`` (``LayerConstraints``, ``find_chip_layers``,
``get_valid_mapping``: the layer-to-core assignment by maximum flow over the per-core
kernel, neuron and bias memories), ``dynapcnn_layer.py`` (``DynapcnnLayer`` and its
``memory_summary``) and ``discretize.py``, with ``sinabs.layers``, Sinabs's own torch
simulation of spiking layers. :func:`import_dynapcnn` imports those through
:func:`neurovpr.backendkit.vendor_imports.import_without_parent_init`, which skips the
``sinabs.backend.dynapcnn`` package ``__init__``; a failure is reported with the module
and the error.

What needs ``samna`` and therefore cannot run here: ``DynapcnnNetwork`` (its
``make_config`` and chip configuration validation) and ``specksim``. The per-core memory
sizes Sinabs passes to ``get_valid_mapping`` are written in
``sinabs/backend/dynapcnn/chips/dynapcnn.py`` ``get_constraints`` (a module that imports
``samna``); neurovpr reads them from ``hwspecs/speck.toml``, which cites that file.
"""

from __future__ import annotations

from types import SimpleNamespace

from neurovpr.backendkit.vendor_imports import import_without_parent_init

__all__ = ["SINABS_VERSION", "INSTALL_HINT", "import_dynapcnn"]

#: The Sinabs release the checks are written and tested for (installed with --no-deps).
SINABS_VERSION = "3.1.3"
INSTALL_HINT = "install it with `bash scripts/install_synsense.sh` (sinabs is installed with --no-deps)."


def import_dynapcnn() -> SimpleNamespace:
    """Sinabs's samna-free DYNAP-CNN modules: ``mapping``, ``layer`` (dynapcnn_layer), ``discretize``, ``layers``.

    Raises
    ------
    neurovpr.errors.BackendUnavailableError
        If Sinabs is missing, or a module fails to import.
    """
    mods = import_without_parent_init(
        "sinabs.backend.dynapcnn", ("mapping", "dynapcnn_layer", "discretize"), hint=INSTALL_HINT
    )
    import sinabs.layers as layers

    return SimpleNamespace(
        mapping=mods["mapping"], layer=mods["dynapcnn_layer"], discretize=mods["discretize"], layers=layers
    )
