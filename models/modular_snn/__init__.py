"""Modular SNN and Ensembles of Modular SNNs (Hussaini, Milford & Fischer, IEEE T-RO 2024).

- :mod:`.network` -- the graph of one module (paper parameters)
- :mod:`.training` -- training one module, presenting images
- :mod:`.inference` -- assignment, hyperactive neurons, fusion, ensembles
- :mod:`.deployment` -- the current-based approximation for backends without conductance synapses
- :mod:`.parallel` -- process pool / Dask execution of module jobs
- :mod:`.runs` -- run directories: plan, resume, query responses, similarities
- :mod:`.report` -- metrics at several sequence lengths and plots
- :mod:`.plugin` -- ``neurovpr train/eval --model modular``; :data:`MODEL` is its entry point
"""

from .inference import (
    assign_neurons,
    draw_hyperactive_threshold,
    ensemble_similarity,
    fuse_modules,
    hyperactive_neurons,
    module_similarity,
    reference_activity,
)
from .network import ModuleParameters, build_module
from .plugin import MODEL, ModularSNNPlugin
from .runs import make_plan, member_similarities, query_responses, train_run
from .training import TrainingSettings, derive_seed, train_module

__all__ = [
    "MODEL",
    "ModularSNNPlugin",
    "ModuleParameters",
    "TrainingSettings",
    "assign_neurons",
    "build_module",
    "derive_seed",
    "draw_hyperactive_threshold",
    "ensemble_similarity",
    "fuse_modules",
    "hyperactive_neurons",
    "make_plan",
    "member_similarities",
    "module_similarity",
    "query_responses",
    "reference_activity",
    "train_module",
    "train_run",
]
