"""Importing NengoDL 3.6.0 next to TensorFlow 2.15 and Keras 2.15.

NengoDL 3.6.0 (its last release) was written for TensorFlow up to 2.11. With Keras
2.13 and later its ``nengo_dl/compat.py`` fails at import, on two lines:
``from keras.engine.functional import Functional, _build_map`` (Keras moved that package
to ``keras.src.engine``; the module and both names are unchanged there) and
``from keras.layers import BatchNormalizationV1, BatchNormalizationV2`` (Keras 2.15 still
defines both names, in ``keras.src.layers``, but no longer exports them from
``keras.layers``). This module makes both resolve without touching the installed files:
before NengoDL is imported, ``keras.engine`` and ``keras.engine.functional`` are entered
in ``sys.modules`` as the ``keras.src.engine`` modules, and the two class names are set on
``keras.layers`` from ``keras.src.layers``, each when (and only when) Keras lacks it.
Nothing else is aliased.

It also keeps TensorFlow quiet and inside its bounds: its C++ log level, its thread
pools and Keras's home folder get defaults, each only where the caller has not set it
(:mod:`neurovpr.backendkit.tensorflow_env`). NengoDL's
warning that it was tested up to Nengo 3.2 is not repeated (it runs on Nengo 4.1: the
backend's tests compare its spike counts with Nengo's own simulator).
"""

from __future__ import annotations

import importlib
import importlib.util
import sys
import warnings
from types import ModuleType

from neurovpr.backendkit.tensorflow_env import tensorflow_defaults
from neurovpr.errors import BackendUnavailableError

__all__ = ["NENGO_DL_VERSION", "INSTALL_HINT", "configure_tensorflow", "alias_keras_names", "import_nengo_dl"]

#: The NengoDL release the backend and the trainer are written and tested for.
NENGO_DL_VERSION = "3.6.0"
#: How to install NengoDL here.
INSTALL_HINT = (
    "install it with scripts/install_nengo_dl.sh from the neurovpr source tree (the 'nengo-dl' extra's "
    f"TensorFlow 2.15 and Keras 2.15, then `pip install --no-deps nengo-dl=={NENGO_DL_VERSION}`)"
)


def configure_tensorflow(threads: int | None = 1) -> None:
    """TensorFlow's log level, thread pools (``threads`` each) and Keras's home folder, where the caller set none.

    See :func:`neurovpr.backendkit.tensorflow_env.tensorflow_defaults`.
    """
    tensorflow_defaults(threads)


def alias_keras_names() -> list[str]:
    """Give Keras the two old names NengoDL imports, where it lacks them (see the module docstring).

    Returns
    -------
    list of str
        The names added (empty when Keras still has them all).
    """
    import keras
    import keras.layers

    added = []
    if "keras.engine" not in sys.modules and importlib.util.find_spec("keras.engine") is None:
        sys.modules["keras.engine"] = importlib.import_module("keras.src.engine")
        sys.modules["keras.engine.functional"] = importlib.import_module("keras.src.engine.functional")
        keras.engine = sys.modules["keras.engine"]  # type: ignore[attr-defined]
        added.append("keras.engine")
    for name in ("BatchNormalizationV1", "BatchNormalizationV2"):
        if not hasattr(keras.layers, name):
            setattr(keras.layers, name, getattr(importlib.import_module("keras.src.layers"), name))
            added.append(f"keras.layers.{name}")
    return added


def import_nengo_dl(threads: int | None = 1) -> ModuleType:
    """Import NengoDL through the Keras alias (TensorFlow set up by :func:`configure_tensorflow`).

    Raises
    ------
    BackendUnavailableError
        When NengoDL, TensorFlow or Keras is missing or fails to import (one sentence
        with the cause and how to install it).
    """
    loaded = sys.modules.get("nengo_dl")
    if loaded is not None:
        return loaded
    if importlib.util.find_spec("nengo_dl") is None:
        raise BackendUnavailableError(f"NengoDL (nengo_dl) is not installed; {INSTALL_HINT}.")
    configure_tensorflow(threads)
    try:
        with warnings.catch_warnings():
            warnings.filterwarnings("ignore", message=".*has not been tested with your Nengo version.*")
            warnings.filterwarnings("ignore", category=DeprecationWarning)
            alias_keras_names()
            return importlib.import_module("nengo_dl")
    except Exception as exc:
        raise BackendUnavailableError(f"NengoDL does not import ({type(exc).__name__}: {exc}); {INSTALL_HINT}.") from exc
