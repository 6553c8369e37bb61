"""A Modular SNN run directory: training with resume (plan: :mod:`.plan`), query responses, similarities.

Layout of ``RUN_DIR``::

    run.json                      written last, when every module is trained
    modules/m00_k000.h5           learned network of member 0, module 0 (nv.save)
    modules/m00_k000.npz          its record (places, responses, counts, seed, timing)
    query/<backend>/m00_k000.npz  cached query responses (eval), keyed by the query data

Plan and calibration places: :mod:`.plan`.

Training traverses. Every module trains on its places in the reference traverse and,
when given, in extra reference traverses of the same places (``extra_references``;
see :mod:`.training`). The assignment responses average a place's last training
presentations over all traverses (VPRSNN's ``get_new_assignments`` on the training run);
hyperactive activity is counted over the main reference traverse, as VPRSNN's ``record``
mode shows the first training traverse.

Resume. A module counts as finished when its ``.npz`` record and network file both read
back whole (:func:`neurovpr.apps.rundir.damaged_part`: CRC-32 of the record's members, the
network file's checksum; a damaged one is named and trained again) and the record carries the fingerprint of the same job
(settings, data including every extra traverse's images, places, seeds); a record with
another fingerprint is refused rather than mixed in. Because every module depends only on its own seeds, a resumed run gives
bit-identical files and results to an uninterrupted one on the same backend and machine.
"""

from __future__ import annotations

import hashlib
import json
import sys
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

import neurovpr as nv
from neurovpr.apps.rundir import RunDir, damaged_part
from neurovpr.data.ground_truth import GroundTruth
from neurovpr.fileio import atomic_write_bytes

from .anatomy import place_anatomy
from .inference import (
    SCORES,
    THRESHOLDS,
    assign_neurons,
    calibrate_threshold,
    fuse_modules,
    hyperactive_neurons,
    module_similarity,
)
from .parallel import npz_bytes, query_job, read_npz, run_jobs, train_job
from .plan import ModulePlan, calibration_places, describe_plan, make_plan, query_seed, split_queries
from .training import TrainingSettings, presentation_order

__all__ = [
    "MemberSimilarities",
    "digest",
    "reference_digest",
    "train_run",
    "query_responses",
    "member_similarities",
    "record_assignments",
    "RUN_FORMAT",
]

#: ``run.json`` format tag of this model.
RUN_FORMAT = "neurovpr-modular-snn-run/2"
MEASURES = ("images", "spikes")

def digest(*parts: Any) -> str:
    """SHA-256 of ``parts`` in order: arrays by their bytes, anything else as sorted-key JSON.

    The fingerprint of run files (modules, cached query responses); a caller's own key
    built with it changes exactly when one of its parts does.
    """
    h = hashlib.sha256()
    for part in parts:
        h.update(part.tobytes() if isinstance(part, np.ndarray) else json.dumps(part, sort_keys=True).encode())
        h.update(b"\x00")
    return h.hexdigest()


def reference_digest(reference: np.ndarray) -> str:
    """SHA-256 of preprocessed reference images as the run stores them (``uint8``, one row per image)."""
    return digest(_as_rows(reference))


def _as_rows(images: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray(np.asarray(images, dtype=np.uint8).reshape(len(images), -1))


def _modules_dir(run_dir: Path) -> Path:
    return run_dir / "modules"


def _finished(run_dir: Path, job: ModulePlan, fingerprint: str) -> bool:
    rec_path = _modules_dir(run_dir) / f"{job.name}.npz"
    if not rec_path.is_file():
        return False
    for part in (rec_path, _modules_dir(run_dir) / f"{job.name}.h5"):
        problem = damaged_part(part)
        if problem is not None:
            if problem != "missing":
                print(f"note: {part} is damaged ({problem}); module {job.name} is trained again.", file=sys.stderr)
            return False
    found = str(read_npz(rec_path).get("fingerprint", ""))
    if found != fingerprint:
        raise nv.ValidationError(
            f"{rec_path} was trained with other settings, data or seed than this run; use a new --out folder instead of --resume."
        )
    return True


def train_run(
    run_dir: str | Path,
    reference: np.ndarray,
    settings: TrainingSettings,
    *,
    members: int = 1,
    seed: int = 0,
    place_order: str = "shuffled",
    n_calibration: int = 0,
    hyperactive: str = "images",
    theta: float | None = None,
    score: str = "standard",
    workers: int = 1,
    scheduler: str | None = None,
    resume: bool = False,
    max_modules: int | None = None,
    info: dict[str, Any] | None = None,
    progress: bool = True,
    extra_references: Sequence[np.ndarray] = (),
    only_members: Sequence[int] | None = None,
    seeding: str = "module",
) -> dict[str, Any]:
    """Train every module of every member into ``run_dir``; write ``run.json`` when all are done.

    Parameters
    ----------
    reference
        Preprocessed reference images ``(R, 28, 28)`` (0..255).
    settings
        Graph, coding and training settings.
    members, seed, place_order, n_calibration
        Ensemble size, master seed, how places are cut into modules and how many are
        calibration places (see the module docstring).
    hyperactive, theta, score
        Hyperactive measure (``"images"`` or ``"spikes"``), a fixed threshold (``None``:
        calibrated per member at evaluation, or 0 without calibration places) and the
        place score (``"standard"`` or ``"sum"``), stored for evaluation.
    workers, scheduler
        Local worker processes, or a Dask scheduler address.
    resume
        Skip finished modules; without it ``run_dir`` must not hold modules yet.
    max_modules
        Train at most this many of the unfinished modules, then stop (resume later).
    info
        Extra entries for ``run.json`` (dataset path, place count, ...).
    extra_references
        Further preprocessed reference traverses of the same ``R`` places in the same
        order, each ``(R, 28, 28)``, trained on together with ``reference`` (see the
        module docstring); their digests enter every module's fingerprint and
        ``run.json`` (``extra_reference_digests``).
    only_members
        Train the modules of these members only (indices into ``0..members-1``), e.g. to
        spread the members of one ensemble over several machines; every member's
        modules are seeded by the master seed and the member index alone, so a member
        trained this way is the member a full run trains.
    seeding
        ``"module"`` (every module its own random draws) or ``"code"`` (VPRSNN's: every module
        of a member the same initial weights, delays and Poisson streams); see :mod:`.plan`.
        Stored in ``run.json`` with every module's seeds.

    Returns
    -------
    dict
        A summary: the plan, modules trained now and skipped, timing per module, and
        ``"complete"`` (with ``"remaining_modules"`` when modules are left). When every
        module of the chosen members (``only_members``, or all) is finished,
        ``"run_info"`` holds what ``run.json`` would hold for those members alone (their
        modules), for :func:`query_responses` and :func:`member_similarities`.
    """
    run_dir = Path(run_dir)
    images = _as_rows(reference)
    n_ref = images.shape[0]
    extras = [_as_rows(extra) for extra in extra_references]
    for k, extra in enumerate(extras, start=1):
        if extra.shape != images.shape:
            raise nv.ValidationError(
                f"extra reference traverse {k} has {extra.shape[0]} images of {extra.shape[1]} pixels, but the reference has "
                f"{n_ref} of {images.shape[1]}; it must hold the same places in the same order."
            )
    if hyperactive not in MEASURES:
        raise nv.ValidationError(f"hyperactive measure is {hyperactive!r}, expected one of {', '.join(MEASURES)}.")
    if score not in SCORES:
        raise nv.ValidationError(f"place score is {score!r}, expected one of {', '.join(SCORES)}.")
    if theta is not None and not (np.isfinite(theta) and theta >= 0):
        raise nv.ValidationError(f"hyperactive threshold theta is {theta!r}, expected a number >= 0.")
    if max_modules is not None and max_modules < 1:
        raise nv.ValidationError(f"max modules is {max_modules}, expected at least 1.")
    chosen = set(range(int(members))) if only_members is None else {int(m) for m in only_members}
    if not chosen or not chosen <= set(range(int(members))):
        raise nv.ValidationError(f"only_members {sorted(chosen)} must name members among 0..{int(members) - 1}.")
    existing = _modules_dir(run_dir).is_dir() and any(_modules_dir(run_dir).iterdir())
    if (existing or RunDir(run_dir).info_file.exists()) and not resume:
        raise nv.ValidationError(f"{run_dir} already holds a run; pass --resume to continue it or choose another --out.")
    plan = make_plan(n_ref, settings.module_size, members, seed, place_order, n_calibration, seeding)
    cfg = json.dumps(settings.as_dict(), sort_keys=True)
    data_digest = digest(images)
    extra_digests = [digest(extra) for extra in extras]
    # without extra traverses the fingerprint is the one of single-traverse runs (they stay resumable)
    extra_part = (extra_digests,) if extras else ()
    # the shared seeds join the fingerprint only when they exist, so that runs seeded per module stay resumable
    prints = [digest(cfg, data_digest, j.places, j.seed, j.name, *extra_part, *j.apart_seeds) for j in plan]
    n_chosen = sum(1 for j in plan if j.member in chosen)
    todo = [i for i, j in enumerate(plan) if j.member in chosen and not _finished(run_dir, j, prints[i])]
    skipped = n_chosen - len(todo)
    if max_modules is not None:
        todo = todo[:max_modules]
    _modules_dir(run_dir).mkdir(parents=True, exist_ok=True)
    timings: list[dict[str, float]] = []

    def write(index: int, result: dict[str, Any]) -> None:
        job = plan[todo[index]]
        atomic_write_bytes(_modules_dir(run_dir) / f"{job.name}.h5", result["network"])
        atomic_write_bytes(_modules_dir(run_dir) / f"{job.name}.npz", result["record"])
        timings.append(result["timing"])

    n_traverses = 1 + len(extras)
    shared = np.concatenate([images, *extras], axis=0) if extras else images
    jobs = [
        (cfg, f"modular_snn_{plan[i].name}", plan[i].places, plan[i].seed, prints[i], n_traverses, *plan[i].apart_seeds)
        for i in todo
    ]
    start = time.perf_counter()
    bar = _bar(n_chosen, skipped, "training modules", progress)
    try:
        run_jobs(train_job, shared, jobs, write, workers=workers, scheduler=scheduler, progress=bar)
    finally:
        if bar is not None:
            bar.close()
    wall = time.perf_counter() - start
    unfinished = [j for i, j in enumerate(plan) if not _finished(run_dir, j, prints[i])]
    remaining = len(unfinished)
    summary: dict[str, Any] = {
        "run": str(run_dir),
        "plan": describe_plan(n_ref, settings.module_size, n_calibration),
        "members": int(members),
        "modules_per_member": len(plan) // int(members),
        "training_traverses": n_traverses,
        "trained_now": len(todo),
        "skipped_finished": skipped,
        "wall_seconds": round(wall, 3),
    }
    if timings:
        for key in ("train_seconds", "train_cpu_seconds", "record_seconds", "record_cpu_seconds"):
            summary[f"{key}_per_module"] = round(float(np.mean([t[key] for t in timings])), 3)
    if remaining:
        summary.update(complete=False, remaining_modules=remaining)
    if any(j.member in chosen for j in unfinished):
        return summary
    done = [j for j in plan if j.member in chosen]
    records = [read_npz(_modules_dir(run_dir) / f"{j.name}.npz") for j in done]
    run_info = {
        "model": "modular",
        "format": RUN_FORMAT,
        "dt_ms": settings.dt,
        "backend": settings.backend,
        "seed": int(seed),
        "n_reference": n_ref,
        "reference_digest": data_digest,
        "training_traverses": n_traverses,
        "extra_reference_digests": extra_digests,
        "members": int(members),
        "module_size": settings.module_size,
        "place_order": place_order,
        "seeding": seeding,
        "plan": describe_plan(n_ref, settings.module_size, n_calibration),
        "calibration_places": calibration_places(n_ref, n_calibration).tolist(),
        "hyperactive": {"measure": hyperactive, "theta": None if theta is None else float(theta), "thresholds": list(THRESHOLDS)},
        "score": score,
        "settings": settings.as_dict(),
        "modules": [
            {
                "member": j.member, "module": j.module, "name": j.name, **j.seeds, "places": j.places.tolist(),
                "calibration": j.calibration,
            }
            for j in done
        ],
        **{
            f"{key}_per_module": round(float(np.mean([float(r[key]) for r in records])), 3)
            for key in ("train_seconds", "train_cpu_seconds", "record_seconds", "record_cpu_seconds")
        },
        **(info or {}),
    }
    summary["run_info"] = run_info
    if remaining:
        return summary
    RunDir(run_dir).write_info(run_info, indent=1)
    summary.update(complete=True)
    return summary


def _bar(total: int, initial: int, desc: str, enabled: bool) -> Any:
    if not enabled:
        return None
    from tqdm.auto import tqdm

    return tqdm(total=total, initial=initial, desc=desc, unit="module")


def _modules(run_info: dict[str, Any]) -> list[dict[str, Any]]:
    mods = run_info.get("modules")
    if not isinstance(mods, list) or not mods:
        raise nv.ValidationError("run.json lists no modules; was the run complete?")
    return mods


def query_responses(
    run_dir: str | Path,
    run_info: dict[str, Any],
    query: np.ndarray,
    *,
    backend: str | None = None,
    backend_options: Mapping[str, Any] | None = None,
    workers: int = 1,
    scheduler: str | None = None,
    progress: bool = True,
) -> dict[str, np.ndarray]:
    """Spike counts ``(Q, n)`` of every module for the query images, by module name (cached in the run).

    ``backend_options`` are passed to :func:`neurovpr.compile` (e.g. the torch backend's
    ``dtype`` and ``fuse``). The cache file of a module holds the digest of the query
    images, the backend, its options and the module network's digest; any difference
    recomputes it.
    """
    run_dir = Path(run_dir)
    backend = backend or run_info["backend"]
    settings = TrainingSettings.from_dict(run_info["settings"])
    cfg = json.dumps(settings.as_dict(), sort_keys=True)
    images = _as_rows(query)
    q_digest = digest(images)
    options = json.dumps(dict(backend_options or {}), sort_keys=True)
    cache = run_dir / "query" / backend
    out: dict[str, np.ndarray] = {}
    jobs, names, keys = [], [], []
    for mod in _modules(run_info):
        name = str(mod["name"])
        h5 = _modules_dir(run_dir) / f"{name}.h5"
        if not h5.is_file():
            raise nv.ValidationError(f"{h5} is missing; the run directory is incomplete.")
        net_bytes = h5.read_bytes()
        # the options and a shared stream seed join the key only when given, so that caches written without them stay valid
        seed = query_seed(mod)
        key = digest(
            q_digest, backend, *([options] if backend_options else []), hashlib.sha256(net_bytes).hexdigest(),
            *([seed] if "stream_seed" in mod and int(mod["stream_seed"]) != int(mod["seed"]) else []),
        )
        cached = cache / f"{name}.npz"
        if cached.is_file():
            rec = read_npz(cached)
            if str(rec.get("key", "")) == key:
                out[name] = rec["counts"]
                continue
        jobs.append((cfg, backend, options, net_bytes, seed))
        names.append(name)
        keys.append(key)

    def write(index: int, counts: np.ndarray) -> None:
        atomic_write_bytes(cache / f"{names[index]}.npz", npz_bytes(counts=counts, key=np.str_(keys[index])))
        out[names[index]] = counts

    bar = _bar(len(_modules(run_info)), len(out), f"query responses ({backend})", progress)
    try:
        run_jobs(query_job, images, jobs, write, workers=workers, scheduler=scheduler, progress=bar)
    finally:
        if bar is not None:
            bar.close()
    return out


@dataclass(frozen=True, slots=True)
class MemberSimilarities:
    """What :func:`member_similarities` returns.

    Attributes
    ----------
    similarities
        One ``(len(places), len(queries))`` matrix per member.
    places, queries
        The reported reference places and queries (sorted global indices): every one
        but the calibration places and queries.
    thresholds
        Each member's hyperactive threshold (calibrated, fixed, or 0).
    calibration
        Each member's calibration Recall@1 per candidate threshold (empty when none was calibrated).
    anatomy
        Each member's :func:`.anatomy.place_anatomy` of the reported places (rows as in ``similarities``).
    """

    similarities: list[np.ndarray]
    places: np.ndarray
    queries: np.ndarray
    thresholds: list[float]
    calibration: list[dict[float, float]]
    anatomy: list[dict[str, np.ndarray]]


def record_assignments(record: Mapping[str, np.ndarray]) -> np.ndarray:
    """The place of each neuron of a module record (``modules/*.npz``), -1 if it never fired.

    :func:`.inference.assign_neurons` on the record's ``own_responses``, ties broken by the
    order the module showed its places in, derived from the record's seed
    (:func:`.training.presentation_order`).
    """
    places = np.asarray(record["places"], dtype=np.int64)
    return assign_neurons(record["own_responses"], places, order=presentation_order(int(record["seed"]), places.size))


def member_similarities(
    run_dir: str | Path,
    run_info: dict[str, Any],
    counts: dict[str, np.ndarray],
    ground_truth: Any,
    members: Sequence[int] | None = None,
) -> MemberSimilarities:
    """Each member's similarity matrix on the reported places and queries: assignment, hyperactive removal, fusion.

    ``counts`` holds every module's spike counts for every query; ``ground_truth`` is the
    full ``[reference, query]`` ground truth (it separates the calibration queries, see
    :func:`split_queries`). A member's threshold is ``run_info``'s fixed one, or, with
    calibration places, the one :func:`.inference.calibrate_threshold` picks from its
    calibration modules, or 0. ``members`` (default: every member with modules in
    ``run_info``) chooses which, in that order.
    """
    run_dir = Path(run_dir)
    n_ref = int(run_info["n_reference"])
    fixed = run_info["hyperactive"]["theta"]
    measure = run_info["hyperactive"]["measure"]
    thresholds = run_info["hyperactive"]["thresholds"]
    score = run_info["score"]
    cal_places = np.asarray(run_info["calibration_places"], dtype=np.int64)
    cal_queries, queries = split_queries(ground_truth, cal_places)
    places = np.setdiff1d(np.arange(n_ref), cal_places)
    if cal_places.size and cal_queries.size == 0:
        raise nv.ValidationError("no query matches only calibration places, so the hyperactive threshold cannot be calibrated.")
    chosen = sorted({int(mod["member"]) for mod in _modules(run_info)}) if members is None else list(members)
    out = MemberSimilarities([], places, queries, [], [], [])
    for m in chosen:
        parts: dict[bool, list[tuple[np.ndarray, np.ndarray, np.ndarray]]] = {True: [], False: []}
        for mod in _modules(run_info):
            if int(mod["member"]) != int(m):
                continue
            rec = read_npz(_modules_dir(run_dir) / f"{mod['name']}.npz")
            assignments = record_assignments(rec)
            activity = rec["images_fired"] if measure == "images" else rec["total_spikes"]
            parts[bool(mod.get("calibration", False))].append((counts[mod["name"]], assignments, activity))
        recall: dict[float, float] = {}
        if fixed is not None:
            theta = float(fixed)
        elif parts[True]:
            calibration = [(c[cal_queries], a, act) for c, a, act in parts[True]]
            gt = _subset_ground_truth(ground_truth, np.sort(cal_places), cal_queries)
            theta, recall = calibrate_threshold(calibration, n_ref, np.sort(cal_places), gt, score=score, thresholds=thresholds)
        else:
            theta = 0.0
        fused = fuse_modules(
            [
                module_similarity(c[queries], a, n_ref, ignore=hyperactive_neurons(act, theta), score=score)
                for c, a, act in parts[False]
            ]
        )
        out.similarities.append(fused[places])
        out.thresholds.append(theta)
        out.calibration.append(recall)
        anatomy = place_anatomy([(a, act) for _, a, act in parts[False]], theta, n_ref)
        out.anatomy.append({name: values[places] for name, values in anatomy.items()})
    return out


def _subset_ground_truth(ground_truth: Any, places: np.ndarray, queries: np.ndarray) -> GroundTruth:
    matrix = np.asarray(getattr(ground_truth, "matrix", ground_truth), dtype=bool)
    return GroundTruth(matrix=matrix[places][:, queries])
