"""Save and load networks (placeholder until the HDF5 format lands)."""

from __future__ import annotations

__all__ = ["save", "load"]


def save(obj, path):  # noqa: ANN001, ANN201
    raise NotImplementedError


def load(path):  # noqa: ANN001, ANN201
    raise NotImplementedError
