"""One trained model on several backends: accuracy, agreement, spike counts, time and energy.

``neurovpr compare`` runs the model of a run directory on each named backend through
its plugin's :meth:`~neurovpr.apps.modelapi.ModelPlugin.infer` and compares the results with
those of the first backend that ran (the *reference of comparison*):

- ``metrics``: the model's own accuracy metrics on that backend (``R@1``, ``P@100R``, ...);
- ``agreement``: the fraction of queries whose predicted place equals the reference's;
- ``spike_count_correlation``: Pearson's r between the flattened output spike counts
  ``(queries, outputs)`` and the reference's (``None`` when either is constant);
- ``seconds_per_query``: wall-clock time per query as the model measured it;
- ``energy`` (with a hwspec): joules per inference estimated by
  :func:`neurovpr.hardware.energy.estimate_energy` from the activity the run counted.

A backend that is installed but cannot be imported, or that cannot run a feature the
model needs, is not run: its row carries ``refused``, one sentence saying why (the
import error and the extra to reinstall, or the feature). A backend other than the one
the run was trained on runs the trained weights with plasticity off; its row says
``deployed_from`` that backend. This module imports no backend and no model: both are
found through their entry points.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from neurovpr.apps import modelapi
from neurovpr.apps.compare_result import PRIMARY_METRICS, BackendComparison, Comparison
from neurovpr.apps.rundir import NETWORK_FILE, RunDir
from neurovpr.errors import BackendUnavailableError, UnsupportedFeatureError, ValidationError
from neurovpr.hardware.check import check_network
from neurovpr.hardware.hwspec import load_hwspec
from neurovpr.ir.network import Network
from neurovpr.runtime import registry

__all__ = [
    "BackendComparison",
    "Comparison",
    "parse_backends",
    "availability_refusal",
    "agreement",
    "spike_count_correlation",
    "compare_model",
    "PRIMARY_METRICS",
]


def _backend_names() -> list[str]:
    return registry.declared_names()


def parse_backends(text: str | Sequence[str]) -> tuple[str, ...]:
    """The backend names of ``--backends A,B,...`` (unique, known), or a one-sentence error."""
    names = [n.strip() for n in (text.split(",") if isinstance(text, str) else text)]
    if not names or any(not n for n in names):
        raise ValidationError(f"--backends {text!r} must be a comma-separated list of backend names without empty entries.")
    seen = {n for n in names if names.count(n) > 1}
    if seen:
        raise ValidationError(f"--backends names {sorted(seen)[0]!r} more than once.")
    known = _backend_names()
    for name in names:
        if name not in known:
            raise BackendUnavailableError(f"Unknown backend {name!r} in --backends; known backends: {', '.join(known)}.")
    return tuple(names)


def availability_refusal(name: str) -> str | None:
    """``None`` when backend ``name`` can run networks here, else one sentence why not.

    An installed backend whose simulator fails to import gets the import error and the
    extra to reinstall; a mapping-only backend its own refusal.
    """
    try:
        backend = registry.get_backend(name)
    except BackendUnavailableError as exc:
        return f"{str(exc).rstrip('.')}; reinstall neurovpr with the extra that provides it."
    reason = backend.unavailable_reason()
    if reason is None:
        caps = backend.capabilities
        if not caps.runs:
            return caps.run_refusal or f"Backend {name!r} maps networks but does not run them."
        return None
    reason = reason.rstrip(".")
    extra = backend.extra
    if extra and f"neurovpr[{extra}]" not in reason and f"'{extra}' extra" not in reason:
        reason += f"; reinstall it with: pip install --force-reinstall 'neurovpr[{extra}]'"
    return f"Backend {name!r} is installed but cannot be used here: {reason}."


def agreement(predictions: np.ndarray, reference: np.ndarray) -> float:
    """Fraction of queries whose prediction equals the reference's."""
    a, b = np.asarray(predictions).ravel(), np.asarray(reference).ravel()
    if a.shape != b.shape or a.size == 0:
        raise ValidationError(f"cannot compare {a.size} predictions with {b.size} reference predictions.")
    return float(np.mean(a == b))


def spike_count_correlation(counts: np.ndarray, reference: np.ndarray) -> float | None:
    """Pearson's r of the flattened spike counts and the reference's; ``None`` when either is constant."""
    a = np.asarray(counts, dtype=np.float64).ravel()
    b = np.asarray(reference, dtype=np.float64).ravel()
    if a.shape != b.shape or a.size == 0:
        raise ValidationError(
            f"cannot correlate output spike counts of shape {np.shape(counts)} with the reference's {np.shape(reference)}."
        )
    if np.ptp(a) == 0 or np.ptp(b) == 0:
        return None
    return float(np.corrcoef(a, b)[0, 1])


def _finite_or_none(value: Any) -> float | None:
    try:
        v = float(value)
    except (TypeError, ValueError):
        return None
    return v if math.isfinite(v) else None


def _check_result(model: str, backend: str, result: Any) -> dict[str, Any]:
    """Validate what ``infer`` returned; one sentence naming the model, backend and key otherwise."""
    where = f"model {model!r} inference on {backend!r}"
    if not isinstance(result, Mapping):
        raise ValidationError(f"{where} returned a {type(result).__name__}, expected a dict.")
    for key in ("metrics", "predictions", "output_counts", "seconds_per_query"):
        if key not in result:
            raise ValidationError(f"{where} returned no {key!r}.")
    if not isinstance(result["metrics"], Mapping):
        raise ValidationError(f"{where} returned metrics of type {type(result['metrics']).__name__}, expected a dict.")
    predictions = np.asarray(result["predictions"])
    counts = np.asarray(result["output_counts"])
    if predictions.ndim != 1 or predictions.size == 0 or not np.issubdtype(predictions.dtype, np.integer):
        raise ValidationError(f"{where} returned predictions of shape {predictions.shape}, expected one int per query.")
    if counts.ndim != 2 or counts.shape[0] != predictions.size:
        raise ValidationError(
            f"{where} returned output counts of shape {counts.shape}, expected ({predictions.size}, outputs)."
        )
    seconds = _finite_or_none(result["seconds_per_query"])
    if seconds is None or seconds < 0:
        raise ValidationError(f"{where} returned seconds_per_query {result['seconds_per_query']!r}, expected a number >= 0.")
    activity = result.get("activity")
    if activity is not None and not isinstance(activity, Mapping):
        raise ValidationError(f"{where} returned activity of type {type(activity).__name__}, expected a dict.")
    deployed = result.get("network")
    if deployed is not None and not isinstance(deployed, Network):
        raise ValidationError(f"{where} returned a network of type {type(deployed).__name__}, expected a neurovpr Network.")
    return {
        "network": deployed,
        "metrics": {str(k): _finite_or_none(v) for k, v in result["metrics"].items()},
        "predictions": predictions.astype(np.int64),
        "output_counts": counts,
        "seconds_per_query": seconds,
        "activity": None if activity is None else dict(activity),
        "notes": tuple(str(n) for n in result.get("notes") or ()),
    }


def _energy(activity: Mapping[str, Any] | None, spec: Any, network: Any, partition: Any) -> dict[str, Any]:
    """Energy per inference on ``spec`` from one backend's per-inference activity, on the run's one ``partition``."""
    from neurovpr.hardware.energy import REQUIRED_COUNTS, estimate_energy

    if activity is None:
        return {"hardware": spec.name, "joules_per_inference": None, "reason": "the backend counted no activity"}
    missing = [k for k in REQUIRED_COUNTS if k not in activity]
    if missing:
        return {"hardware": spec.name, "joules_per_inference": None, "reason": f"the activity lacks the count {missing[0]!r}"}
    counts = {k: float(v) for k, v in activity.items() if k in (*REQUIRED_COUNTS, "plastic_updates", "spikes_between_chips")}
    counts["dt_ms"] = activity.get("dt_ms")
    if isinstance(activity.get("population_spikes"), Mapping):
        counts["population_spikes"] = dict(activity["population_spikes"])
    report = estimate_energy(counts, spec, network=network, partition=partition)
    full = report.as_dict()
    return {k: full[k] for k in ("hardware", "joules_per_inference", "breakdown", "seconds_per_inference", "chips",
                                 "cores", "not_estimated", "notes")}  # fmt: skip


def _neurobench(activity: Mapping[str, Any] | None, network: Any, seed: int) -> dict[str, Any]:
    """NeuroBench's metrics of one backend's run, from its per-inference activity and the run's network."""
    from neurovpr.evaluation.neurobench import neurobench_from_activity

    if network is None:
        return {"reason": f"the run directory has no {NETWORK_FILE}"}
    if activity is None or "steps" not in activity:
        return {"reason": "the backend counted no activity"}
    return neurobench_from_activity(network, activity, seed=seed)


def _run_network(run_dir: Path) -> Any:
    """The run's network (for the partition behind the energy estimate), or ``None`` when it has none."""
    run = RunDir(run_dir)
    return run.load_network() if run.has_network else None


def compare_model(
    run_dir: str | Path,
    data: str | Path | None,
    backends: str | Sequence[str],
    *,
    hardware: str | None = None,
    seed: int = 0,
    progress: bool = True,
    model: modelapi.ModelPlugin | None = None,
) -> Comparison:
    """Run the model of ``run_dir`` on every backend of ``backends`` and compare them.

    Parameters
    ----------
    run_dir
        A run directory written by ``neurovpr train`` (``run.json`` names the model).
    data
        The dataset whose query set is run (``None``: the one the model trained on, where it knows it).
    backends
        Backend names, as a list or the ``--backends`` text ``"A,B,..."``.
    hardware
        A hwspec name or file: estimate energy per inference on it from each backend's activity.
    seed
        Seed passed to the model's inference (Poisson input, random connectors).
    progress
        Show a progress bar over the backends.
    model
        The model's plugin; by default the installed model named in ``run.json``
        (:func:`neurovpr.apps.modelapi.get_model`).

    Raises
    ------
    ValidationError, BackendUnavailableError
        For a bad run directory, dataset, hwspec or backend list, and when the model
        does not implement inference (before any backend runs).
    """
    names = parse_backends(backends)
    run_dir = Path(run_dir)
    info = modelapi.read_run_info(run_dir)
    plugin = modelapi.get_model(info["model"]) if model is None else model
    if not isinstance(plugin, modelapi.ModelPlugin):
        raise ValidationError(f"model must be a neurovpr ModelPlugin, got {type(plugin).__name__}.")
    if type(plugin).infer is modelapi.ModelPlugin.infer:
        raise UnsupportedFeatureError(f"Model {info['model']!r} does not implement inference, so it cannot be compared.")
    spec = fit = None
    network = _run_network(run_dir)
    if hardware is not None:
        spec = load_hwspec(hardware)
        if network is not None:
            # one partition, as `neurovpr check --run RUN_DIR` makes it: the run's time step and this seed
            recorded = RunDir(run_dir).time_step()
            fit = check_network(network, spec, seed=seed, dt=None if recorded is None else recorded[0])
    trained_on = info.get("backend") if isinstance(info.get("backend"), str) else None
    data_path = None if data is None else Path(data)
    if data_path is not None and not data_path.exists():
        raise ValidationError(f"dataset path {str(data)!r} does not exist.")

    bar: Any = None
    if progress:
        from tqdm.auto import tqdm

        bar = tqdm(total=len(names), desc="compare", unit="backend")
    rows: list[BackendComparison] = []
    ref: BackendComparison | None = None
    try:
        for name in names:
            if bar is not None:
                bar.set_postfix_str(name)
            row = _one_backend(plugin, info["model"], run_dir, data_path, name, seed, trained_on, ref, spec, network, fit)
            if ref is None and row.ran:
                ref = row
            rows.append(row)
            if bar is not None:
                bar.update(1)
    finally:
        if bar is not None:
            bar.close()
    return Comparison(
        model=str(info["model"]),
        run=str(run_dir),
        data=None if data_path is None else str(data_path),
        trained_on=trained_on,
        hardware=None if spec is None else spec.name,
        rows=tuple(rows),
        hardware_fit=None if fit is None else {
            "fits": fit.fits, "dt_ms": fit.spec.timing.time_step_ms, "chips": fit.partition.chips,
            "cores": len(fit.partition.cores), "violations": len(fit.partition.violations),
        },
    )


def _one_backend(
    plugin: modelapi.ModelPlugin,
    model: str,
    run_dir: Path,
    data: Path | None,
    name: str,
    seed: int,
    trained_on: str | None,
    ref: BackendComparison | None,
    spec: Any,
    network: Any,
    fit: Any,
) -> BackendComparison:
    refusal = availability_refusal(name)
    if refusal is not None:
        return BackendComparison(backend=name, refused=refusal)
    try:
        raw = plugin.infer(run_dir, data, name, seed=seed)
    except (UnsupportedFeatureError, BackendUnavailableError) as exc:
        return BackendComparison(backend=name, refused=str(exc))
    except NotImplementedError as exc:  # the model's own "not on this backend"
        return BackendComparison(backend=name, refused=str(exc) or f"Model {model!r} has no inference on {name!r}.")
    res = _check_result(model, name, raw)
    agree = corr = None
    if ref is None:
        agree = 1.0
        corr = spike_count_correlation(res["output_counts"], res["output_counts"])
    else:
        assert ref.predictions is not None and ref.output_counts is not None
        if res["predictions"].size != ref.predictions.size:
            raise ValidationError(
                f"model {model!r} answered {res['predictions'].size} queries on {name!r} but "
                f"{ref.predictions.size} on {ref.backend!r}."
            )
        agree = agreement(res["predictions"], ref.predictions)
        corr = spike_count_correlation(res["output_counts"], ref.output_counts)
    if res["network"] is not None and spec is not None:
        # the model ran another form of its network here (e.g. integrate-and-fire on a chip without leak): its own partition
        network = res["network"]
        fit = check_network(network, spec, seed=seed, dt=None if fit is None else fit.spec.timing.time_step_ms)
        verdict = "fits" if fit.fits else f"does not fit ({len(fit.partition.violations)} limits broken)"
        res["notes"] += (
            f"its energy uses the partition of the form that ran: it {verdict} {spec.name}, {len(fit.partition.cores)} cores, "
            f"{fit.partition.chips} chip(s)",
        )
    energy = None if spec is None else _energy(res["activity"], spec, network, None if fit is None else fit.partition)
    return BackendComparison(
        neurobench=_neurobench(res["activity"], network, seed),
        backend=name,
        metrics=res["metrics"],
        agreement=agree,
        spike_count_correlation=corr,
        seconds_per_query=res["seconds_per_query"],
        energy=energy,
        deployed_from=trained_on if trained_on is not None and trained_on != name else None,
        notes=res["notes"],
        predictions=res["predictions"],
        output_counts=res["output_counts"],
    )
