"""Export to and import from the Neuromorphic Intermediate Representation (NIR).

The mapping, its units and what NIR cannot express are one table in
:mod:`neurovpr.interop.nir.mapping`. Typical use::

    from neurovpr.interop.nir import export_nir, import_nir

    notes = export_nir(network, "net.nir")          # refuses what NIR cannot express
    result = import_nir("from_snntorch.nir", integration="euler")
    result.network, result.outputs, result.notes

Needs the optional ``nir`` package (``pip install 'neurovpr[nir]'``).
"""

from .files import export_nir, import_nir, load_nir, network_to_nir, nir_to_network, read_graph, write_graph
from .importer import NIRImport
from .mapping import DEFAULT_DT_MS, INTEGRATIONS, TAU_DELTA_MS, TAU_NO_LEAK_MS

__all__ = [
    "DEFAULT_DT_MS",
    "INTEGRATIONS",
    "NIRImport",
    "TAU_DELTA_MS",
    "TAU_NO_LEAK_MS",
    "export_nir",
    "import_nir",
    "load_nir",
    "network_to_nir",
    "nir_to_network",
    "read_graph",
    "write_graph",
]
