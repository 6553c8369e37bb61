"""``neurovpr train/eval --model modular``: the command-line face of the Modular SNN.

``train`` reads a dataset (generic or published layout), preprocesses the reference
traverse (28x28, patch-normalised), adds the reference traverse of every
``--extra-reference`` dataset as further training images of the same places (place
``i`` of each is place ``i`` of the main reference, as the paper trains on two reference
traverses; see :mod:`.runs`), sets ``--calibration-places`` aside (default: about 20 % of
the places in whole modules, none below three modules), trains every module of every
ensemble member in parallel (local processes, or Dask with ``--scheduler``) into
``RUN_DIR`` and writes ``run.json``. ``eval`` shows the query traverse to every module
(cached in the run), calibrates each member's hyperactive threshold on the calibration
places, builds the members' and the ensemble's similarity and distance matrices on the
other (reported) places, applies sequence matching of length ``--seq-len`` (Eq. 13,
identity kernel, ``valid`` mode), and reports Recall@N, precision at 100% recall, the PR
AUC and the concentration of the best matches next to SAD and Perfect Memory on the same
images, as JSON plus PNG plots in ``RUN_DIR/eval`` (or ``--report``).
"""

from __future__ import annotations

import io
import json
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

import numpy as np

import neurovpr as nv
from neurovpr.apps.modelapi import ModelPlugin, SamplePresentation
from neurovpr.apps.options import option
from neurovpr.apps.requests import EvalRequest, TrainRequest, check_fields
from neurovpr.apps.rundir import RunDir
from neurovpr.data.encoding import RateCoding
from neurovpr.fileio import atomic_write_text
from neurovpr.resources import check_network

from .deployment import deployed_network, deployment_form, static_network
from .network import ModuleParameters
from .parallel import default_workers
from .plan import calibration_places, default_calibration_places, describe_plan, query_seed, split_queries
from .report import evaluate_similarities, write_plots
from .runs import RUN_FORMAT, member_similarities, query_responses, reference_digest, train_run
from .training import TrainingSettings

__all__ = ["ModularSNNPlugin", "ModularTrainOptions", "ModularEvalOptions", "load_traverse"]

_TRAINING = TrainingSettings()


@dataclass(frozen=True, slots=True, kw_only=True)
class ModularTrainOptions:
    """The Modular SNN's own ``train`` options (defaults: the paper, from :class:`.training.TrainingSettings`)."""

    members: int = option(1, "ensemble size M (1: one modular SNN)")
    epochs: int = option(_TRAINING.epochs, "training epochs per module")
    module_size: int = option(_TRAINING.module_size, "places per module")
    neurons: int = option(_TRAINING.params.n_neurons, "excitatory (and inhibitory) neurons per module")
    places: int | None = option(None, "use only the first N reference places", default_text="all")
    extra_reference: tuple[Path, ...] = option(
        (),
        "another dataset whose reference traverse holds the same places in the same order; its images are "
        "trained on too (repeatable; --places applies to it as well)",
        metavar="PATH",
    )
    workers: int | None = option(None, "local worker processes", default_text="the CPU cores")
    max_modules: int | None = option(
        None, "train at most N unfinished modules, then stop (continue with --resume)", default_text="all"
    )
    stdp: Literal["code", "paper"] = option(_TRAINING.params.stdp, "learning rule: the authors' code or the paper's equation")
    hyperactive: Literal["images", "spikes"] = option(
        "images", "hyperactive activity: reference images fired for, or spikes"
    )
    theta: float | None = option(None, "fixed hyperactive threshold", default_text="calibrated per member")
    place_score: Literal["standard", "sum"] = option("standard", "place score: spikes per assigned neuron, or the sum")
    place_order: Literal["shuffled", "route"] = option(
        "shuffled", "places of a module: random per member, or consecutive"
    )
    seeding: Literal["module", "code"] = option(
        "module",
        "random draws: every module its own, or as the authors' code (every module of a member the same initial "
        "weights, delays and Poisson streams)",
    )
    calibration_places: int | None = option(
        None,
        "places set aside to calibrate the hyperactive threshold",
        default_text="about 20% of the places in whole modules, none below three modules",
    )
    assignment_presentations: int = option(
        _TRAINING.assignment_presentations, "assign neurons from this many last training presentations"
    )
    dt: float = option(_TRAINING.dt, "time step in ms (as the authors' code)")
    integration: Literal["euler", "exact"] = option(
        _TRAINING.params.integration, "cell steps: forward Euler (as the authors' code) or exact"
    )
    simulate_rest: bool = option(False, "simulate the 150 ms rest instead of reset()")

    def __post_init__(self) -> None:
        check_fields(self)
        if self.assignment_presentations < 1:
            raise nv.ValidationError(f"--assignment-presentations is {self.assignment_presentations}; it must be >= 1.")


@dataclass(frozen=True, slots=True, kw_only=True)
class ModularEvalOptions:
    """The Modular SNN's own ``eval`` options."""

    members_used: int | None = option(None, "evaluate the first K ensemble members only", default_text="all")
    workers: int | None = option(None, "local worker processes", default_text="the CPU cores")
    report: Path | None = option(None, "folder for results JSON and PNGs", default_text="RUN_DIR/eval")

    def __post_init__(self) -> None:
        check_fields(self)


def load_extra_references(paths: Any, main: str | Path, n_places: int, places: int | None, progress: bool) -> list[Any]:
    """Open every ``--extra-reference`` dataset, check its place count and return its preprocessed reference images.

    Every count is checked before any image is preprocessed. With ``places`` the first
    ``places`` reference places of each are kept (it needs at least that many);
    without, each must have exactly ``n_places``, the count of ``main``.
    """
    from neurovpr.data.generic import open_traverse

    traverses = []
    for path in paths or ():
        traverse = open_traverse(path)
        have = traverse.n_reference
        if places is None and have != n_places:
            raise nv.ValidationError(
                f"the extra reference traverse {path} has {have} reference places but {main} has {n_places}; place i of "
                "every training traverse must be the same place, so the counts must match."
            )
        if places is not None and have < n_places:
            raise nv.ValidationError(
                f"the extra reference traverse {path} has {have} reference places, fewer than the {n_places} used from "
                f"{main} (--places {n_places})."
            )
        if len(traverse.references) > 1:
            print(
                f"note: {path} has {len(traverse.references)} reference traverses; this model trains on the first "
                f"({traverse.reference.name}) only.",
                file=sys.stderr,
            )
        traverses.append(traverse.reference.subset(slice(0, n_places)) if have != n_places else traverse.reference)
    return [t.preprocessed(progress=progress) for t in traverses]


def load_traverse(path: str | Path, places: int | None = None) -> Any:
    """Open a dataset and keep its first ``places`` reference places (and as many queries)."""
    from neurovpr.data.generic import open_traverse

    traverse = open_traverse(path)
    if places is None:
        return traverse
    n = int(places)
    if not 1 <= n <= traverse.n_reference:
        raise nv.ValidationError(f"--places is {n}, but {path} has {traverse.n_reference} reference places.")
    return traverse.subset(slice(0, n), slice(0, min(n, traverse.n_query)))


class ModularSNNPlugin(ModelPlugin):
    """Modular SNN / Ensembles of Modular SNNs (Hussaini, Milford & Fischer, T-RO 2024)."""

    name = "modular"
    description = "Modular SNN and Ensembles of Modular SNNs (Hussaini et al., T-RO 2024)"
    train_options = ModularTrainOptions
    eval_options = ModularEvalOptions

    # ------------------------------------------------------------------ train
    def run_train(self, request: TrainRequest) -> dict[str, Any]:
        """Train into ``request.out`` (see the module docstring)."""
        o: ModularTrainOptions = request.options
        backend = request.backend
        chosen = nv.get_backend(backend)
        if not chosen.capabilities.learns:
            raise nv.UnsupportedFeatureError(f"backend {backend!r} does not learn on-line, so it cannot train the Modular SNN.")
        workers = int(o.workers or default_workers())
        if workers < 1:
            raise nv.ValidationError(f"--workers is {workers}, expected at least 1.")
        # input delays start at one step (the simulator's minimum delay)
        params = ModuleParameters(
            stdp=o.stdp, n_neurons=int(o.neurons), delay_min=max(0.1, float(o.dt)), integration=o.integration
        )
        settings = TrainingSettings(
            params=params,
            coding=RateCoding(),
            epochs=int(o.epochs),
            module_size=int(o.module_size),
            dt=float(o.dt),
            simulate_rest=bool(o.simulate_rest),
            backend=backend,
            assignment_presentations=int(o.assignment_presentations),
        )
        chosen.check_network(settings.network("modular_snn_module"))
        check_network(settings.network("modular_snn_module"), dt=settings.dt, what="train", copies=workers)
        traverse = load_traverse(request.data, o.places)
        if len(traverse.references) > 1:
            print(
                f"note: {traverse.name} has {len(traverse.references)} reference traverses; this model trains on the "
                f"first ({traverse.reference.name}) only.",
                file=sys.stderr,
            )
        extra_paths = [Path(p) for p in (o.extra_reference or [])]
        extras = load_extra_references(extra_paths, request.data, traverse.n_reference, o.places, request.progress)
        n_cal = o.calibration_places
        n_cal = default_calibration_places(traverse.n_reference, settings.module_size) if n_cal is None else int(n_cal)
        if not 0 <= n_cal < traverse.n_reference:
            raise nv.ValidationError(
                f"--calibration-places is {n_cal}, expected 0..{traverse.n_reference - 1} for {traverse.n_reference} places."
            )
        if n_cal and not split_queries(traverse.ground_truth, calibration_places(traverse.n_reference, n_cal))[0].size:
            raise nv.ValidationError(
                f"no query of {request.data} matches only calibration places; pass --calibration-places 0 or --theta."
            )
        reference = traverse.reference.preprocessed(progress=request.progress)
        note = describe_plan(len(reference), settings.module_size, n_cal)
        if (len(reference) - n_cal) % settings.module_size or n_cal % settings.module_size:
            print(f"note: {note}.", file=sys.stderr)
        info = {
            "data": str(Path(request.data).resolve()),
            "places": o.places,
            "dataset": traverse.name,
            "extra_references": [str(p.resolve()) for p in extra_paths],
        }
        summary = train_run(
            request.out,
            reference,
            settings,
            members=int(o.members),
            seed=request.seed,
            place_order=o.place_order,
            seeding=o.seeding,
            n_calibration=n_cal,
            hyperactive=o.hyperactive,
            theta=o.theta,
            score=o.place_score,
            workers=workers,
            scheduler=request.scheduler,
            resume=request.resume,
            max_modules=o.max_modules,
            info=info,
            progress=request.progress,
            extra_references=extras,
        )
        return {"model": self.name, "backend": backend, **summary}

    # ------------------------------------------------------------------- eval
    def run_evaluate(self, request: EvalRequest, run_info: dict[str, Any]) -> dict[str, Any]:
        """Evaluate the run in ``request.run`` (see the module docstring)."""
        o: ModularEvalOptions = request.options
        run_dir = request.run
        if run_info.get("format") != RUN_FORMAT:
            raise nv.ValidationError(
                f"{RunDir(run_dir).info_file} is not a complete Modular SNN run (format {run_info.get('format')!r})."
            )
        backend = request.backend or run_info["backend"]
        progress = request.progress
        data, traverse, reference, query = _run_data(run_dir, run_info, request.data, progress)
        n_members = int(run_info["members"])
        used = n_members if o.members_used is None else int(o.members_used)
        if not 1 <= used <= n_members:
            raise nv.ValidationError(f"--members-used is {used}, but the run has {n_members} member(s).")
        seq_len = request.seq_len
        workers = int(o.workers or default_workers())
        counts = query_responses(
            run_dir, run_info, query, backend=backend, backend_options=request.backend_options, workers=workers,
            scheduler=request.scheduler, progress=progress,
        )  # fmt: skip
        ms = member_similarities(run_dir, run_info, counts, traverse.ground_truth, members=range(used))
        gt = traverse.ground_truth.subset(ms.places, ms.queries)
        result = evaluate_similarities(ms.similarities, reference[ms.places], query[ms.queries], gt, seq_lens=(seq_len,))
        level = result["by_seq_len"][str(seq_len)]
        concentration = level["concentration"]
        report_dir = Path(o.report) if o.report is not None else run_dir / "eval"
        files = write_plots(result, report_dir, seq_len, tag=f"{backend}_L{seq_len}")
        out = {
            "model": self.name,
            "backend": backend,
            "data": str(data),
            "seq_len": seq_len,
            "ensemble_size": used,
            "metrics": level["ensemble"] if used > 1 else level["members"][0],
            "concentration": concentration["ensemble"] if used > 1 else concentration["members"][0],
            "modular_snn": level["members"][0],
            "members": level["members"],
            "mean_of_members": level["mean_of_members"],
            "baselines": level["baselines"],
            "baseline_concentration": {name: concentration[name] for name in level["baselines"]},
            "reported": {"places": int(ms.places.size), "queries": int(ms.queries.size)},
            "calibration": {
                "places": len(run_info["calibration_places"]),
                "hyperactive_thresholds": ms.thresholds,
                "recall_at_1_by_threshold": [{str(k): v for k, v in r.items()} for r in ms.calibration],
            },
            "plan": run_info.get("plan"),
            "files": {k: str(v) for k, v in files.items()},
        }
        json_path = report_dir / f"results_{backend}_L{seq_len}.json"
        out["files"]["json"] = str(json_path)
        atomic_write_text(json_path, json.dumps(out, indent=1))
        return out

    # ------------------------------------------------------------------ infer
    def infer(
        self, run_dir: Path, data: Path | None, backend: str, *, seed: int = 0, current_based: bool = False
    ) -> dict[str, Any]:
        """Run every learned module of ``run_dir`` on ``backend`` over the query set of ``data`` (``neurovpr compare``).

        The learned weights and thresholds run with plasticity off: on a backend that
        learns, the stored networks as ``eval`` runs them; on one that does not, the
        learned STDP projections deployed as static synapses. A backend that cannot run
        the module's conductance-based, adaptive-threshold neurons (Nengo, NengoLoihi,
        Lava) runs its current-based approximation instead (:mod:`.deployment`;
        ``V_ref`` calibrated per module on the reference backend over the module's own
        reference images), and the result's ``notes`` say so; ``current_based=True``
        runs that approximation on any backend (to measure it against the original on
        ``reference``). Before any query, a backend that refuses every form raises
        :class:`~neurovpr.errors.UnsupportedFeatureError` naming the feature. ``seed``
        0 gives the Poisson input of ``eval``. The prediction of a query is the
        ensemble's most similar place; the output counts are the excitatory spike
        counts of every module side by side ``(queries, modules x neurons)``;
        ``seconds_per_query`` is the simulation time of all modules for one query.
        """
        from neurovpr.evaluation.metrics import distance_from_similarity, evaluate

        from .inference import ensemble_similarity
        from .parallel import run_jobs
        from .report import N_VALUES
        from .training import derive_seed

        run_dir = Path(run_dir)
        run_info = RunDir(run_dir).read_info()
        if run_info.get("format") != RUN_FORMAT:
            raise nv.ValidationError(
                f"{RunDir(run_dir).info_file} is not a complete Modular SNN run (format {run_info.get('format')!r})."
            )
        chosen = nv.get_backend(backend)
        learns = chosen.capabilities.learns
        modules = run_info.get("modules") or []
        if not modules:
            raise nv.ValidationError(f"{RunDir(run_dir).info_file} lists no modules; was the run complete?")
        cfg_settings = TrainingSettings.from_dict(run_info["settings"])
        first = _module_network(run_dir, modules[0]["name"])
        form = deployment_form(first, backend, dt=cfg_settings.dt, current_based=current_based)
        data, traverse, reference, query = _run_data(run_dir, run_info, data, True)
        images = np.ascontiguousarray(np.asarray(query, dtype=np.uint8).reshape(len(query), -1))
        cfg = json.dumps(cfg_settings.as_dict(), sort_keys=True)
        ref_rows = np.ascontiguousarray(np.asarray(reference, dtype=np.uint8).reshape(len(reference), -1))
        jobs = []
        for mod in modules:
            path = run_dir / "modules" / f"{mod['name']}.h5"
            if not path.is_file():
                raise nv.ValidationError(f"{path} is missing; the run directory is incomplete.")
            net_bytes = path.read_bytes()
            job_seed = query_seed(mod, seed)
            own = ref_rows[np.asarray(mod["places"], dtype=np.int64)] if form != "original" else ref_rows[:0]
            jobs.append((cfg, backend, net_bytes, job_seed, learns, form, own, derive_seed(int(mod["seed"]), 3)))
        results: dict[int, dict[str, Any]] = {}

        def keep(index: int, result: bytes) -> None:
            with np.load(io.BytesIO(result), allow_pickle=False) as npz:
                results[index] = {k: npz[k] for k in npz.files}

        from tqdm.auto import tqdm

        bar = tqdm(total=len(jobs), desc=f"compare modules ({backend})", unit="module", leave=False)
        try:
            # a backend other than the training one may start its own runtime processes (Lava
            # forks them), which it cannot do inside a spawned worker: deployments run in-process
            workers = default_workers() if backend == run_info.get("backend") else 1
            run_jobs(_infer_job, images, jobs, keep, workers=workers, progress=bar)
        finally:
            bar.close()
        counts = {str(mod["name"]): results[i]["counts"] for i, mod in enumerate(modules)}
        ms = member_similarities(run_dir, run_info, counts, traverse.ground_truth)
        similarity = ensemble_similarity(ms.similarities)
        gt = traverse.ground_truth.subset(ms.places, ms.queries)
        metrics = evaluate(distance_from_similarity(similarity), gt, n_values=N_VALUES)
        n_q = len(query)
        stats = [results[i]["stats"] for i in range(len(modules))]
        keys = [str(k) for k in results[0]["stat_keys"]]
        totals = np.sum(stats, axis=0)
        activity = {k: float(v) / n_q for k, v in zip(keys, totals, strict=True)}
        activity["dt_ms"] = float(json.loads(cfg)["dt"])
        notes = sorted({str(results[i]["note"]) for i in range(len(modules)) if str(results[i]["note"])})
        return {
            "notes": notes,
            "deployment": form,
            "metrics": metrics,
            "predictions": ms.places[np.argmax(similarity, axis=0)].astype(np.int64),
            "output_counts": np.concatenate([counts[str(m["name"])] for m in modules], axis=1)[ms.queries],
            "seconds_per_query": float(sum(float(results[i]["seconds"]) for i in range(len(modules))) / n_q),
            "activity": activity,
        }

    # ------------------------------------------------------------------ sample presentation
    def sample_presentation(self, run_dir: Path, data: Path | None) -> SamplePresentation:
        """The first reported module of ``run_dir`` (learned weights and thresholds) shown the first query image."""
        from .network import INPUT

        run_info = RunDir(run_dir).read_info()
        if run_info.get("format") != RUN_FORMAT:
            raise nv.ValidationError(
                f"{RunDir(run_dir).info_file} is not a complete Modular SNN run (format {run_info.get('format')!r})."
            )
        modules = [mod for mod in run_info.get("modules") or [] if not mod.get("calibration")]
        if not modules:
            raise nv.ValidationError(f"{RunDir(run_dir).info_file} lists no reported module; was the run complete?")
        settings = TrainingSettings.from_dict(run_info["settings"])
        data = data or run_info.get("data")
        if not data:
            raise nv.ValidationError(f"{RunDir(run_dir).info_file} names no dataset; pass --data.")
        traverse = load_traverse(data, run_info.get("places"))
        if traverse.n_query < 1:
            raise nv.ValidationError(f"dataset {data} has no query image to show.")
        image = np.asarray(traverse.query.subset([0]).preprocessed(), dtype=np.uint8).reshape(-1)
        name = modules[0]["name"]
        return SamplePresentation(
            network=_module_network(Path(run_dir), name), inputs={INPUT: settings.coding.rates(image)},
            duration_ms=settings.coding.presentation_ms, dt=settings.dt, title=f"Modular SNN module {name}, query image 0",
        )  # fmt: skip


def _run_data(run_dir: Path, run_info: dict[str, Any], data: Any, progress: bool) -> tuple[Any, Any, np.ndarray, np.ndarray]:
    """``(data, traverse, reference, query)``: the dataset (``data`` or the run's own), checked against what the
    run was trained on (place count and reference-image digest), and its preprocessed reference and query images."""
    data = data or run_info.get("data")
    if not data:
        raise nv.ValidationError(f"{RunDir(run_dir).info_file} names no dataset; pass --data.")
    traverse = load_traverse(data, run_info.get("places"))
    if traverse.n_reference != int(run_info["n_reference"]):
        raise nv.ValidationError(
            f"{data} has {traverse.n_reference} reference places but the run was trained on {run_info['n_reference']}."
        )
    reference = traverse.reference.preprocessed(progress=progress)
    if reference_digest(reference) != run_info.get("reference_digest"):
        raise nv.ValidationError(f"the reference images of {data} differ from those the run in {run_dir} was trained on.")
    return data, traverse, reference, traverse.query.preprocessed(progress=progress)


def _module_network(run_dir: Path, name: str) -> nv.Network:
    path = Path(run_dir) / "modules" / f"{name}.h5"
    if not path.is_file():
        raise nv.ValidationError(f"{path} is missing; the run directory is incomplete.")
    return nv.load(path)


def _infer_job(
    images: np.ndarray,
    settings: str,
    backend: str,
    network: bytes,
    seed: int,
    learns: bool,
    form: str,
    calibration: np.ndarray,
    calibration_seed: int,
) -> bytes:
    """One module's responses to every query, activity counts, time and deployment note, as ``.npz`` bytes.

    Runs in a worker. ``form`` is a :data:`.deployment.FORMS` entry; the current-based
    forms calibrate ``V_ref`` on ``calibration`` (the module's own reference images).
    """
    import time

    from .parallel import _network_from_bytes, npz_bytes
    from .training import Presenter, record_responses

    cfg = TrainingSettings.from_dict(json.loads(settings))
    net = _network_from_bytes(network)
    note = ""
    if form == "original":
        run_net = net if learns else static_network(net)
    else:
        run_net, text = deployed_network(net, form, calibration, coding=cfg.coding, dt=cfg.dt, seed=int(calibration_seed))
        note = text or ""
    sim = nv.compile(run_net, backend=backend, dt=cfg.dt, seed=int(seed))
    try:
        sim.plasticity(False)
        before = sim.statistics()
        start = time.perf_counter()
        counts = record_responses(Presenter(sim, cfg), images)
        seconds = time.perf_counter() - start
        after = sim.statistics()
    finally:
        sim.close()
    keys = ("steps", "neuron_updates", "spikes", "synaptic_events", "plastic_updates")
    stats = np.array([float(after.get(k, 0) - before.get(k, 0)) for k in keys])
    return npz_bytes(counts=counts, stats=stats, stat_keys=np.array(keys), seconds=np.float64(seconds), note=np.array(note))


#: The plugin instance named by the ``neurovpr.models`` entry point.
MODEL = ModularSNNPlugin()
