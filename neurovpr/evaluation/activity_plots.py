"""Spike rasters and per-population firing-rate histograms of a simulation, as PNG and JSON.

:func:`plot_activity` takes any :class:`~neurovpr.runtime.simulation.Simulation` (any
backend) after a run and writes ``raster.png`` (one panel per population, time against
neuron index), ``rates.png`` (one histogram of per-neuron firing rates per population) and
``activity_summary.json`` (spike count, mean and maximum rate and silent neurons per population).
Figures use matplotlib's constrained layout, so titles and labels are never clipped; files
are written atomically.
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from neurovpr.errors import ValidationError
from neurovpr.fileio import atomic_write_text, save_figure

__all__ = ["plot_spike_raster", "plot_rate_histograms", "plot_activity", "RASTER_FILE", "RATES_FILE", "SUMMARY_FILE"]

RASTER_FILE = "raster.png"
RATES_FILE = "rates.png"
SUMMARY_FILE = "activity_summary.json"
#: Spikes drawn per raster panel at most (an even subsample beyond it, said in the title).
MAX_DRAWN = 200_000


def _figure(width: float, height: float):
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(width, height), dpi=100, layout="constrained")
    FigureCanvasAgg(fig)
    return fig


def _save(fig: Any, path: str | Path) -> Path:
    if Path(path).suffix.lower() != ".png":
        raise ValidationError(f"plot path {path} must end in .png.")
    return save_figure(fig, path)


def plot_spike_raster(
    trains: Mapping[str, tuple[np.ndarray, np.ndarray]],
    sizes: Mapping[str, int],
    duration_ms: float,
    path: str | Path,
    *,
    title: str = "Spike raster",
) -> Path:
    """One raster panel per population (rows in the order of ``trains``).

    Parameters
    ----------
    trains
        ``(times_ms, neuron_indices)`` per population, as ``Simulation.spike_trains`` gives.
    sizes
        Neurons per population (the panel's height).
    duration_ms
        Length of the run (the time axis).
    path
        The PNG to write.
    title
        The figure's title.
    """
    if not trains:
        raise ValidationError("plot_spike_raster: no population to draw.")
    fig = _figure(8.0, 1.0 + 1.6 * len(trains))
    axes = fig.subplots(len(trains), 1, sharex=True, squeeze=False)[:, 0]
    for ax, (name, (t, idx)) in zip(axes, trains.items(), strict=True):
        t, idx = np.asarray(t, dtype=np.float64), np.asarray(idx)
        label = f"{name} ({t.size} spikes)"
        if t.size > MAX_DRAWN:
            keep = np.linspace(0, t.size - 1, MAX_DRAWN).astype(np.int64)
            t, idx = t[keep], idx[keep]
            label += f", {MAX_DRAWN} drawn"
        ax.scatter(t, idx, s=2, marker="|", linewidths=0.6, color="black")
        ax.set_ylim(-0.5, max(int(sizes[name]), 1) - 0.5)
        ax.set_ylabel("neuron")
        ax.set_title(label, fontsize=9, loc="left")
    axes[-1].set_xlim(0.0, max(float(duration_ms), 1e-9))
    axes[-1].set_xlabel("time (ms)")
    fig.suptitle(title)
    return _save(fig, path)


def plot_rate_histograms(rates_hz: Mapping[str, np.ndarray], path: str | Path, *, title: str = "Firing rates") -> Path:
    """One histogram of per-neuron firing rates (Hz) per population, side by side."""
    if not rates_hz:
        raise ValidationError("plot_rate_histograms: no population to draw.")
    fig = _figure(3.2 * len(rates_hz) + 0.6, 3.4)
    axes = fig.subplots(1, len(rates_hz), squeeze=False)[0]
    for ax, (name, rates) in zip(axes, rates_hz.items(), strict=True):
        r = np.asarray(rates, dtype=np.float64)
        ax.hist(r, bins=min(30, max(5, r.size // 4)), color="tab:blue")
        ax.set_title(f"{name}: mean {r.mean():.3g} Hz", fontsize=9)
        ax.set_xlabel("rate (Hz)")
        ax.set_ylabel("neurons")
    fig.suptitle(title)
    return _save(fig, path)


def plot_activity(
    sim: Any, out_dir: str | Path, *, populations: Sequence[str] | None = None, title: str | None = None
) -> dict[str, Path]:
    """Raster, rate histograms and a JSON summary of ``sim``'s run since its last reset.

    Parameters
    ----------
    sim
        A Simulation after ``run``.
    out_dir
        Folder for ``raster.png``, ``rates.png`` and ``activity_summary.json`` (created if missing).
    populations
        Which populations (default: all, in the network's order).
    title
        What was simulated (default: the network's name); the backend and duration are added.

    Returns
    -------
    dict
        ``{"raster": path, "rates": path, "summary": path}``.
    """
    names = list(sim.network.populations) if populations is None else list(populations)
    unknown = [n for n in names if n not in sim.network.populations]
    if unknown:
        raise ValidationError(f"plot_activity: population {unknown[0]!r} does not exist.")
    duration = float(sim.time)
    if duration <= 0:
        raise ValidationError("plot_activity: the simulation has not run since its last reset.")
    sizes = {n: sim.network.populations[n].size for n in names}
    trains = {n: sim.spike_trains(n) for n in names}
    rates = {n: sim.spike_counts(n) * 1000.0 / duration for n in names}
    out = Path(out_dir)
    title = f"{sim.network.name if title is None else title} on {sim.backend}, {duration:g} ms"
    paths = {
        "raster": plot_spike_raster(trains, sizes, duration, out / RASTER_FILE, title=f"Spike raster: {title}"),
        "rates": plot_rate_histograms(rates, out / RATES_FILE, title=f"Firing rates: {title}"),
    }
    summary = {
        "network": sim.network.name,
        "title": title,
        "backend": sim.backend,
        "duration_ms": duration,
        "populations": {
            n: {
                "neurons": sizes[n],
                "spikes": int(trains[n][0].size),
                "mean_rate_hz": float(rates[n].mean()),
                "max_rate_hz": float(rates[n].max()),
                "silent_neurons": int(np.count_nonzero(rates[n] == 0)),
            }
            for n in names
        },
    }
    atomic_write_text(out / SUMMARY_FILE, json.dumps(summary, indent=2) + "\n")
    paths["summary"] = out / SUMMARY_FILE
    return paths
