#!/usr/bin/env bash
# Set up the project's virtual environment (.venv, Python 3.11) and run one job in it.
#
#   bash scripts/bootstrap.sh demo [ARGS...]   install neurovpr with the tour's backends, run `neurovpr demo ARGS`
#   bash scripts/bootstrap.sh test [ARGS...]   install every backend the tests exercise, run pytest ARGS
#
# Safe to run again: it reuses .venv and only installs what is missing.
set -euo pipefail
cd "$(dirname "$0")/.."

mode="${1:-}"
shift || true

find_python() {
    for candidate in "${PYTHON:-}" python3.11 python3 python; do
        [ -n "$candidate" ] || continue
        if command -v "$candidate" >/dev/null 2>&1 &&
            "$candidate" -c 'import sys; sys.exit(0 if sys.version_info[:2] == (3, 11) else 1)' 2>/dev/null; then
            echo "$candidate"
            return 0
        fi
    done
    echo "neurovpr needs Python 3.11 (set PYTHON=/path/to/python3.11)" >&2
    return 1
}

# pip leaves bytecode to the first import (a fresh install then skips compiling every file of
# torch, TensorFlow and the rest, most of which the demo and the tests never import)
export PIP_NO_COMPILE=1

if [ ! -x .venv/bin/python ]; then
    "$(find_python)" -m venv .venv
fi
pip_install() { .venv/bin/python -m pip install --quiet --disable-pip-version-check "$@"; }

case "$mode" in
    demo)
        # The tour runs one network on Brian2, Nengo/NengoLoihi and Lava and trains LoCS-Net with
        # torch: about 1.6 GB installed (torch 2.13 CPU build most of it). PyNN/NEST, sPyNNaker and
        # the rest come with `test`; the demo names the extra of each backend it did not run.
        pip_install -e ".[brian2,nengo,locsnet]"
        if [ -f scripts/install_lava.sh ]; then
            bash scripts/install_lava.sh .venv/bin/python
        fi
        exec .venv/bin/neurovpr demo "$@"
        ;;
    test)
        pip_install -e ".[all,test]"
        if [ -f scripts/install_lava.sh ]; then
            bash scripts/install_lava.sh .venv/bin/python
        fi
        if [ -f scripts/install_neurobench.sh ]; then
            bash scripts/install_neurobench.sh .venv/bin/python
        fi
        if [ -f scripts/install_synsense.sh ]; then
            bash scripts/install_synsense.sh .venv/bin/python
        fi
        if [ -f scripts/install_nengo_dl.sh ]; then
            bash scripts/install_nengo_dl.sh .venv/bin/python
        fi
        exec .venv/bin/python -m pytest "$@"
        ;;
    *)
        echo "usage: bash scripts/bootstrap.sh {demo|test} [ARGS...]" >&2
        exit 2
        ;;
esac
