"""Spike raster and rate histograms of a trained model as it is evaluated (``neurovpr eval --activity-plots DIR``).

A model names one representative presentation of a trained run
(:meth:`~neurovpr.apps.modelapi.ModelPlugin.sample_presentation`: its trained network,
the inputs of the first query, how long and at which step); :func:`plot_sample_activity`
compiles it on the chosen backend with plasticity off, runs it once and writes
:meth:`Simulation.plot_activity <neurovpr.runtime.simulation.Simulation.plot_activity>`'s
``raster.png``, ``rates.png`` and ``activity_summary.json`` into the folder.
"""

from __future__ import annotations

import os
from pathlib import Path

from neurovpr.apps.modelapi import ModelPlugin
from neurovpr.runtime.compiler import compile as compile_network
from neurovpr.runtime.registry import get_backend

__all__ = ["plot_sample_activity"]


def plot_sample_activity(
    model: ModelPlugin,
    run_dir: str | os.PathLike[str],
    data: str | os.PathLike[str] | None,
    backend: str,
    out_dir: str | os.PathLike[str],
    *,
    seed: int = 0,
) -> dict[str, Path]:
    """Simulate ``model``'s sample presentation of ``run_dir`` on ``backend`` and draw its activity into ``out_dir``.

    Parameters
    ----------
    model
        The model that trained ``run_dir``.
    run_dir
        The trained run.
    data
        The dataset whose first query is shown (``None``: the run's own).
    backend
        The backend to simulate on.
    out_dir
        Folder of the plots (created).
    seed
        Seed of the simulation (its Poisson sources).

    Returns
    -------
    dict
        The paths written (``raster``, ``rates``, ``summary``).
    """
    sample = model.sample_presentation(Path(run_dir), None if data is None else Path(data))
    learns = get_backend(backend).capabilities.learns
    sim = compile_network(sample.network, backend=backend, dt=sample.dt, seed=seed)
    try:
        if learns:
            sim.plasticity(False)
        sim.run(sample.duration_ms, inputs=sample.inputs)
        return sim.plot_activity(out_dir, title=sample.title)
    finally:
        sim.close()
