"""Datasets, encoders and event streams.

Modules (imported on first use, so ``import neurovpr.data`` stays light):

- :mod:`~neurovpr.data.traverse` -- :class:`ImageSet`, :class:`Traverse`
- :mod:`~neurovpr.data.ground_truth` -- :class:`GroundTruth`
- :mod:`~neurovpr.data.generic` -- the generic folder layout, :func:`open_traverse`
- :mod:`~neurovpr.data.published` -- Nordland, Oxford RobotCar, St Lucia, SFU-Mountain, Synthia
- :mod:`~neurovpr.data.download` -- pooch downloads with checksums
- :mod:`~neurovpr.data.synthetic` -- procedural traverses with appearance change
- :mod:`~neurovpr.data.preprocess` -- the Modular SNN's 28x28 patch-normalised input
- :mod:`~neurovpr.data.encoding` -- Poisson rate coding
"""

from __future__ import annotations

import importlib
from typing import Any

_EXPORTS = {
    "ImageSet": "neurovpr.data.traverse",
    "Traverse": "neurovpr.data.traverse",
    "GroundTruth": "neurovpr.data.ground_truth",
    "open_traverse": "neurovpr.data.generic",
    "read_generic": "neurovpr.data.generic",
    "write_generic": "neurovpr.data.generic",
    "load_published": "neurovpr.data.published",
    "synthetic_traverse": "neurovpr.data.synthetic",
    "AppearanceChange": "neurovpr.data.synthetic",
    "preprocess_image": "neurovpr.data.preprocess",
    "preprocess_images": "neurovpr.data.preprocess",
    "RateCoding": "neurovpr.data.encoding",
}

__all__ = sorted(_EXPORTS)


def __getattr__(name: str) -> Any:
    if name in _EXPORTS:
        return getattr(importlib.import_module(_EXPORTS[name]), name)
    raise AttributeError(f"module 'neurovpr.data' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_EXPORTS))
