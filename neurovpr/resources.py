"""The resource estimator: memory and work, estimated before anything is allocated or run.

Every place that would allocate in proportion to a user's numbers (``compile``, a
simulation's ``run``, ``neurovpr check``, ``energy``, ``train`` and the event and
``.mat`` readers) asks this module first, and a request past the limit is refused
with one sentence naming the object, the estimate and the limit, instead of failing
later with a ``MemoryError`` or running for days.

Limits (both overridable, read when a check runs):

- **memory**: what this machine has, the smaller of its physical memory and the
  memory limit of its control group (containers). ``NEUROVPR_MAX_MEMORY`` sets
  another value in bytes, with an optional ``K``/``M``/``G``/``T`` suffix (powers of
  1024), e.g. ``NEUROVPR_MAX_MEMORY=64G``.
- **work**: operations of one simulation (one ``run``: every neuron update and
  synaptic event of every step, plus a fixed cost per step), default
  :data:`DEFAULT_MAX_WORK`; ``NEUROVPR_MAX_WORK`` sets another number (e.g.
  ``1e13``). On this project's development machine the reference backend does
  about 10^8 to 10^9 such operations per second, so the default is minutes to hours
  of CPU time for one run.
- **populations and projections**: how many one network may hold, default
  :data:`DEFAULT_MAX_NODES`; ``NEUROVPR_MAX_NODES`` sets another number. Each one is
  decoded, validated, partitioned onto cores and stepped by Python code of its own
  (tens of microseconds to milliseconds each, in every loader, partitioner and
  backend), so their number bounds the work of loading, ``check`` and ``energy``
  whatever their sizes; a file past it is refused before its graph is decoded.

The estimates are deliberately simple upper bounds (8-byte values, a few arrays per
neuron and per synapse); they exist to turn an impossible request into a clear
refusal, not to predict the exact footprint.
"""

from __future__ import annotations

import math
import os
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from neurovpr.errors import ValidationError

__all__ = [
    "ResourceLimitError",
    "DEFAULT_MAX_WORK",
    "DEFAULT_MAX_NODES",
    "node_limit",
    "require_nodes",
    "memory_limit",
    "work_limit",
    "format_bytes",
    "require_memory",
    "require_work",
    "NetworkEstimate",
    "estimate_network",
    "check_network",
    "run_work",
    "check_run",
]

#: Default limit on the operations of one simulation (``NEUROVPR_MAX_WORK`` overrides it).
DEFAULT_MAX_WORK = 1e12
#: Default limit on the populations plus projections of one network (``NEUROVPR_MAX_NODES`` overrides it).
DEFAULT_MAX_NODES = 10_000
#: Operations counted for every simulated step regardless of size (loop and bookkeeping cost).
STEP_COST = 1000.0
#: Fraction of all synapses assumed to carry a spike in one step (a generous upper bound).
ACTIVITY = 0.02
_BYTES_PER_SYNAPSE = 48  # pre, post, weight, delay (8 bytes each) and room for copies made while building
_BYTES_PER_PLASTIC_SYNAPSE = 80  # plus traces and the per-step weight bookkeeping of learning rules
_MEMORY_ENV, _WORK_ENV, _NODES_ENV = "NEUROVPR_MAX_MEMORY", "NEUROVPR_MAX_WORK", "NEUROVPR_MAX_NODES"
_UNITS = {"": 1, "K": 1024, "M": 1024**2, "G": 1024**3, "T": 1024**4, "P": 1024**5}


class ResourceLimitError(ValidationError):
    """A request would need more memory or work than the limit allows."""


def _parse_bytes(text: str) -> int:
    match = re.fullmatch(r"\s*([0-9]*\.?[0-9]+(?:[eE][+-]?[0-9]+)?)\s*([KMGTP]?)(?:i?B)?\s*", text, flags=re.IGNORECASE)
    if match is None:
        raise ValidationError(f"{_MEMORY_ENV}={text!r} is not a size in bytes (examples: 8000000000, 512M, 64G).")
    value = float(match[1]) * _UNITS[match[2].upper()]
    if not math.isfinite(value) or value < 1:
        raise ValidationError(f"{_MEMORY_ENV}={text!r} must be a positive size in bytes.")
    return int(value)


def _machine_memory() -> int:
    try:
        total = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (ValueError, OSError, AttributeError):  # pragma: no cover - not POSIX
        total = 1 << 40
    for cgroup in ("/sys/fs/cgroup/memory.max", "/sys/fs/cgroup/memory/memory.limit_in_bytes"):
        try:
            text = Path(cgroup).read_text().strip()
        except OSError:
            continue
        if text.isdigit() and 0 < int(text) < total:
            total = int(text)
    return int(total)


def memory_limit() -> tuple[int, str]:
    """``(bytes, where the limit comes from)``: ``NEUROVPR_MAX_MEMORY`` or this machine's memory."""
    text = os.environ.get(_MEMORY_ENV)
    if text:
        return _parse_bytes(text), _MEMORY_ENV
    return _machine_memory(), f"this machine's memory; set {_MEMORY_ENV} to change it"


def work_limit() -> tuple[float, str]:
    """``(operations, where the limit comes from)``: ``NEUROVPR_MAX_WORK`` or :data:`DEFAULT_MAX_WORK`."""
    text = os.environ.get(_WORK_ENV)
    if text:
        try:
            value = float(text)
        except ValueError:
            value = math.nan
        if not math.isfinite(value) or value < 1:
            raise ValidationError(f"{_WORK_ENV}={text!r} must be a positive number of operations (e.g. 1e13).")
        return value, _WORK_ENV
    return DEFAULT_MAX_WORK, f"the default; set {_WORK_ENV} to change it"


def node_limit() -> tuple[int, str]:
    """``(count, where the limit comes from)``: ``NEUROVPR_MAX_NODES`` or :data:`DEFAULT_MAX_NODES`."""
    text = os.environ.get(_NODES_ENV)
    if text:
        if not text.strip().isdigit() or int(text) < 1:
            raise ValidationError(f"{_NODES_ENV}={text!r} must be a positive whole number (e.g. 100000).")
        return int(text), _NODES_ENV
    return DEFAULT_MAX_NODES, f"the default; set {_NODES_ENV} to change it"


def require_nodes(populations: int, projections: int, what: str, kinds: tuple[str, str] = ("populations", "projections")) -> None:
    """Refuse ``what`` (a network or a file) when it holds more populations and projections than the limit.

    ``kinds`` names the two counts (a NIR graph has nodes and edges). The sentence
    reads ``"<what> holds 200000 populations and 0 projections (200000 in all); the
    limit is 10000 (...)."``.
    """
    limit, source = node_limit()
    if populations + projections > limit:
        raise ResourceLimitError(
            f"{what} holds {populations} {kinds[0]} and {projections} {kinds[1]} "
            f"({populations + projections} in all); the limit is {limit} ({source})."
        )


def format_bytes(n: float) -> str:
    """``n`` bytes as a short human-readable size (``"74.5 GiB"``)."""
    for unit in ("B", "KiB", "MiB", "GiB", "TiB", "PiB", "EiB"):
        if abs(n) < 1024 or unit == "EiB":
            return f"{n:.0f} {unit}" if unit == "B" else f"{n:.1f} {unit}"
        n /= 1024
    return f"{n:.1f} EiB"  # pragma: no cover


def require_memory(nbytes: float, what: str, detail: str = "", *, limit: tuple[float, str] | None = None) -> None:
    """Refuse when ``what`` needs more than the memory limit.

    ``what`` names the object and the value, e.g. ``"reading 'x.mat' (1e11 values)"``;
    the sentence reads ``"<what> needs about X of memory<detail>; the limit is Y (...)."``.
    ``limit`` is ``(bytes, where it comes from)`` when not the process's limit (e.g. a GPU's free memory).
    """
    limit, source = memory_limit() if limit is None else limit
    if not nbytes <= limit:  # also refuses NaN
        raise ResourceLimitError(
            f"{what} needs about {format_bytes(nbytes)} of memory{detail}; the limit is {format_bytes(limit)} ({source})."
        )


def require_work(operations: float, what: str) -> None:
    """Refuse when ``what`` needs more operations than the work limit (see the module docstring)."""
    limit, source = work_limit()
    if not operations <= limit:
        raise ResourceLimitError(f"{what} needs about {operations:.3g} operations; the limit is {limit:.3g} ({source}).")


# -- networks --------------------------------------------------------------------------
@dataclass(frozen=True, slots=True)
class NetworkEstimate:
    """Upper estimates for one network at one time step.

    Attributes
    ----------
    neurons, synapses
        Neurons (sources included) and expected connections.
    memory
        Bytes to build and hold it, ``{object description: bytes}`` in ``parts``.
    step_work
        Operations of one simulated step.
    """

    neurons: int
    synapses: float
    memory: float
    step_work: float
    parts: dict[str, float]

    def largest(self) -> str:
        """The description of the part that needs the most memory."""
        return max(self.parts, key=self.parts.__getitem__) if self.parts else "the network"


def _distribution_bound(dist: Any, fallback: float) -> float:
    high = getattr(dist, "high", None)
    if high is not None and math.isfinite(high):
        return float(high)
    mean, sigma = getattr(dist, "mu", None), getattr(dist, "sigma", None)
    if mean is not None and sigma is not None:
        return float(mean) + 6.0 * float(sigma)
    return fallback


def _connections(proj: Any, n_pre: int, n_post: int) -> float:
    from neurovpr.ir.connectors import (
        AllToAllConnector,
        ConvolutionConnector,
        FixedNumberPreConnector,
        FixedProbabilityConnector,
        FromListConnector,
        OneToOneConnector,
    )

    conn = proj.connector
    if isinstance(conn, AllToAllConnector):
        return float(n_pre) * n_post
    if isinstance(conn, OneToOneConnector):
        return float(n_pre)
    if isinstance(conn, FromListConnector):
        return float(conn.conn_list.shape[0])
    if isinstance(conn, FixedProbabilityConnector):
        return float(conn.p_connect) * n_pre * n_post
    if isinstance(conn, FixedNumberPreConnector):
        n = conn.n if isinstance(conn.n, int) else max(0.0, _distribution_bound(conn.n, n_pre))
        return float(min(n, n_pre) if not conn.with_replacement else n) * n_post
    if isinstance(conn, ConvolutionConnector):
        c_in = conn.input_shape[0]
        kh, kw = conn.kernel_shape
        return float(np.prod(conn.output_shape, dtype=np.float64)) * c_in * kh * kw
    return float(n_pre) * n_post  # an unknown connector: the dense bound


def _max_delay(proj: Any, dt: float) -> float:
    from neurovpr.ir.connectors import FromListConnector

    delays = [dt]
    spec = proj.synapse.delay
    if isinstance(spec, float):
        delays.append(spec)
    elif isinstance(spec, np.ndarray) and spec.size:
        delays.append(float(np.max(spec)))
    elif spec is not None:
        delays.append(_distribution_bound(spec, dt))
    conn = proj.connector
    if isinstance(conn, FromListConnector) and conn.conn_list.shape[1] == 4 and conn.conn_list.shape[0]:
        delays.append(float(conn.conn_list[:, 3].max()))
    return max(delays)


def estimate_network(network: Any, *, dt: float) -> NetworkEstimate:
    """Estimate what building and simulating ``network`` at time step ``dt`` (ms) needs."""
    parts: dict[str, float] = {}
    neurons = 0
    step_work = STEP_COST
    sizes = {}
    for name, pop in network.populations.items():
        sizes[name] = pop.size
        neurons += pop.size
        n_fields = len(getattr(pop.cell_type, "__dataclass_fields__", ())) + 8
        parts[f"population {name!r} ({pop.size} neurons)"] = float(pop.size) * n_fields * 8
        step_work += pop.size
    synapses = 0.0
    for name, proj in network.projections.items():
        n_pre, n_post = sizes.get(proj.pre, 0), sizes.get(proj.post, 0)
        count = _connections(proj, n_pre, n_post)
        synapses += count
        per = _BYTES_PER_PLASTIC_SYNAPSE if proj.plastic else _BYTES_PER_SYNAPSE
        slots = math.ceil(_max_delay(proj, dt) / dt) + 2 if dt > 0 else math.inf
        buffer = 2.0 * n_post * slots * 8
        parts[f"projection {name!r} ({count:.3g} synapses, delays up to {slots - 2} steps)"] = count * per + buffer
        step_work += count * ACTIVITY * (3.0 if proj.plastic else 1.0)
    memory = float(sum(parts.values()))
    return NetworkEstimate(neurons=neurons, synapses=synapses, memory=memory, step_work=step_work, parts=parts)


def check_network(network: Any, *, dt: float, what: str = "compile", copies: int = 1) -> NetworkEstimate:
    """Refuse ``network`` when building it at ``dt`` needs more than the memory limit; returns the estimate.

    ``copies``: how many are built at once (one per worker process of a training run).

    The sentence names the network and its largest part (the population or
    projection that dominates), e.g. ``"compile: network 'n' needs about 175.0 TiB
    of memory, most of it for population 'a' (10^12 neurons); the limit is ..."``.
    """
    require_nodes(len(network.populations), len(network.projections), f"{what}: network {network.name!r}")
    est = estimate_network(network, dt=dt)
    times = f" x {copies} at once" if copies > 1 else ""
    require_memory(est.memory * copies, f"{what}: network {network.name!r}{times}", f" (most of it for {est.largest()})")
    return est


def run_work(estimate: NetworkEstimate, steps: float) -> float:
    """Operations of ``steps`` simulated steps of a network with this estimate."""
    return float(steps) * estimate.step_work


def check_run(network: Any, *, dt: float, steps: float, what: str = "run") -> None:
    """Refuse a simulation of ``steps`` steps of ``network`` past the memory or work limit."""
    est = check_network(network, dt=dt, what=what)
    require_work(run_work(est, steps), f"{what}: {steps:.3g} steps of {dt:g} ms of network {network.name!r}")
