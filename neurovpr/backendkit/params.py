"""Cell parameters as a backend reads them: one value per neuron, or one shared value."""

from __future__ import annotations

from typing import Any

import numpy as np

__all__ = ["per_neuron", "uniform_value"]

#: Relative tolerance under which per-neuron values count as one shared value.
_RTOL = 1e-9


def per_neuron(value: Any, size: int) -> np.ndarray:
    """A parameter (one number or one per neuron) as a new ``float64`` array of ``size`` values."""
    return np.broadcast_to(np.asarray(value, dtype=np.float64), (size,)).copy()


def uniform_value(value: Any) -> float | None:
    """The one value a parameter takes for every neuron, or ``None`` when the neurons differ."""
    arr = np.asarray(value, dtype=np.float64)
    if arr.ndim == 0:
        return float(arr)
    return float(arr[0]) if np.allclose(arr, arr[0], rtol=_RTOL, atol=0.0) else None
