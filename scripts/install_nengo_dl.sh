#!/usr/bin/env bash
# Install NengoDL 3.6.0 for the `nengo-dl` backend and LoCS-Net's NengoDL trainer
# (`neurovpr train --model locsnet --trainer nengo-dl`).
#
# NengoDL 3.6.0, its last release, is an sdist that asks for `tensorflow>=2.3.4` (and was
# tested up to TensorFlow 2.11, whose numpy pins clash with Lava's). neurovpr uses it
# with tensorflow-cpu 2.15.1 and Keras 2.15.0, which share numpy 1.26 with Lava; TF 2.15
# needs wrapt <1.15. Those and NengoDL's own small dependencies are the `nengo-dl` extra
# (resolved normally); nengo-dl itself is then installed alone with --no-deps, since
# resolving its sdist would add the full `tensorflow` package next to tensorflow-cpu.
#
# NengoDL's compat module imports `keras.engine.functional`, which Keras 2.13+ moved to
# `keras.src.engine.functional`. neurovpr enters the old name in memory before importing
# NengoDL (neurovpr.backends.nengo_dl.compat); site-packages is not touched. The last
# step checks that NengoDL imports through that fix and runs a one-neuron network.
#
# About 1.1 GB installed (TensorFlow most of it), a few minutes from the package mirror.
#
# Usage: scripts/install_nengo_dl.sh [PYTHON]   (default: $PYTHON, else `python`), after `pip install -e .`
# Safe to run again: each step is skipped when already satisfied.
set -euo pipefail
cd "$(dirname "$0")/.."

PY="${1:-${PYTHON:-python}}"
NENGO_DL_VERSION="3.6.0"

if ! "$PY" -c 'import sys; sys.exit(0 if sys.version_info[:2] == (3, 11) else 1)'; then
    echo "install_nengo_dl.sh: $PY is not Python 3.11; neurovpr needs Python 3.11." >&2
    exit 2
fi

# 1. TensorFlow, Keras and what NengoDL imports, resolved normally (no-ops when already met).
"$PY" -m pip install --quiet --disable-pip-version-check -e ".[nengo-dl]"

# 2. nengo-dl itself, without its `tensorflow` requirement.
installed="$("$PY" -c 'import importlib.metadata as m
try:
    print(m.version("nengo-dl"))
except m.PackageNotFoundError:
    print("")')"
if [ "$installed" != "$NENGO_DL_VERSION" ]; then
    "$PY" -m pip install --quiet --disable-pip-version-check --no-deps "nengo-dl==${NENGO_DL_VERSION}"
fi

# 3. Verify: NengoDL imports through neurovpr's fix and simulates (TensorFlow caches in a temporary folder).
"$PY" - <<'PYEOF'
import numpy as np

import neurovpr as nv
from neurovpr.runtime.registry import backend_info

info = backend_info("nengo-dl")
if not info.available:
    raise SystemExit(f"install_nengo_dl.sh: the nengo-dl backend is not available: {info.reason}")
net = nv.Network("check")
net.add_population("lif", 1, nv.IF_curr_exp(i_offset=1.0))
sim = nv.compile(net, backend="nengo-dl", dt=1.0, seed=0)
sim.run(100.0)
assert int(np.sum(sim.spike_counts("lif"))) > 0, "a driven LIF neuron did not fire on NengoDL"
print(f"NengoDL {info.version} imports and simulates through neurovpr's Keras fix.")
PYEOF
