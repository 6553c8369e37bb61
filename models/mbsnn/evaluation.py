"""Test phase: familiarity along another recording of the route, AUC-ROC, baselines and figures.

:func:`evaluate` replays a test recording through the trained network (plasticity off)
and through the same network with its KC->KC weights back at their initial value (the
naive network), compares the MBON rates window by window (see
:mod:`~neurovpr.models.mbsnn.model`) and scores the windows of the learned segment
(positives, by normalised time) against the rest with the ROC curve. The frame-based
baselines of the paper, SeqSLAM and Perfect Memory
(:mod:`neurovpr.models.route_baselines`), score the same windows from frames of PN
spike counts, learning the frames of the same learned segment.
"""

from __future__ import annotations

import json
import os
import time
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from neurovpr.apps.modelapi import SamplePresentation
from neurovpr.apps.rundir import RunDir
from neurovpr.data.events import PNSpikes, pn_frames
from neurovpr.errors import FileFormatError, ValidationError
from neurovpr.evaluation.metrics import auc_roc, roc
from neurovpr.fileio import atomic_write_text
from neurovpr.hardware.energy import write_activity
from neurovpr.models.route_baselines import perfect_memory_familiarity, seqslam_familiarity

from .model import compile_mbsnn, familiarity, naive_weights, present, segment_labels
from .network import KC_KC, POPULATIONS
from .plots import plot_familiarity, plot_mbon_traces, plot_roc_curves
from .training import SEGMENT_FILE, load_recording, load_spikes, pn_grid

__all__ = ["baseline_scores", "evaluate", "score"]


def baseline_scores(
    learned: PNSpikes, test: PNSpikes, n_windows: int, *, share: float, seq_len: int = 10
) -> dict[str, np.ndarray]:
    """SeqSLAM and Perfect Memory familiarity of each of ``n_windows`` windows of ``test``.

    ``learned`` is the learned segment, ``share`` the fraction of its recording it
    covers; it is cut into ``round(n_windows * share)`` frames (at least 4), so a learned
    frame and a test window cover the same fraction of the route whatever the speeds.
    """
    if learned.n_pn != test.n_pn:
        raise ValidationError(f"baselines: learned frames have {learned.n_pn} PNs but test frames {test.n_pn}.")
    if not 0 < share <= 1:
        raise ValidationError(f"baselines: share must be in (0, 1], got {share!r}.")
    grid, patch = pn_grid(test.n_pn)
    test_frames = pn_frames(test, grid, n_frames=n_windows)
    n_learned = max(round(n_windows * share), 4)
    learned_frames = pn_frames(learned, grid, n_frames=n_learned)
    exclusion = max(0, min(5, (n_learned - 2) // 2))
    return {
        "SeqSLAM": seqslam_familiarity(
            learned_frames, test_frames, patch=patch, seq_len=max(1, min(seq_len, n_windows)), exclusion=exclusion
        ),
        "PerfectMemory": perfect_memory_familiarity(learned_frames, test_frames, patch=patch, exclusion=exclusion),
    }


def score(labels: np.ndarray, scores: np.ndarray) -> dict[str, Any]:
    """AUC-ROC, the ROC curve, and mean scores inside and outside the learned segment."""
    from sklearn.metrics import average_precision_score

    fpr, tpr, _ = roc(labels, scores)
    return {
        "AUC_ROC": round(auc_roc(labels, scores), 6),
        "AUC_PR": round(float(average_precision_score(labels.astype(int), scores)), 6),
        "mean_in_segment": round(float(np.mean(scores[labels])), 6),
        "mean_outside": round(float(np.mean(scores[~labels])), 6),
        "_roc": (fpr, tpr),
    }


def _output_dir(run_dir: Path, data: Path, stretch: float, backend: str) -> Path:
    tag = data.stem if stretch == 1.0 else f"{data.stem}_x{stretch:g}"
    return run_dir / "eval" / f"{tag}_{backend}"


def _run_settings(run_dir: Path, info: dict[str, Any]) -> tuple[float, float, int, float, int, bool, str]:
    """``(start, end, n_pn, dt, seed, trim, backend)`` of a trained run's ``run.json``."""
    try:
        start, end = (float(v) for v in info["learn"])
        return (
            start, end, int(info["n_pn"]), float(info["parameters"]["dt_ms"]), int(info.get("seed", 0)),
            bool(info.get("trim_inactive", True)), str(info["backend"]),
        )  # fmt: skip
    except (KeyError, TypeError, ValueError) as exc:
        raise FileFormatError(f"{RunDir(run_dir).info_file} lacks the mbsnn setting {exc}.") from None


def _trained_network(run: RunDir, n_pn: int) -> Any:
    """The trained mushroom body of ``run``, checked against ``run.json``."""
    network = run.load_network()
    missing = [name for name in POPULATIONS if name not in network.populations]
    if missing:
        raise FileFormatError(f"{run.network_file} is not a mushroom body: it lacks population(s) {', '.join(missing)}.")
    if network.populations["input"].size != n_pn:
        raise FileFormatError(f"{run.network_file} has {network.populations['input'].size} inputs, run.json says {n_pn}.")
    return network


def sample_presentation(
    run_dir: str | os.PathLike[str], info: dict[str, Any], data: str | os.PathLike[str] | None, *, window_ms: float = 500.0
) -> SamplePresentation:
    """The trained mushroom body of ``run_dir`` played the first ``window_ms`` of recording ``data`` (default: the run's)."""
    run_dir = Path(run_dir)
    _, _, n_pn, dt, _, trim, _ = _run_settings(run_dir, info)
    network = _trained_network(RunDir(run_dir), n_pn)
    data = Path(data if data is not None else info["data"])
    test = load_recording(data, n_pn=n_pn, trim=trim, stretch=1.0, what="test recording")
    end = min(float(window_ms), test.duration_ms)
    return SamplePresentation(
        network=network, inputs={"input": test.window(0.0, end).to_source()}, duration_ms=end, dt=dt,
        title=f"MBSNN, first {end:g} ms of {data.stem}",
    )  # fmt: skip


def evaluate(
    run_dir: str | os.PathLike[str],
    info: dict[str, Any],
    *,
    data: str | os.PathLike[str] | None = None,
    backend: str | None = None,
    windows: int = 100,
    stretch: float = 1.0,
    seq_len: int = 10,
    progress: bool = True,
    backend_options: Mapping[str, Any] | None = None,
) -> dict[str, Any]:
    """Evaluate the run in ``run_dir`` on the recording ``data`` (default: the training one).

    ``backend_options`` are passed to :func:`neurovpr.compile` (the backend's own options).

    Writes ``eval/<recording>_<backend>/`` in the run directory: ``result.json``,
    ``mbon.png`` (MBON rates before and after learning, membrane potential), ``roc.png``
    (MBSNN, SeqSLAM and Perfect Memory) and ``familiarity.png``; returns the JSON
    object of ``neurovpr eval --json``.
    """
    run_dir = Path(run_dir)
    if isinstance(windows, bool) or int(windows) != windows or windows < 4:
        raise ValidationError(f"--windows must be an integer >= 4, got {windows!r}.")
    if not (np.isfinite(stretch) and stretch > 0):
        raise ValidationError(f"--stretch must be a finite number > 0, got {stretch!r}.")
    start, end, n_pn, dt, seed, trim, train_backend = _run_settings(run_dir, info)
    backend = backend or train_backend
    data = Path(data if data is not None else info["data"])
    test = load_recording(data, n_pn=n_pn, trim=trim, stretch=stretch, what="test recording")
    labels = segment_labels(int(windows), start, end)
    if labels.all() or not labels.any():
        raise ValidationError(
            f"the learned segment {start}:{end} covers {'all' if labels.any() else 'none'} of the {windows} windows; "
            "use more windows."
        )
    run = RunDir(run_dir)
    network = _trained_network(run, n_pn)
    learned_segment = load_spikes(run.part(SEGMENT_FILE))
    sim = compile_mbsnn(network, dt=dt, backend=backend, seed=seed, **dict(backend_options or {}))
    t0 = time.perf_counter()
    after = present(sim, test, learn=False, progress="test, trained" if progress else None)
    wall = time.perf_counter() - t0
    # the trained pass's activity (counted since compile), per window: the NeuroBench block of `eval --json`
    write_activity(run_dir, sim.statistics(), int(windows), dt_ms=dt, population_spikes=after.counts)
    sim.set_weights(KC_KC, naive_weights(sim))
    before = present(sim, test, learn=False, progress="test, naive" if progress else None)
    rates_before, rates_after = before.rates(int(windows)), after.rates(int(windows))
    scores = {"MBSNN": familiarity(rates_before, rates_after)}
    scores.update(baseline_scores(learned_segment, test, int(windows), share=end - start, seq_len=seq_len))
    results = {name: score(labels, s) for name, s in scores.items()}
    out = _output_dir(run_dir, data, float(stretch), backend)
    plot_mbon_traces(
        out / "mbon.png", rates_before=rates_before, rates_after=rates_after, v_times_ms=after.v_times,
        v_before_mv=before.v, v_after_mv=after.v, duration_ms=after.duration_ms, segment=(start, end),
        title=f"MBON on {data.stem} (learned {start:g}-{end:g} of the route)",
    )  # fmt: skip
    plot_roc_curves(
        {name: (*r["_roc"], r["AUC_ROC"]) for name, r in results.items()}, out / "roc.png",
        title=f"Learned segment vs the rest, {data.stem}",
    )  # fmt: skip
    plot_familiarity(out / "familiarity.png", scores, segment=(start, end))
    clean = {name: {k: v for k, v in r.items() if not k.startswith("_")} for name, r in results.items()}
    metrics = {
        **clean["MBSNN"],
        "mbon_rate_before_hz": round(before.rate_hz, 3),
        "mbon_rate_after_hz": round(after.rate_hz, 3),
        "windows": int(windows),
        "realtime_factor": round(after.duration_ms / 1000.0 / wall, 4) if wall > 0 else None,
    }
    result = {
        "model": "mbsnn",
        "backend": backend,
        "data": str(data),
        "stretch": float(stretch),
        "learned_segment": [start, end],
        "metrics": metrics,
        "baselines": {"SeqSLAM": clean["SeqSLAM"], "PerfectMemory": clean["PerfectMemory"]},
        "familiarity": {name: np.round(s, 6).tolist() for name, s in scores.items()},
        "outputs": {name: str(out / f"{name}.png") for name in ("mbon", "roc", "familiarity")},
    }
    atomic_write_text(out / "result.json", json.dumps(result, indent=2))
    return result
