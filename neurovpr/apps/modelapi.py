"""The model API: typed train/evaluate requests, and the models found by entry points.

Models live outside the core (``models/``, installed as ``neurovpr.models.<name>``)
and declare a :class:`ModelPlugin` instance under the ``neurovpr.models`` entry
point group, so Python code and the CLI can train and evaluate them without importing them by name.

A *run directory* is what ``neurovpr train`` writes; its layout is owned by
:class:`~neurovpr.apps.rundir.RunDir`. ``neurovpr eval --run DIR`` reads its
``run.json`` to find the model.
"""

from __future__ import annotations

import argparse
import dataclasses
from pathlib import Path
from typing import Any

from neurovpr import entrypoints
from neurovpr.apps.options import add_option_arguments
from neurovpr.apps.requests import EvalRequest, TrainRequest
from neurovpr.apps.rundir import RunDir
from neurovpr.errors import BackendUnavailableError, UnsupportedFeatureError, ValidationError
from neurovpr.ir.network import Network

__all__ = [
    "ModelPlugin",
    "SamplePresentation",
    "TrainRequest",
    "EvalRequest",
    "MODEL_ENTRY_POINT_GROUP",
    "model_names",
    "get_model",
    "read_run_info",
]

MODEL_ENTRY_POINT_GROUP = "neurovpr.models"



@dataclasses.dataclass(frozen=True, slots=True, kw_only=True)
class _NoOptions:
    """A model without options of its own."""


def _request(kind: type, options: type, fields: dict[str, Any], model: str) -> Any:
    common = {f.name for f in dataclasses.fields(kind)} - {"options"}
    own = {f.name for f in dataclasses.fields(options)}
    unknown = sorted(set(fields) - common - own)
    if unknown:
        raise ValidationError(
            f"{unknown[0]!r} is not an option of model {model!r}; its options: {', '.join(sorted(own)) or 'none'} "
            f"(and {', '.join(sorted(common))})."
        )
    given = {k: v for k, v in fields.items() if k in own}
    return kind(**{k: v for k, v in fields.items() if k in common}, options=options(**given))


def _given(request: Any, fields: dict[str, Any], build: Any, kind: type) -> Any:
    if request is None:
        return build(**fields)
    if fields:
        raise ValidationError(f"give either a {kind.__name__} or keyword arguments, not both ({', '.join(fields)}).")
    if not isinstance(request, kind):
        raise ValidationError(f"expected a {kind.__name__}, got {type(request).__name__}.")
    return request


def _check_options(options: Any, kind: type, model: str) -> None:
    if not isinstance(options, kind):
        raise ValidationError(f"model {model!r} takes options of type {kind.__name__}, got {type(options).__name__}.")


@dataclasses.dataclass(frozen=True, slots=True, kw_only=True)
class SamplePresentation:
    """One representative presentation of a trained model: what ``eval --activity-plots`` simulates and draws.

    Attributes
    ----------
    network
        The trained network, as the model evaluates it (plasticity is switched off).
    inputs
        The run inputs of the presentation (``Simulation.run(..., inputs=...)``).
    duration_ms
        How long it is shown.
    dt
        The time step the model runs at.
    title
        What it is (``"module m3, query image 0"``), for the plots.
    """

    network: Network
    inputs: dict[str, Any]
    duration_ms: float
    dt: float
    title: str


class ModelPlugin:
    """Base class of a model: typed ``train``/``evaluate`` (for Python and the CLI) and its command-line options.

    A model declares ``train_options`` and ``eval_options``, frozen dataclasses of its
    own options (all with defaults, validated on construction), and implements
    :meth:`run_train` and :meth:`run_evaluate`. Callers use :meth:`train` and
    :meth:`evaluate` with a request or with keyword arguments::

        from neurovpr import models
        summary = models.get("mbsnn").train(data="route.aedat4", out="runs/mb", n_kc=2000)

    The command line builds the same requests from its parsed options.
    """

    #: The name used with ``--model``.
    name: str = ""
    #: One line describing the model.
    description: str = ""
    #: The model's own ``train`` options: a frozen dataclass whose fields all have defaults and help
    #: (:func:`neurovpr.apps.options.option`); the command line's flags are generated from it.
    train_options: type = _NoOptions
    #: The model's own ``eval`` options.
    eval_options: type = _NoOptions

    def add_train_arguments(self, parser: argparse._ActionsContainer) -> None:
        """Add the model's own ``train`` options to the command line, one per field of ``train_options``."""
        add_option_arguments(parser, self.train_options)

    def add_eval_arguments(self, parser: argparse._ActionsContainer) -> None:
        """Add the model's own ``eval`` options to the command line, one per field of ``eval_options``."""
        add_option_arguments(parser, self.eval_options)

    def train_request(self, **fields: Any) -> TrainRequest:
        """A :class:`TrainRequest` from keyword arguments: the common fields and this model's options, by name."""
        return _request(TrainRequest, self.train_options, fields, self.name)

    def eval_request(self, **fields: Any) -> EvalRequest:
        """An :class:`EvalRequest` from keyword arguments: the common fields and this model's options, by name."""
        return _request(EvalRequest, self.eval_options, fields, self.name)

    def train(self, request: TrainRequest | None = None, /, **fields: Any) -> dict[str, Any]:
        """Train (a :class:`TrainRequest`, or its fields and the model's options as keywords); a JSON-ready summary."""
        request = _given(request, fields, self.train_request, TrainRequest)
        if request.options is None:
            request = dataclasses.replace(request, options=self.train_options())
        _check_options(request.options, self.train_options, self.name)
        return self.run_train(request)

    def evaluate(
        self, request: EvalRequest | None = None, /, run_info: dict[str, Any] | None = None, **fields: Any
    ) -> dict[str, Any]:
        """Evaluate a trained run (a request or keywords); the JSON object ``eval --json`` prints."""
        request = _given(request, fields, self.eval_request, EvalRequest)
        if request.options is None:
            request = dataclasses.replace(request, options=self.eval_options())
        _check_options(request.options, self.eval_options, self.name)
        info = read_run_info(request.run) if run_info is None else run_info
        if info.get("model") not in (None, self.name):
            raise ValidationError(f"run {str(request.run)!r} was trained by model {info['model']!r}, not {self.name!r}.")
        return self.run_evaluate(request, info)

    def run_train(self, request: TrainRequest) -> dict[str, Any]:
        """Train into ``request.out`` (``request.options`` is a ``train_options``); a JSON-ready summary."""
        raise NotImplementedError(f"Model {self.name!r} does not implement training.")

    def run_evaluate(self, request: EvalRequest, run_info: dict[str, Any]) -> dict[str, Any]:
        """Evaluate the run in ``request.run`` whose ``run.json`` is ``run_info``."""
        raise NotImplementedError(f"Model {self.name!r} does not implement evaluation.")

    def infer(self, run_dir: Path, data: Path | None, backend: str, *, seed: int = 0) -> dict[str, Any]:
        """Run the trained model of ``run_dir`` on ``backend`` over the query set of ``data``.

        Used by ``neurovpr compare``. Returns a dict with ``"metrics"`` (the model's
        accuracy metrics), ``"predictions"`` (one predicted place per query, a list of
        ints), ``"output_counts"`` (a ``(queries, outputs)`` array of output spike
        counts), ``"seconds_per_query"`` and ``"activity"`` (per-inference counts as
        ``Simulation.statistics()`` gives them), and optionally ``"notes"`` (sentences
        on how the model was deployed there, shown by ``compare``) and ``"network"`` (the
        network that ran there when it is not the run's own, e.g. a form the backend
        holds: ``compare`` partitions it for that row's energy). A model that cannot
        run on the backend raises :class:`~neurovpr.errors.UnsupportedFeatureError` naming why.
        """
        raise NotImplementedError(f"Model {self.name!r} does not implement inference for compare.")

    def sample_presentation(self, run_dir: Path, data: Path | None) -> SamplePresentation:
        """The first query presentation of the trained run in ``run_dir`` on ``data`` (default: the run's data).

        Used by ``neurovpr eval --activity-plots DIR`` (:func:`neurovpr.apps.activity.plot_sample_activity`)
        to draw a spike raster and rate histograms of a model as it is evaluated.
        """
        raise UnsupportedFeatureError(f"model {self.name!r} names no sample presentation, so it has no activity plots.")


def model_names() -> list[str]:
    """Names of the installed models."""
    return entrypoints.declared_names(MODEL_ENTRY_POINT_GROUP)


def get_model(name: str) -> ModelPlugin:
    """The model declared under ``name``."""
    return entrypoints.load_declared(
        MODEL_ENTRY_POINT_GROUP, name, ModelPlugin, what="model", unknown=ValidationError, broken=BackendUnavailableError
    )


def read_run_info(run_dir: str | Path) -> dict[str, Any]:
    """``run.json`` of the run directory ``run_dir``, checked (:meth:`RunDir.read_info`)."""
    return RunDir(run_dir).read_info()
