"""The interface between the command line and the models, found by entry points.

Models live outside the core (``models/``, installed as ``neurovpr.models.<name>``)
and declare a :class:`ModelPlugin` instance under the ``neurovpr.models`` entry
point group, so the CLI can train and evaluate them without importing them by name.

A *run directory* is what ``neurovpr train`` writes: ``run.json`` (at least
``{"model": NAME, "backend": ..., "seed": ...}``), the trained network(s) as HDF5,
and whatever else the model needs. ``neurovpr eval --run DIR`` reads ``run.json`` to
find the model.
"""

from __future__ import annotations

import argparse
import importlib.metadata
import json
from pathlib import Path
from typing import Any

from neurovpr.apps.rundir import RUN_FILE
from neurovpr.errors import BackendUnavailableError, ValidationError

__all__ = ["ModelPlugin", "MODEL_ENTRY_POINT_GROUP", "model_names", "get_model", "read_run_info"]

MODEL_ENTRY_POINT_GROUP = "neurovpr.models"


class ModelPlugin:
    """Base class of a model's command-line integration."""

    #: The name used with ``--model``.
    name: str = ""
    #: One line describing the model.
    description: str = ""

    def add_train_arguments(self, parser: argparse.ArgumentParser) -> None:
        """Add the model's own ``train`` options (all must have defaults)."""

    def add_eval_arguments(self, parser: argparse.ArgumentParser) -> None:
        """Add the model's own ``eval`` options (all must have defaults)."""

    def train(self, args: argparse.Namespace) -> dict[str, Any]:
        """Train into ``args.out`` and return a JSON-ready summary."""
        raise NotImplementedError

    def evaluate(self, args: argparse.Namespace, run_info: dict[str, Any]) -> dict[str, Any]:
        """Evaluate the run in ``args.run``; return the JSON object ``eval --json`` prints."""
        raise NotImplementedError

    def infer(self, run_dir: Path, data: Path | None, backend: str, *, seed: int = 0) -> dict[str, Any]:
        """Run the trained model of ``run_dir`` on ``backend`` over the query set of ``data``.

        Used by ``neurovpr compare``. Returns a dict with ``"metrics"`` (the model's
        accuracy metrics), ``"predictions"`` (one predicted place per query, a list of
        ints), ``"output_counts"`` (a ``(queries, outputs)`` array of output spike
        counts), ``"seconds_per_query"`` and ``"activity"`` (per-inference counts as
        ``Simulation.statistics()`` gives them), and optionally ``"notes"`` (sentences
        on how the model was deployed there, shown by ``compare``). A model that cannot
        run on the backend raises :class:`~neurovpr.errors.UnsupportedFeatureError` naming why.
        """
        raise NotImplementedError(f"Model {self.name!r} does not implement inference for compare.")


def _entry_points() -> list[importlib.metadata.EntryPoint]:
    return sorted(importlib.metadata.entry_points(group=MODEL_ENTRY_POINT_GROUP), key=lambda ep: ep.name)


def model_names() -> list[str]:
    """Names of the installed models."""
    return [ep.name for ep in _entry_points()]


def get_model(name: str) -> ModelPlugin:
    """The model declared under ``name``."""
    matches = [ep for ep in _entry_points() if ep.name == name]
    if not matches:
        raise ValidationError(f"Unknown model {name!r}; known models: {', '.join(model_names()) or 'none'}.")
    try:
        plugin = matches[0].load()
    except Exception as exc:
        raise BackendUnavailableError(f"Model {name!r} failed to load: {type(exc).__name__}: {exc}.") from exc
    if not isinstance(plugin, ModelPlugin):
        raise BackendUnavailableError(f"Model {name!r} does not provide a neurovpr ModelPlugin.")
    return plugin


def read_run_info(run_dir: str | Path) -> dict[str, Any]:
    """Read and check ``RUN_DIR/run.json``."""
    path = Path(run_dir) / RUN_FILE
    if not path.is_file():
        raise ValidationError(f"Run directory {str(run_dir)!r} has no run.json (was it written by neurovpr train?).")
    try:
        info = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise ValidationError(f"{path} is not readable JSON ({exc}).") from None
    if not isinstance(info, dict) or not isinstance(info.get("model"), str):
        raise ValidationError(f"{path} does not name its model.")
    return info
