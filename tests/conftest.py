"""Shared fixtures: the optional real-data folder and the installed backends."""

from __future__ import annotations

from pathlib import Path

import pytest

from neurovpr.backendkit.tensorflow_env import tensorflow_defaults
from neurovpr.paths import shared_datasets

# NengoDL and NengoLoihi (when TensorFlow is installed) import TensorFlow: one thread per pool, Keras's home
# in a temporary folder, before any test module imports them
tensorflow_defaults(threads=1)


@pytest.fixture(scope="session")
def shared_data() -> Path:
    """The real datasets folder; tests using it skip with a reason when it is absent."""
    path = shared_datasets()
    if path is None:
        pytest.skip("real datasets not found: set NEUROVPR_SHARED_DATA or place them in ../shared/datasets")
    return path
