#!/usr/bin/env bash
# Install NeuroBench (neurobench 2.3.0), the metrics package the NeuroBench agreement test checks against.
#
# neurobench 2.3.0 requires torchaudio, and the torchaudio pip resolves for torch 2.13 does not
# load its extension ("Could not load this library"). The metrics neurovpr checks against
# (neurobench.metrics, neurobench.models.SNNTorchModel, neurobench.benchmarks) import neither
# torchaudio nor tonic, so neurobench is installed alone with --no-deps after what it does use
# (torch, snntorch, numba, tqdm: the `nir-peer` extra and neurovpr's own dependencies).
#
# Usage: scripts/install_neurobench.sh [PYTHON]   (default: $PYTHON, else `python`), after `pip install -e ".[all]"`
# Safe to run again: skipped when installed.
set -euo pipefail

PY="${1:-${PYTHON:-python}}"
NEUROBENCH_VERSION="2.3.0"

installed="$("$PY" -c 'import importlib.metadata as m
try:
    print(m.version("neurobench"))
except m.PackageNotFoundError:
    print("")')"
if [ "$installed" != "$NEUROBENCH_VERSION" ]; then
    "$PY" -m pip install --quiet --disable-pip-version-check --no-deps "neurobench==${NEUROBENCH_VERSION}"
fi
"$PY" -c 'from neurobench.metrics.static import ConnectionSparsity, Footprint
from neurobench.metrics.workload import ActivationSparsity, MembraneUpdates, SynapticOperations
from neurobench.models import SNNTorchModel
print("neurobench imports (without torchaudio).")'
