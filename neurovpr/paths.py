"""Where neurovpr finds optional real data and keeps its caches.

``NEUROVPR_SHARED_DATA`` points at a folder of real datasets (the test suite and the
measured figures read it); without it, ``<repo>/../shared/datasets`` is tried.
Neither is needed for the default run.
"""

from __future__ import annotations

import os
from pathlib import Path

__all__ = ["shared_datasets", "cache_dir"]

_REPO = Path(__file__).resolve().parent.parent


def shared_datasets() -> Path | None:
    """The shared real-data folder, or ``None`` when it is not present."""
    env = os.environ.get("NEUROVPR_SHARED_DATA")
    candidates = [Path(env)] if env else []
    candidates.append(_REPO.parent / "shared" / "datasets")
    for path in candidates:
        if path.is_dir():
            return path
    return None


def cache_dir(name: str) -> Path:
    """A project-owned cache folder (``NEUROVPR_CACHE`` or ``<repo>/.cache``), created on demand."""
    root = Path(os.environ.get("NEUROVPR_CACHE", _REPO / ".cache"))
    path = root / name
    path.mkdir(parents=True, exist_ok=True)
    return path
