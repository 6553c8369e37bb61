"""TorchSimulation: sources, read-out and the batched drive around :mod:`.build`'s step.

``run`` advances one item (a batch of 1) whose state carries over between runs until
``reset()``; ``run_batch`` simulates its items ``batch_size`` at a time, each from the
reset state. Source spikes are drawn on the host by the backend kit
(:class:`~neurovpr.backendkit.sources.SourceState`, one generator per Poisson population
continuing across resets), item after item, so a batch draws exactly what the loop of
``run`` and ``reset`` on this backend draws.
"""

from __future__ import annotations

import functools
import time
from collections.abc import Callable
from typing import Any, TypeVar

import numpy as np
import torch

from neurovpr.backendkit.hosted import HostedSimulation
from neurovpr.errors import BackendUnavailableError, UnsupportedFeatureError, ValidationError
from neurovpr.hardware.check import HardwareTarget
from neurovpr.ir.cells import IF_cond_exp_adaptive
from neurovpr.ir.network import Network
from neurovpr.runtime.batch import BatchResult

from .build import BatchState, Compiled, spiking
from .capabilities import LEARNING_REFUSAL
from .drive import SourceDrive
from .translation import build_layout

__all__ = ["TorchSimulation", "resolve_device"]

T = TypeVar("T")

#: Steps of source spikes a batch schedules at once (fewer, larger tensor operations; a longer delay ring).
_LEAD = 16

_DTYPES = {"float64": torch.float64, "float32": torch.float32}


def resolve_device(device: str | None) -> torch.device:
    """The device of option ``device``: CUDA when present and none is named, else the named one."""
    if device is None:
        return torch.device("cuda" if torch.cuda.is_available() else "cpu")
    try:
        dev = torch.device(device)
    except (RuntimeError, TypeError):
        raise ValidationError(
            f"torch backend: device {device!r} is not a torch device (use 'cpu', 'cuda' or 'cuda:N')."
        ) from None
    if dev.type == "cuda" and not torch.cuda.is_available():
        raise BackendUnavailableError(f"torch backend: device {device!r} was asked for, but torch sees no CUDA device here.")
    if dev.type not in ("cpu", "cuda"):
        raise ValidationError(f"torch backend: device {device!r} is not supported (use 'cpu' or 'cuda').")
    return dev


def _with_threads(method: Callable[..., T]) -> Callable[..., T]:
    """Run ``method`` with torch's intra-op CPU threads set to the simulation's option ``threads`` (restored after)."""

    @functools.wraps(method)
    def wrapper(self: TorchSimulation, *args: Any) -> T:
        if self._threads is None or self._device.type != "cpu":
            return method(self, *args)
        before = torch.get_num_threads()
        torch.set_num_threads(self._threads)
        try:
            return method(self, *args)
        finally:
            torch.set_num_threads(before)

    return wrapper


class TorchSimulation(HostedSimulation):
    """A network compiled for the ``torch`` backend (options: see :mod:`neurovpr.backends.torch`)."""

    def __init__(
        self,
        network: Network,
        *,
        dt: float,
        seed: int,
        hardware: HardwareTarget | None = None,
        device: str | None = None,
        dtype: str = "float64",
        batch_size: int = 256,
        threads: int | None = 1,
        fuse: bool = False,
    ) -> None:
        super().__init__(network, backend="torch", dt=dt, seed=seed, hardware=hardware)
        if dtype not in _DTYPES:
            raise ValidationError(f"torch backend: dtype must be 'float64' or 'float32', got {dtype!r}.")
        if isinstance(batch_size, bool) or not isinstance(batch_size, (int, np.integer)) or batch_size < 1:
            raise ValidationError(f"torch backend: batch_size must be an integer >= 1, got {batch_size!r}.")
        self._device = resolve_device(device)
        self._dtype = _DTYPES[dtype]
        self._batch_size = int(batch_size)
        if threads is not None and (isinstance(threads, bool) or not isinstance(threads, (int, np.integer)) or threads < 1):
            raise ValidationError(f"torch backend: threads must be an integer >= 1 or None, got {threads!r}.")
        self._threads = None if threads is None else int(threads)
        if not isinstance(fuse, bool):
            raise ValidationError(f"torch backend: fuse must be True or False, got {fuse!r}.")
        self._fuse = fuse
        self._plastic = False  # inference only: weights and thresholds are fixed
        self._theta = np.zeros(0)
        self._state: BatchState | None = None
        self._clear_records()
        self._build()

    @property
    def device(self) -> torch.device:
        """The device the state lives on."""
        return self._device

    # -- building ------------------------------------------------------------
    def _build(self) -> None:
        started = time.perf_counter_ns()
        layout = build_layout(self._network, self._conns, self._values, self._dt)
        theta = [np.zeros(0)]
        for name in self._neuron_pops:
            pop = self._network.populations[name]
            cell = pop.cell_type
            theta.append(
                np.broadcast_to(cell.theta_init, (pop.size,)).astype(np.float64)
                if isinstance(cell, IF_cond_exp_adaptive)
                else np.zeros(pop.size)
            )
        self._theta = np.concatenate(theta)
        self._offsets = {g.name: (g.lo, g.hi) for g in layout.groups}
        self._net = Compiled(layout, self._theta, device=self._device, dtype=self._dtype, dt=self._dt, fuse=self._fuse)
        self._state = None
        self._build_ns += time.perf_counter_ns() - started

    # -- Simulation hooks ----------------------------------------------------
    def _set_plasticity(self, on: bool) -> None:
        if on:
            self._plastic = False
            raise UnsupportedFeatureError(f"Backend 'torch' cannot switch plasticity on: {LEARNING_REFUSAL}.")

    def _set_recording(self, population: str, variable: str, neurons: np.ndarray) -> None:
        self._traces.setdefault((population, variable), [])

    def _clear_records(self) -> None:
        super()._clear_records()
        self._traces: dict[tuple[str, str], list[np.ndarray]] = {key: [] for key in self._recording}

    def _trace(self, population: str, variable: str) -> tuple[np.ndarray, np.ndarray]:
        neurons = self._recording[(population, variable)]
        parts = self._traces.get((population, variable), [])
        values = np.concatenate(parts) if parts else np.zeros((0, self._network.populations[population].size))
        times = (self._steps - values.shape[0] + np.arange(values.shape[0]) + 1) * self._dt
        return times, values[:, neurons]

    def _reset(self) -> None:
        self._state = None
        self._steps = 0
        self._clear_records()

    def _learned_state(self, population: str) -> dict[str, np.ndarray]:
        if population in self._offsets and isinstance(self._network.populations[population].cell_type, IF_cond_exp_adaptive):
            lo, hi = self._offsets[population]
            return {"theta": self._theta[lo:hi].copy()}
        return {}

    @_with_threads
    def _run(self, n_steps: int) -> None:
        started = time.perf_counter_ns()
        if self._state is None:
            self._state = BatchState(self._net, 1, self._dt)
        first = self._steps
        events = {}
        for name, src in self._sources.items():
            steps, neurons = src.events(first, n_steps)
            order = np.argsort(steps, kind="stable")
            steps, neurons = steps[order], neurons[order]
            events[name] = (steps, np.zeros(steps.size, dtype=np.int64), neurons)
            raster = np.zeros((n_steps, self._network.populations[name].size), dtype=bool)
            raster[steps - first, neurons] = True
            self._record.add(name, raster, first, source=True)
        recorded = [key for key in self._recording if key[0] in self._offsets]
        drive = SourceDrive(self._net, events, 1, first, n_steps)
        spikes, traces = self._drive(self._state, drive, events, keep_spikes=True, recorded=recorded)
        for name in self._neuron_pops:
            lo, hi = self._offsets[name]
            raster = np.zeros((n_steps, hi - lo), dtype=bool)
            rows, _, neurons = spikes[name]
            raster[rows - first, neurons] = True
            self._record.add(name, raster, first, source=False)
        for key, values in traces.items():
            self._traces[key].append(values[:, 0, :])
        self._record.add_steps(n_steps)
        self._steps += n_steps
        self._run_ns += time.perf_counter_ns() - started

    @_with_threads
    def _run_batch(
        self,
        n_steps: int,
        items: list[dict[str, Any]],
        populations: list[str],
        spike_trains: bool,
        tick: Callable[[], None] | None,
    ) -> BatchResult:
        started = time.perf_counter_ns()
        counts: dict[str, list[np.ndarray]] = {name: [] for name in populations}
        trains: dict[str, list[tuple[np.ndarray, np.ndarray]]] = {name: [] for name in populations} if spike_trains else {}
        recorded = list(self._recording)
        traces: dict[tuple[str, str], list[np.ndarray]] = {key: [] for key in recorded}

        for lo in range(0, len(items), self._batch_size):
            chunk = items[lo : lo + self._batch_size]
            size = len(chunk)
            events = self._batch_events(chunk, n_steps)
            drive = SourceDrive(self._net, events, size, 0, n_steps)
            state = BatchState(self._net, size, self._dt, lead=_LEAD, extra_bytes=drive.bytes)
            spikes, volts = self._drive(state, drive, events, keep_spikes=spike_trains, recorded=recorded)
            neuron_counts = state.counts.cpu().numpy()
            for name in populations:
                pop_size = self._network.populations[name].size
                if name in events:
                    steps, item, neurons = events[name]
                    per = np.bincount(item * pop_size + neurons, minlength=size * pop_size).reshape(size, pop_size)
                    counts[name].append(per)
                    if spike_trains:
                        trains[name].extend(_split(steps * self._dt, item, neurons, size))
                else:
                    a, b = self._offsets[name]
                    counts[name].append(neuron_counts[:, a:b])
                    if spike_trains:
                        steps, item, neurons = spikes[name]
                        trains[name].extend(_split((steps + 1) * self._dt, item, neurons, size))
            for pop, var in recorded:
                idx = self._recording[(pop, var)]
                traces[(pop, var)].append(np.transpose(volts[(pop, var)][:, :, idx], (1, 0, 2)))
            stats = self._record.stats
            stats["steps"] += size * n_steps
            stats["neuron_updates"] += size * n_steps * self._net.n
            stats["spikes"] += int(neuron_counts.sum()) + sum(int(e[0].size) for e in events.values())
            stats["synaptic_events"] += state.synaptic_events
            if tick is not None:
                for _ in range(size):
                    tick()
        self._reset()
        self._run_ns += time.perf_counter_ns() - started
        return BatchResult(
            counts={name: np.concatenate(parts).astype(np.int64) for name, parts in counts.items()},
            trains={name: tuple(parts) for name, parts in trains.items()},
            traces={key: np.concatenate(parts) for key, parts in traces.items()},
        )

    # -- driving -------------------------------------------------------------
    def _batch_events(self, chunk: list[dict[str, Any]], n_steps: int) -> dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]]:
        """``(steps, items, neurons)`` of every source's spikes, item after item as the loop draws them, sorted by step."""
        parts: dict[str, list[tuple[np.ndarray, np.ndarray, np.ndarray]]] = {name: [] for name in self._sources}
        for k, item in enumerate(chunk):
            for name, value in item.items():
                self._set_input(name, value)
            for name, src in self._sources.items():
                steps, neurons = src.events(0, n_steps)
                parts[name].append((steps, np.full(steps.size, k, dtype=np.int64), neurons))
        out = {}
        for name, pieces in parts.items():
            steps, item, neurons = (np.concatenate(col) for col in zip(*pieces, strict=True))
            order = np.argsort(steps, kind="stable")
            out[name] = (steps[order], item[order], neurons[order])
        return out

    def _drive(
        self,
        state: BatchState,
        drive: SourceDrive,
        events: dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]],
        *,
        keep_spikes: bool,
        recorded: list[tuple[str, str]],
    ) -> tuple[dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]], dict[str, np.ndarray]]:
        """Advance ``state`` over the steps of ``drive`` with the given source events.

        Source spikes reach their targets through ``drive`` (dense blocks) and the delay ring
        (the rest, scheduled ``lead`` steps at a time). Returns each population's spikes
        ``(steps, items, neurons)`` (when ``keep_spikes``) and the ``(n_steps, batch, size)``
        values of each recorded ``(population, variable)``.
        """
        dev, first, n_steps = self._device, drive.first, drive.n_steps
        lead = state.ring - self._net.ring + 1
        bounds, tensors = {}, {}
        for name, (steps, item, neurons) in events.items():
            if name in drive.whole:
                continue
            bounds[name] = np.searchsorted(steps, np.arange(first, first + n_steps + lead), side="left")
            tensors[name] = (
                torch.as_tensor(steps, device=dev),
                torch.as_tensor(item, device=dev),
                torch.as_tensor(neurons, device=dev),
            )
        kept: dict[str, list[tuple[int, torch.Tensor]]] = {name: [] for name in self._neuron_pops}
        volts: dict[tuple[str, str], list[torch.Tensor]] = {key: [] for key in recorded}
        for k in range(n_steps):
            j = first + k
            if k % lead == 0:  # the source spikes of the next `lead` steps, scheduled at once
                for name, (steps, item, neurons) in tensors.items():
                    a, b = bounds[name][k], bounds[name][min(k + lead, n_steps)]
                    if b > a:
                        state.emit(name, item[a:b], neurons[a:b], steps[a:b], dense=False)
            drive.add(state.slot(j), j)  # what sources deliver at step j joins the ring's arrivals
            for name, spikes in state.update(j):
                if keep_spikes:
                    kept[name].append((j, torch.stack(spiking(spikes), 1)))
            for pop, var in recorded:
                lo, hi = self._offsets[pop]
                volts[(pop, var)].append(state.variable(var)[:, lo:hi].clone())
        drive.finish(state)
        state.synaptic_events += drive.synaptic_events
        out = {}
        for name, parts in kept.items():
            nz = [p.cpu().numpy() for _, p in parts]
            steps = np.concatenate(
                [np.full(p.shape[0], j, dtype=np.int64) for (j, _), p in zip(parts, nz, strict=True)] or [np.zeros(0, np.int64)]
            )
            pairs = np.concatenate(nz) if nz else np.zeros((0, 2), dtype=np.int64)
            out[name] = (steps, pairs[:, 0], pairs[:, 1])
        traces = {key: torch.stack(vs).cpu().numpy().astype(np.float64) for key, vs in volts.items() if vs}
        return out, traces


def _split(times: np.ndarray, item: np.ndarray, neurons: np.ndarray, size: int) -> list[tuple[np.ndarray, np.ndarray]]:
    """Per item, ``(times, neurons)`` sorted by time then neuron."""
    out = []
    for k in range(size):
        sel = item == k
        t, i = times[sel], neurons[sel]
        order = np.lexsort((i, t))
        out.append((t[order].astype(np.float64), i[order].astype(np.int64)))
    return out
