"""``neurovpr.compile``: turn a network into a runnable simulation on a named backend."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from neurovpr.errors import ValidationError
from neurovpr.hardware.check import hardware_target
from neurovpr.ir.network import Network
from neurovpr.resources import check_network
from neurovpr.runtime.registry import get_backend
from neurovpr.runtime.simulation import Simulation

__all__ = ["compile"]


def compile(
    network: Network,
    backend: str = "reference",
    *,
    dt: float = 0.1,
    seed: int | None = None,
    hardware: str | None = None,
    **options: Any,
) -> Simulation:
    """Compile ``network`` for ``backend``.

    Parameters
    ----------
    network
        The graph to run.
    backend
        A backend name from ``neurovpr backends``.
    dt
        Time step in ms (PyNN's default 0.1 ms).
    seed
        Seed of every random draw (connectivity, weights, Poisson spikes). ``None``
        draws a fresh seed, readable afterwards as ``Simulation.seed``.
    hardware
        A hwspec name or ``.toml`` path: partition the network onto that chip once, with
        this ``dt`` and ``seed``, refuse it unless it fits, and compute in the arithmetic
        of its ``[formats]`` (backends list the arithmetics they emulate in their
        capabilities). The simulation's ``hardware`` holds that partition.
    **options
        Backend-specific options (see each backend's documentation).

    Returns
    -------
    Simulation
        The compiled simulation.
    """
    if not isinstance(network, Network):
        raise ValidationError(f"compile: expected a neurovpr Network, got {type(network).__name__}.")
    if isinstance(dt, bool) or not isinstance(dt, (int, float, np.integer, np.floating)):
        raise ValidationError(f"compile: dt must be a number of ms, got {dt!r}.")
    if not math.isfinite(float(dt)) or not 0 < float(dt) <= 10.0:
        raise ValidationError(f"compile: dt must be in (0, 10] ms, got {dt!r}.")
    if seed is None:
        seed = int(np.random.SeedSequence().generate_state(1)[0])
    elif isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or not 0 <= seed < 2**63:
        raise ValidationError(f"compile: seed must be an integer in [0, 2**63), got {seed!r}.")
    check_network(network, dt=float(dt), what="compile")
    target = None if hardware is None else hardware_target(network, hardware, dt=float(dt), seed=int(seed))
    return get_backend(backend).compile(network, dt=float(dt), seed=int(seed), hardware=target, **options)
