"""A tiny Modular SNN for fast tests, shared by the Modular SNN test files."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from neurovpr.data.encoding import RateCoding
from neurovpr.models.modular_snn import ModuleParameters, TrainingSettings

__all__ = ["TINY", "tiny_images", "synthetic_dataset"]

# A module small enough for fast tests: 8x8 images, 10 neurons, 100 ms presentations, 0.5 ms steps
# (exact steps: a forward-Euler step needs dt below tau_gi = 0.5 ms).
TINY = TrainingSettings(
    params=ModuleParameters(n_input=64, n_neurons=10, delay_min=0.5, integration="exact"),
    coding=RateCoding(presentation_ms=100.0),
    dt=0.5,
    epochs=2,
    module_size=3,
    weight_sum=40.0,
)


def tiny_images(n: int, seed: int = 0) -> np.ndarray:
    """``n`` random 8x8 uint8 images."""
    return np.random.default_rng(seed).integers(0, 256, size=(n, 8, 8)).astype(np.uint8)


def synthetic_dataset(folder: Path, n: int) -> Path:
    """A synthetic traverse of ``n`` places written in the generic layout under ``folder / "data"``."""
    from neurovpr.data.generic import write_generic
    from neurovpr.data.synthetic import synthetic_traverse

    return write_generic(synthetic_traverse(n, seed=2), folder / "data")
