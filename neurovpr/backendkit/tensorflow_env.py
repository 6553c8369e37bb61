"""TensorFlow's environment defaults, for backends that import it directly or through a vendor package.

TensorFlow reads its C++ log level and thread-pool sizes from the environment when it
is imported or its runtime starts, and Keras 2 writes ``keras.json`` into ``~/.keras``
on first import unless ``KERAS_HOME`` points elsewhere. NengoDL imports TensorFlow, and
so does NengoLoihi whenever TensorFlow is installed (it probes for NengoDL), so both the
``nengo-dl`` and the ``nengo``/``nengo-loihi`` backends apply these defaults before
importing them. Each variable is set only where the caller has not set it; nothing is
imported here.
"""

from __future__ import annotations

import os
import sys
import tempfile
from pathlib import Path

__all__ = ["tensorflow_defaults"]


def tensorflow_defaults(threads: int | None = None) -> None:
    """Defaults for TensorFlow's log level and thread pools and for Keras's home folder, where none are set.

    Parameters
    ----------
    threads
        Threads of each TensorFlow pool (``None``: TensorFlow's own choice). Takes effect
        only before TensorFlow's runtime starts; later calls keep the pools it has.
    """
    os.environ.setdefault("TF_CPP_MIN_LOG_LEVEL", "2")
    os.environ.setdefault("KERAS_HOME", str(Path(tempfile.gettempdir()) / f"neurovpr-keras-{os.getuid()}"))
    if threads is None:
        return
    os.environ.setdefault("TF_NUM_INTRAOP_THREADS", str(int(threads)))
    os.environ.setdefault("TF_NUM_INTEROP_THREADS", str(int(threads)))
    tf = sys.modules.get("tensorflow")
    if tf is not None:
        try:
            tf.config.threading.set_intra_op_parallelism_threads(int(threads))
            tf.config.threading.set_inter_op_parallelism_threads(int(threads))
        except RuntimeError:
            pass  # the runtime has started: its pools stay as they are
