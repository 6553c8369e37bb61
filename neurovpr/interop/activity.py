"""Activity of a network driven by Poisson input, for graphs that come without a run.

A network imported from another framework (a NIR file) has no recorded run, so
``neurovpr energy`` cannot read its activity. :func:`probe_activity` runs it on the
reference backend with every input neuron firing as a Poisson process at one rate
and returns the per-inference counts in the form of
:func:`neurovpr.hardware.energy.read_activity`.
"""

from __future__ import annotations

import math
import os
import time
from typing import Any

import numpy as np

from neurovpr.errors import ValidationError
from neurovpr.ir.cells import SpikeSourceArray, SpikeSourcePoisson
from neurovpr.ir.network import Network

__all__ = ["probe_activity"]


def _positive(name: str, value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) or value <= 0:
        raise ValidationError(f"probe_activity: {name} must be a finite number > 0, got {value!r}.")
    return float(value)


def probe_activity(
    network: Network,
    *,
    rate_hz: float = 20.0,
    duration_ms: float = 100.0,
    dt: float = 1.0,
    seed: int = 0,
    backend: str = "reference",
    plots: str | os.PathLike[str] | None = None,
) -> dict[str, Any]:
    """Counts of one "inference": ``duration_ms`` of Poisson input at ``rate_hz`` on every source neuron.

    Parameters
    ----------
    network
        The network (its spike sources are driven; their own rates or spike times are replaced).
    rate_hz
        Firing rate of every input neuron.
    duration_ms
        Length of the inference.
    dt
        Simulation time step (ms).
    seed
        Seed of the input spikes and of random connectors.
    backend
        The backend that runs it.
    plots
        A folder: also write the run's spike raster and rate histograms there (``Simulation.plot_activity``).

    Returns
    -------
    dict
        ``inferences`` (1), ``dt_ms``, ``steps``, ``neuron_updates``, ``spikes``,
        ``synaptic_events``, ``plastic_updates``, ``population_spikes``, ``cpu_seconds``.
    """
    from neurovpr.runtime.compiler import compile as nv_compile

    rate_hz, duration_ms, dt = _positive("rate_hz", rate_hz), _positive("duration_ms", duration_ms), _positive("dt", dt)
    if rate_hz * dt / 1000.0 > 1.0:
        raise ValidationError(f"probe_activity: rate {rate_hz:g} Hz exceeds one spike per {dt:g} ms step.")
    sources = [p for p in network.populations.values() if p.is_source]
    if not sources:
        raise ValidationError(f"Network {network.name!r} has no spike source to drive.")
    rng = np.random.default_rng(seed)
    steps = max(1, round(duration_ms / dt))
    inputs: dict[str, Any] = {}
    for pop in sources:
        if isinstance(pop.cell_type, SpikeSourcePoisson):
            inputs[pop.name] = np.full(pop.size, rate_hz)
        elif isinstance(pop.cell_type, SpikeSourceArray):
            fired = rng.random((steps, pop.size)) < rate_hz * dt / 1000.0
            step, neuron = np.nonzero(fired)
            inputs[pop.name] = SpikeSourceArray.from_events(step * dt, neuron, pop.size)
    sim = nv_compile(network, backend=backend, dt=dt, seed=seed)
    start = time.process_time()
    sim.run(steps * dt, inputs=inputs)
    cpu = time.process_time() - start
    stats = sim.statistics()
    out: dict[str, Any] = {"inferences": 1, "dt_ms": dt}
    for key in ("steps", "neuron_updates", "spikes", "synaptic_events", "plastic_updates"):
        out[key] = float(stats.get(key, 0))
    out["population_spikes"] = {name: float(sim.spike_counts(name).sum()) for name in network.populations}
    out["cpu_seconds"] = cpu
    if plots is not None:
        sim.plot_activity(plots)
    return out
