"""The Simulation interface every backend implements.

:class:`Simulation` validates every argument a user passes and then calls the
backend's ``_``-prefixed hooks with clean values, so each backend implements the
mechanics once and the error messages are the same everywhere.

Semantics shared by all backends:

- Times are in ms; ``run(duration)`` advances ``round(duration / dt)`` steps.
- ``inputs`` set source activity for this and later runs: a rate (Hz, one value or
  one per neuron) for a ``SpikeSourcePoisson``, spike times (absolute ms since the
  last reset) for a ``SpikeSourceArray``.
- ``reset()`` returns time to 0 and restores the dynamic state (membrane,
  synaptic currents and conductances, refractoriness, plasticity traces,
  calcium current, spikes in flight) and clears recordings, but keeps what was
  learned: weights and adaptive thresholds (as PyNN keeps weights).
- ``plasticity(False)`` freezes learning: weights and adaptive thresholds.
- ``run_batch(duration, inputs=[...])`` runs independent items from the reset state
  (:mod:`neurovpr.runtime.batch`).
"""

from __future__ import annotations

import math
import os
from abc import ABC, abstractmethod
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal, Mapping

import numpy as np

from neurovpr.errors import SimulationError, ValidationError
from neurovpr.ir.cells import IF_cond_exp_adaptive, SpikeSourceArray, SpikeSourcePoisson
from neurovpr.ir.connectivity import resolved_seed
from neurovpr.ir.connectors import ConvolutionConnector, FromListConnector
from neurovpr.ir.network import Network
from neurovpr.resources import estimate_network, require_work
from neurovpr.runtime.batch import BatchResult, run_items
from neurovpr.runtime.weights import check_normalisation, check_weight_range, normalised

if TYPE_CHECKING:
    from neurovpr.hardware.check import HardwareTarget

__all__ = ["Simulation"]


class Simulation(ABC):
    """A compiled network on one backend.

    Parameters
    ----------
    network
        The network (a private copy is kept; later changes to it do not apply).
    backend
        The backend's name.
    dt
        Time step in ms.
    seed
        The seed all random draws derive from.
    hardware
        The hardware target it was compiled for (``nv.compile(..., hardware=...)``), if any.
    """

    def __init__(
        self, network: Network, *, backend: str, dt: float, seed: int, hardware: HardwareTarget | None = None
    ) -> None:
        self._network = network.copy()
        self._backend = backend
        self._dt = float(dt)
        self._seed = int(seed)
        self._hardware = hardware
        self._plastic = True
        self._recording: dict[tuple[str, str], np.ndarray] = {}
        self._step_work = estimate_network(self._network, dt=self._dt).step_work

    # -- read-only facts ---------------------------------------------------
    @property
    def network(self) -> Network:
        """The network this simulation was compiled from (a copy)."""
        return self._network

    @property
    def backend(self) -> str:
        """Name of the backend running it."""
        return self._backend

    @property
    def dt(self) -> float:
        """Time step (ms)."""
        return self._dt

    @property
    def seed(self) -> int:
        """Seed of every random draw."""
        return self._seed

    @property
    def hardware(self) -> HardwareTarget | None:
        """The hardware target compiled for: the hwspec and the one partition of the network on it.

        That partition gave the fit verdict, sets the core blocks the chip's arithmetic
        works in, and is the one to pass to :func:`neurovpr.hardware.estimate_energy`
        (``partition=sim.hardware.partition``). ``None`` without ``hardware=``.
        """
        return self._hardware

    @property
    def plasticity_enabled(self) -> bool:
        """Whether plastic synapses and adaptive thresholds learn."""
        return self._plastic

    @property
    @abstractmethod
    def time(self) -> float:
        """Simulated time since the last reset (ms)."""

    # -- driving -----------------------------------------------------------
    def run(self, duration: float, inputs: Mapping[str, Any] | None = None) -> None:
        """Advance the simulation by ``duration`` ms, first applying ``inputs``."""
        n_steps = self._steps_of(duration, "run")
        if inputs is not None and not isinstance(inputs, Mapping):
            raise ValidationError(
                f"run: inputs must be a mapping {{population name: rates or spike times}}, got {type(inputs).__name__}; "
                f"the sources are {', '.join(repr(n) for n, p in self._network.populations.items() if p.is_source) or 'none'}."
            )
        what = f"run: {duration:g} ms ({n_steps} steps of {self._dt:g} ms) of network {self._network.name!r}"
        require_work(n_steps * self._step_work, what)
        clean: dict[str, Any] = {}
        for name, value in (inputs or {}).items():
            clean[name] = self._check_input(name, value)
        for name, value in clean.items():
            self._set_input(name, value)
        self._run(n_steps)

    def run_batch(
        self,
        duration: float,
        inputs: Sequence[Mapping[str, Any]],
        *,
        populations: Sequence[str] | None = None,
        spike_trains: bool = False,
        tick: Callable[[], None] | None = None,
    ) -> BatchResult:
        """Run independent items, each for ``duration`` ms from the reset state; what each produced.

        Item ``k`` equals ``run(duration, inputs=inputs[k])``, reading the spikes and
        recorded variables, then ``reset()`` (see :mod:`neurovpr.runtime.batch`); a backend
        may run the items at once. The simulation must be at time 0 (just compiled or
        reset) and is reset afterwards.

        Parameters
        ----------
        duration
            Length of every item (ms, a whole number of steps).
        inputs
            One mapping ``{source population: rates or spike times}`` per item, all naming
            the same sources.
        populations
            Populations whose spikes are returned (default: all).
        spike_trains
            Also return every item's spike trains.
        tick
            Called once per finished item (progress reporting).
        """
        n_steps = self._steps_of(duration, "run_batch")
        if isinstance(inputs, Mapping) or not isinstance(inputs, Sequence) or len(inputs) == 0:
            raise ValidationError(
                f"run_batch: inputs must be a non-empty sequence of mappings (one per item), got {type(inputs).__name__}."
            )
        if self.time != 0:
            raise SimulationError(
                f"run_batch: network {self._network.name!r} is at {self.time:g} ms; items start from the reset state, "
                "call reset() first."
            )
        names = populations if populations is not None else list(self._network.populations)
        for name in names:
            self._population(name)
        items: list[dict[str, Any]] = []
        for k, item in enumerate(inputs):
            if not isinstance(item, Mapping):
                raise ValidationError(
                    f"run_batch: inputs[{k}] must be a mapping of source populations, got {type(item).__name__}."
                )
            if items and set(item) != set(items[0]):
                raise ValidationError(
                    f"run_batch: inputs[{k}] names sources {sorted(item)}, inputs[0] names {sorted(items[0])}; "
                    "every item must name the same sources."
                )
            items.append({name: self._check_input(name, value) for name, value in item.items()})
        what = (
            f"run_batch: {len(items)} items of {duration:g} ms ({n_steps} steps of {self._dt:g} ms) "
            f"of network {self._network.name!r}"
        )
        require_work(len(items) * n_steps * self._step_work, what)
        return self._run_batch(n_steps, items, list(names), bool(spike_trains), tick)

    def _steps_of(self, duration: Any, what: str) -> int:
        """Whole steps in ``duration`` ms (validated)."""
        if isinstance(duration, bool) or not isinstance(duration, (int, float, np.integer, np.floating)):
            raise ValidationError(f"{what}: duration must be a number of ms, got {duration!r}.")
        duration = float(duration)
        if not math.isfinite(duration) or duration <= 0:
            raise ValidationError(f"{what}: duration must be a positive finite number of ms, got {duration!r}.")
        n_steps = round(duration / self._dt)
        if n_steps < 1 or abs(n_steps * self._dt - duration) > 1e-6 * max(1.0, duration):
            raise ValidationError(f"{what}: duration {duration!r} ms is not a whole number of {self._dt:g} ms steps.")
        return n_steps

    def reset(self) -> None:
        """Time to 0, dynamic state to initial values, recordings cleared; learning kept."""
        self._reset()

    def plasticity(self, on: bool) -> None:
        """Switch learning (weights and adaptive thresholds) on or off."""
        if not isinstance(on, (bool, np.bool_)):
            raise ValidationError(f"plasticity: expected True or False, got {on!r}.")
        self._plastic = bool(on)
        self._set_plasticity(self._plastic)

    def record(self, population: str, variable: str, neurons: Any = None) -> None:
        """Record a state variable of some neurons (all by default) from the next run on."""
        pop = self._population(population)
        allowed = type(pop.cell_type).recordable
        if variable not in allowed:
            raise ValidationError(
                f"record: {type(pop.cell_type).__name__} population {population!r} has no recordable "
                f"variable {variable!r} (recordable: {', '.join(allowed) or 'none'})."
            )
        idx = np.arange(pop.size) if neurons is None else np.unique(np.asarray(neurons, dtype=np.int64).ravel())
        if idx.size == 0 or idx.min() < 0 or idx.max() >= pop.size:
            raise ValidationError(f"record: neuron indices for {population!r} must lie in 0..{pop.size - 1}.")
        self._recording[(population, variable)] = idx
        self._set_recording(population, variable, idx)

    # -- reading -----------------------------------------------------------
    def spike_counts(self, population: str) -> np.ndarray:
        """Spikes per neuron since the last reset (``int64`` array)."""
        self._population(population)
        return np.asarray(self._spike_counts(population), dtype=np.int64)

    def spike_trains(self, population: str) -> tuple[np.ndarray, np.ndarray]:
        """``(times_ms, neuron_indices)`` of every spike since the last reset, sorted by time."""
        self._population(population)
        times, idx = self._spike_trains(population)
        return np.asarray(times, dtype=np.float64), np.asarray(idx, dtype=np.int64)

    def trace(self, population: str, variable: str) -> tuple[np.ndarray, np.ndarray]:
        """``(times_ms, values)`` of a recorded variable; ``values`` is ``(n_times, n_neurons)``."""
        self._population(population)
        if (population, variable) not in self._recording:
            raise SimulationError(f"trace: {variable!r} of {population!r} was not recorded; call record() before run().")
        return self._trace(population, variable)

    def recorded_neurons(self, population: str, variable: str) -> np.ndarray:
        """The neuron indices whose ``variable`` is recorded."""
        if (population, variable) not in self._recording:
            raise SimulationError(f"{variable!r} of {population!r} is not recorded.")
        return self._recording[(population, variable)].copy()

    def connections(self, projection: str) -> tuple[np.ndarray, np.ndarray]:
        """``(pre, post)`` indices of the projection's connections, in canonical order."""
        self._projection(projection)
        pre, post = self._connections(projection)
        return pre.copy(), post.copy()

    def weights(self, projection: str, format: Literal["array", "list"] = "array") -> np.ndarray:
        """Current weights of a projection.

        ``format="array"`` gives a dense ``(n_pre, n_post)`` matrix with NaN where
        there is no connection (as PyNN's ``Projection.get(format="array")``);
        ``format="list"`` gives one value per connection in canonical order.
        """
        self._projection(projection)
        values = np.asarray(self._weights(projection), dtype=np.float64).copy()
        if format == "list":
            return values
        if format != "array":
            raise ValidationError(f"weights: format must be 'array' or 'list', got {format!r}.")
        proj = self._network.projections[projection]
        pre, post = self._connections(projection)
        dense = np.full((self._network.populations[proj.pre].size, self._network.populations[proj.post].size), np.nan)
        if np.unique(pre * dense.shape[1] + post).size != pre.size:
            raise SimulationError(f"weights: projection {projection!r} has repeated pairs; use format='list'.")
        dense[pre, post] = values
        return dense

    def set_weights(self, projection: str, values: Any) -> None:
        """Replace a projection's weights (a ``(n_pre, n_post)`` matrix or one value per connection)."""
        proj = self._projection(projection)
        pre, post = self._connections(projection)
        arr = np.asarray(values, dtype=np.float64)
        n_pre = self._network.populations[proj.pre].size
        n_post = self._network.populations[proj.post].size
        if arr.ndim == 2 and arr.shape == (n_pre, n_post):
            arr = arr[pre, post]
        elif arr.ndim != 1 or arr.size != pre.size:
            raise ValidationError(
                f"set_weights: {projection!r} needs a ({n_pre}, {n_post}) matrix or {pre.size} values, "
                f"got shape {arr.shape}."
            )
        if arr.size:
            check_weight_range(self._network, projection, float(arr.min()), float(arr.max()))
        self._set_weights(projection, arr.copy())

    def normalise_weights(self, projection: str, total: float, *, w_max: float | None = None) -> None:
        """Scale each postsynaptic neuron's incoming weights in ``projection`` to sum to ``total``, then clip at ``w_max``.

        Diehl & Cook's normalisation between presentations (Brian2 users write it by hand,
        ``w = w * total / sum(w)`` per target): the sums are taken in connection order, a
        neuron whose weights sum to 0 keeps them, and the new weights are checked as
        :meth:`set_weights` checks them. The same numbers on every backend; a backend may
        compute them in its own storage (the reference backend does, without copies).
        """
        self._projection(projection)
        total_f, w_max_f = check_normalisation(projection, total, w_max)
        self._normalise_weights(projection, total_f, w_max_f)

    def statistics(self) -> dict[str, int]:
        """Activity counted since compile: steps, neuron updates, spikes, synaptic events, plastic updates."""
        return dict(self._statistics())

    def close(self) -> None:
        """Release what the simulator holds outside this process (Lava's runtime, Nengo's simulator); a no-op by default.

        The simulation cannot run afterwards on backends that release something.
        """
        return None  # nothing outside the process on this backend

    def plot_activity(
        self, out_dir: str | os.PathLike[str], populations: Sequence[str] | None = None, *, title: str | None = None
    ) -> dict[str, Path]:
        """Write a spike raster, per-population rate histograms (PNG) and a JSON summary of the run since the last reset.

        See :func:`neurovpr.evaluation.activity_plots.plot_activity`; returns the paths written.
        """
        from neurovpr.evaluation.activity_plots import plot_activity

        return plot_activity(self, out_dir, populations=populations, title=title)

    def learned_state(self, population: str) -> dict[str, np.ndarray]:
        """Learned per-neuron quantities of a population (``{"theta": ...}`` for adaptive neurons)."""
        self._population(population)
        return self._learned_state(population)

    def to_network(self, name: str | None = None) -> Network:
        """A network carrying the current weights and learned thresholds.

        Every projection's weight becomes its per-connection array (canonical order)
        and random connectors get their resolved seed, so compiling the result with
        any seed reproduces these connections; adaptive thresholds become
        ``theta_init``. ``nv.save(simulation, path)`` saves this network.
        """
        net = self._network.copy(name)
        for pname, proj in self._network.projections.items():
            weight = np.asarray(self._weights(pname), dtype=np.float64)
            syn = proj.synapse
            conn = proj.connector
            if hasattr(conn, "seed") and conn.random:
                conn = conn.replace(seed=resolved_seed(proj, self._seed))
            if isinstance(conn, ConvolutionConnector) or weight.size == 0:
                continue  # kernels are shared and never learned; an empty projection has nothing to store
            if isinstance(conn, FromListConnector) and conn.conn_list.shape[1] >= 3:
                cl = np.array(conn.conn_list)
                cl[:, 2] = weight
                conn = conn.replace(conn_list=cl)
                new = proj.replace(connector=conn)
            else:
                new = proj.replace(connector=conn, synapse=syn.replace(weight=weight))
            net.replace_projection(new)  # type: ignore[arg-type]
        for pname, pop in self._network.populations.items():
            if isinstance(pop.cell_type, IF_cond_exp_adaptive):
                theta = self._learned_state(pname)["theta"]
                net.replace_population(pop.replace(cell_type=pop.cell_type.replace(theta_init=theta)))  # type: ignore[arg-type]
        return net

    # -- validation helpers --------------------------------------------------
    def _population(self, name: str):
        pops = self._network.populations
        if name not in pops:
            raise ValidationError(f"Population {name!r} does not exist (known: {', '.join(pops)}).")
        return pops[name]

    def _projection(self, name: str):
        projs = self._network.projections
        if name not in projs:
            raise ValidationError(f"Projection {name!r} does not exist (known: {', '.join(projs) or 'none'}).")
        return projs[name]

    def _check_input(self, name: str, value: Any) -> Any:
        pop = self._population(name)
        cell = pop.cell_type
        if isinstance(cell, SpikeSourcePoisson):
            try:
                rates = np.asarray(value, dtype=np.float64)
            except (TypeError, ValueError):
                raise ValidationError(f"inputs[{name!r}]: rates must be numbers (Hz).") from None
            if rates.ndim == 0:
                rates = np.full(pop.size, float(rates))
            if rates.shape != (pop.size,):
                raise ValidationError(f"inputs[{name!r}]: expected 1 or {pop.size} rates, got shape {rates.shape}.")
            if not np.all(np.isfinite(rates)) or rates.min() < 0:
                raise ValidationError(f"inputs[{name!r}]: rates must be finite and >= 0 Hz.")
            if rates.max() * self._dt / 1000.0 > 1.0:
                raise ValidationError(
                    f"inputs[{name!r}]: rate {rates.max():g} Hz exceeds one spike per {self._dt:g} ms step."
                )
            return rates
        if isinstance(cell, SpikeSourceArray):
            src = value if isinstance(value, SpikeSourceArray) else SpikeSourceArray(spike_times=value)
            src = src.for_size(pop.size)
            if src.n_neurons != pop.size:
                raise ValidationError(f"inputs[{name!r}]: spike times for {src.n_neurons} neurons, population has {pop.size}.")
            return src
        raise ValidationError(f"inputs[{name!r}]: population {name!r} is not a spike source.")

    # -- backend hooks -------------------------------------------------------
    @abstractmethod
    def _set_input(self, population: str, value: Any) -> None:
        """Apply validated rates (array) or a :class:`SpikeSourceArray`."""

    @abstractmethod
    def _run(self, n_steps: int) -> None:
        """Advance ``n_steps`` steps."""

    @abstractmethod
    def _reset(self) -> None:
        """Reset as described in :meth:`reset`."""

    @abstractmethod
    def _set_plasticity(self, on: bool) -> None:
        """Switch learning."""

    @abstractmethod
    def _set_recording(self, population: str, variable: str, neurons: np.ndarray) -> None:
        """Start recording."""

    @abstractmethod
    def _spike_counts(self, population: str) -> np.ndarray:
        """Spike counts since reset."""

    @abstractmethod
    def _spike_trains(self, population: str) -> tuple[np.ndarray, np.ndarray]:
        """Spike times and indices since reset."""

    @abstractmethod
    def _trace(self, population: str, variable: str) -> tuple[np.ndarray, np.ndarray]:
        """Recorded values."""

    @abstractmethod
    def _connections(self, projection: str) -> tuple[np.ndarray, np.ndarray]:
        """Pre and post indices in canonical order."""

    @abstractmethod
    def _weights(self, projection: str) -> np.ndarray:
        """Weights in canonical order."""

    @abstractmethod
    def _set_weights(self, projection: str, values: np.ndarray) -> None:
        """Replace weights (canonical order, validated)."""

    def _normalise_weights(self, projection: str, total: float, w_max: float | None) -> None:
        """Normalise through :meth:`weights` and :meth:`set_weights`; backends may override."""
        proj = self._network.projections[projection]
        _, post = self._connections(projection)
        w = self.weights(projection, format="list")
        self.set_weights(projection, normalised(w, post, self._network.populations[proj.post].size, total, w_max))

    @abstractmethod
    def _learned_state(self, population: str) -> dict[str, np.ndarray]:
        """Learned per-neuron values (``theta`` of adaptive neurons)."""

    def _run_batch(
        self,
        n_steps: int,
        items: list[dict[str, Any]],
        populations: list[str],
        spike_trains: bool,
        tick: Callable[[], None] | None,
    ) -> BatchResult:
        """Run validated batch items (:meth:`run_batch`); by default one after another with resets."""
        return run_items(self, n_steps, items, populations, spike_trains, apply=self._set_input, advance=self._run, tick=tick)

    def _statistics(self) -> Mapping[str, int]:
        raise SimulationError(f"Backend {self._backend!r} does not count activity.")
