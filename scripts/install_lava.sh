#!/usr/bin/env bash
# Install Lava (lava-nc 0.10.0) for the `lava` and `lava-fixed` backends.
#
# lava-nc 0.10.0 declares Python <3.11 but runs on 3.11: its dependencies are
# installed normally (pip resolves them for this Python), then lava-nc alone is
# installed with --no-deps --ignore-requires-python. Never put
# --ignore-requires-python on a whole install: pip then picks source packages
# that need a newer Python.
#
# Lava's lava/magma/compiler/var_model.py does not import as shipped on 3.11
# (mutable dataclass defaults). neurovpr fixes that module in memory when the lava
# backend imports it (neurovpr.backends.lava.compat); site-packages is not touched.
# The last step checks that Lava imports through that fix.
#
# Usage: scripts/install_lava.sh [PYTHON]   (default: $PYTHON, else `python`), after `pip install -e .`
# Safe to run again: each step is skipped when already satisfied.
set -euo pipefail

PY="${1:-${PYTHON:-python}}"
LAVA_VERSION="0.10.0"

if ! "$PY" -c 'import sys; sys.exit(0 if sys.version_info[:2] == (3, 11) else 1)'; then
    echo "install_lava.sh: $PY is not Python 3.11; neurovpr needs Python 3.11." >&2
    exit 2
fi

# 1. Lava's declared dependencies, resolved for this Python (no-ops when already met).
"$PY" -m pip install \
    "asteval>=0.9.31,<0.10" \
    "networkx<=2.8.7" \
    "numpy>=1.24.4,<2" \
    "scikit-learn>=1.5,<2" \
    "scipy>=1.10.1,<2"

# 2. lava-nc itself, without its Python version check and without dependencies.
installed="$("$PY" -c 'import importlib.metadata as m
try:
    print(m.version("lava-nc"))
except m.PackageNotFoundError:
    print("")')"
if [ "$installed" != "$LAVA_VERSION" ]; then
    "$PY" -m pip install --no-deps --ignore-requires-python "lava-nc==${LAVA_VERSION}"
else
    echo "lava-nc ${LAVA_VERSION} already installed."
fi

# 3. Verify: the processes the backends use import through neurovpr's fix (needs neurovpr installed).
if ! "$PY" -c 'import neurovpr' 2>/dev/null; then
    echo "install_lava.sh: lava-nc is installed; install neurovpr (pip install -e .) and run this again to verify it." >&2
    exit 1
fi
"$PY" - <<'EOF'
from neurovpr.backends.lava.compat import import_lava

import_lava()
print("Lava imports on this Python through neurovpr's compatibility fix.")
EOF
