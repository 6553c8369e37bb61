"""Learning phase of the mushroom body: one recording's route segment into a run directory.

A run directory written by :func:`train` holds

* ``network.h5`` - the network with its learned KC->KC weights (``nv.save``);
* ``learned_segment.npz`` - the PN spikes of the learned segment (for the frame-based
  baselines at evaluation time);
* ``run.json`` - what was trained and how, written last: a directory without it is an
  unfinished run.
"""

from __future__ import annotations

import io
import os
import time
from pathlib import Path
from typing import Any

import numpy as np

from neurovpr.apps.rundir import NETWORK_FILE, RunDir
from neurovpr.data.events import DAVIS346_BINNING_2020, DAVIS346_BINNING_2023, PNSpikes, load_pn_spikes, stretch_time
from neurovpr.errors import FileFormatError, ValidationError
from neurovpr.fileio import atomic_write_bytes

from .model import check_recording, compile_mbsnn, present
from .network import KC_KC, MBSNNParameters, build_network, check_resources, paper_neuron_count

__all__ = [
    "parse_segment",
    "load_recording",
    "pn_grid",
    "save_spikes",
    "load_spikes",
    "train",
    "SEGMENT_FILE",
]

SEGMENT_FILE = "learned_segment.npz"


def parse_segment(text: str) -> tuple[float, float]:
    """``"START:END"`` (fractions of the recording) -> ``(start, end)`` with ``0 <= start < end <= 1``."""
    parts = str(text).split(":")
    try:
        if len(parts) != 2:
            raise ValueError
        start, end = float(parts[0]), float(parts[1])
    except ValueError:
        raise ValidationError(f"--learn {text!r} is not START:END with two fractions of the recording, e.g. 0.4:0.6.") from None
    if not (np.isfinite(start) and np.isfinite(end) and 0.0 <= start < end <= 1.0):
        raise ValidationError(f"--learn {text!r} must satisfy 0 <= START < END <= 1.")
    return start, end


def load_recording(
    path: str | os.PathLike[str],
    *,
    n_pn: int | None = None,
    trim: bool = True,
    stretch: float = 1.0,
    what: str = "recording",
) -> PNSpikes:
    """PN spikes of a recording: read, refused when empty, trimmed to its moving part, stretched.

    ``trim`` keeps the part where the robot moved (:meth:`PNSpikes.trim_inactive`), so
    two recordings of a route align by normalised time; ``stretch`` multiplies every
    time (2 = the route driven at half speed).
    """
    spikes = load_pn_spikes(path, n_pn=n_pn)
    check_recording(spikes, f"{what} {str(path)!r}")
    if n_pn is not None and spikes.n_pn != n_pn:
        raise ValidationError(f"{what} {str(path)!r} has {spikes.n_pn} projection neurons, expected {n_pn}.")
    if trim:
        spikes = spikes.trim_inactive()
    if stretch != 1.0:
        spikes = stretch_time(spikes, stretch)
    return spikes


def pn_grid(n_pn: int) -> tuple[tuple[int, int], int]:
    """``((rows, cols), patch)``: the mega-pixel grid of the PNs and the baselines' patch size.

    210 and 840 PNs are the DAVIS346 binnings of the 2020 recordings and of the 2023
    paper; any other count is treated as one row (whole-frame contrast normalisation).
    """
    if n_pn == DAVIS346_BINNING_2020.n_pn:
        return DAVIS346_BINNING_2020.grid, 5
    if n_pn == DAVIS346_BINNING_2023.n_pn:
        return DAVIS346_BINNING_2023.grid, 10
    return (1, int(n_pn)), int(n_pn)


def save_spikes(spikes: PNSpikes, path: str | os.PathLike[str]) -> None:
    """Write PN spikes to an ``.npz`` file atomically (plain numeric arrays only)."""
    buf = io.BytesIO()
    np.savez(buf, times_ms=spikes.times_ms, idx=spikes.idx, n_pn=np.int64(spikes.n_pn),
             duration_ms=np.float64(spikes.duration_ms))  # fmt: skip
    atomic_write_bytes(path, buf.getvalue())


def load_spikes(path: str | os.PathLike[str]) -> PNSpikes:
    """Read PN spikes written by :func:`save_spikes` (never unpickles)."""
    try:
        with np.load(path, allow_pickle=False) as data:
            return PNSpikes(
                times_ms=data["times_ms"], idx=data["idx"], n_pn=int(data["n_pn"]), duration_ms=float(data["duration_ms"])
            )
    except (OSError, KeyError, ValueError) as exc:
        raise FileFormatError(f"PN spike file {str(path)!r} is not a readable learned segment ({exc}).") from None


def _existing_run(out: Path, settings: dict[str, Any]) -> dict[str, Any] | None:
    run = RunDir(out)
    if not run.finished or not run.has_network:
        return None
    try:
        info = run.read_info()
    except ValidationError:
        return None
    same = all(info.get(key) == value for key, value in settings.items())
    return info if same else None


def train(
    data: str | os.PathLike[str],
    out: str | os.PathLike[str],
    *,
    learn: tuple[float, float] = (0.4, 0.6),
    params: MBSNNParameters | None = None,
    backend: str = "reference",
    seed: int = 0,
    trim: bool = True,
    stretch: float = 1.0,
    n_pn: int | None = None,
    resume: bool = False,
    progress: bool = True,
) -> dict[str, Any]:
    """Learn the segment ``learn`` of the recording ``data`` and write the run directory ``out``.

    Returns the JSON-ready contents of ``run.json``. With ``resume``, a finished run
    with the same settings in ``out`` is returned as it is.
    """
    params = params if params is not None else MBSNNParameters()
    start, end = learn
    out = Path(out)
    settings = {
        "model": "mbsnn", "data": str(data), "backend": backend, "seed": int(seed),
        "learn": [start, end], "trim_inactive": bool(trim), "stretch": float(stretch),
        "parameters": params.summary(),
    }  # fmt: skip
    if resume and (done := _existing_run(out, settings)) is not None:
        return done
    check_resources(n_pn, params)  # before the recording is read
    spikes = load_recording(data, n_pn=n_pn, trim=trim, stretch=stretch, what="training recording")
    segment = spikes.segment(start, end)
    check_recording(segment, f"the learned segment {start}:{end} of {str(data)!r}")
    network = build_network(spikes.n_pn, params, seed=seed)
    sim = compile_mbsnn(network, dt=params.dt, backend=backend, seed=seed)
    t0 = time.perf_counter()
    response = present(sim, segment, learn=True, progress="learning" if progress else None)
    wall = time.perf_counter() - t0
    weights = sim.weights(KC_KC, format="list")
    run = RunDir(out)
    run.path.mkdir(parents=True, exist_ok=True)
    run.mark_unfinished()  # the directory is unfinished until run.json is back
    run.save_network(sim)
    save_spikes(segment, run.part(SEGMENT_FILE))
    grid, _ = pn_grid(spikes.n_pn)
    info = {
        **settings,
        "dt_ms": params.dt,
        "n_pn": spikes.n_pn,
        "grid": list(grid),
        "network": NETWORK_FILE,
        "learned_segment": SEGMENT_FILE,
        "neurons": paper_neuron_count(network),
        "learning": {
            "duration_ms": response.duration_ms,
            "wall_s": round(wall, 3),
            "realtime_factor": round(response.duration_ms / 1000.0 / wall, 4) if wall > 0 else None,
            "spikes": response.counts,
            "mbon_rate_hz": round(response.rate_hz, 3),
            "kc_kc_potentiated_fraction": round(float(np.mean(weights > 0)), 6),
            "kc_kc_mean_weight_nA": round(float(weights.mean()), 6),
        },
    }
    run.write_info(info)
    return info
