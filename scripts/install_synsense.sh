#!/usr/bin/env bash
# Install SynSense's open toolchains for the Xylo and Speck checks: Rockpool 3.1.0 with
# XyloSim 0.1.3 (the `synsense` extra) and Sinabs 3.1.3.
#
# sinabs 3.1.3 declares `samna>=0.33` and `nir<=1.0.4`. samna, SynSense's chip-configuration
# library, is not on the package index: its PyPI releases are download stubs that try to
# install the real package from SynSense's own server at import time, which cannot work
# without that server (and must never be imported by the tests). neurovpr pins nir 1.0.8.
# So sinabs is installed alone with --no-deps after what it does use (torch, pbr, numpy,
# nirtorch: the `synsense` extra). The Sinabs and Rockpool modules neurovpr uses import no
# samna; their package __init__ files do, and neurovpr skips those
# (neurovpr.backends.xylo.compat, neurovpr.backends.speck.compat). XyloSim is a C++
# extension built from source (needs a C++ compiler).
#
# Usage: scripts/install_synsense.sh [PYTHON]   (default: $PYTHON, else `python`), after `pip install -e .`
# Safe to run again: each step is skipped when already satisfied.
set -euo pipefail

PY="${1:-${PYTHON:-python}}"
SINABS_VERSION="3.1.3"

# 1. Rockpool, XyloSim and what Sinabs needs, resolved normally (no-ops when already met).
"$PY" -m pip install --quiet --disable-pip-version-check -e ".[synsense]"

# 2. sinabs itself, without its samna and nir<=1.0.4 requirements.
installed="$("$PY" -c 'import importlib.metadata as m
try:
    print(m.version("sinabs"))
except m.PackageNotFoundError:
    print("")')"
if [ "$installed" != "$SINABS_VERSION" ]; then
    "$PY" -m pip install --quiet --disable-pip-version-check --no-deps "sinabs==${SINABS_VERSION}"
fi

# 3. Verify: the samna-free parts import through neurovpr's shims, and samna is absent.
"$PY" - <<'PYEOF'
import importlib.util

from neurovpr.backends.speck.compat import import_dynapcnn
from neurovpr.backends.xylo.compat import import_xylo

if importlib.util.find_spec("samna") is not None:
    raise SystemExit("install_synsense.sh: a `samna` package is installed; its PyPI releases try to download "
                     "the real package when imported: uninstall it (pip uninstall samna).")
import_xylo()
import_dynapcnn()
print("Rockpool (Xylo Audio 2 mapper, XyloSim) and Sinabs (DYNAP-CNN mapping) import without samna.")
PYEOF
