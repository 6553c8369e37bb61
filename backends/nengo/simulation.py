"""The ``nengo`` and ``nengo-loihi`` simulations: run, read spikes and voltages, reset, count activity."""

from __future__ import annotations

import time
from collections.abc import Mapping
from typing import Any

import nengo
import numpy as np

from neurovpr.errors import SimulationError, UnsupportedFeatureError, ValidationError
from neurovpr.ir.connectivity import expand
from neurovpr.ir.connectors import ConvolutionConnector
from neurovpr.ir.network import Network
from neurovpr.runtime.simulation import Simulation

from .build import BuiltNetwork, build_network, quiet_nengo
from .capabilities import delay_problems
from .loihi import block_report, loihi_voltage_scale, new_loihi_simulator, reset_loihi_simulator
from .sources import SourceState

__all__ = ["NengoSimulation"]


class NengoSimulation(Simulation):
    """A network on Nengo's reference simulator or on NengoLoihi's Loihi emulator.

    Parameters
    ----------
    network, backend, dt, seed
        As for :class:`~neurovpr.runtime.simulation.Simulation`.
    loihi
        Run on NengoLoihi's emulator (``target="sim"``) instead of ``nengo.Simulator``.
    hardware
        The hwspec being emulated (NengoLoihi only; its chips and cores per chip bound
        the allocation :meth:`loihi_usage` reports).
    block_shapes
        NengoLoihi only: ``{population: (block shape, ensemble shape)}`` passed to
        ``nengo_loihi.BlockShape``; populations not named are split by NengoLoihi itself.
    """

    def __init__(
        self,
        network: Network,
        *,
        backend: str,
        dt: float,
        seed: int,
        loihi: bool,
        hardware: Any = None,
        block_shapes: Mapping[str, tuple[tuple[int, ...], tuple[int, ...]]] | None = None,
    ) -> None:
        super().__init__(network, backend=backend, dt=dt, seed=seed)
        net = self._network
        self._loihi = loihi
        self._hardware = hardware
        self._block_shapes = dict(block_shapes or {})
        for name in self._block_shapes:
            if name not in net.populations or net.populations[name].is_source:
                raise ValidationError(f"block_shapes: {name!r} is not a neuron population of {net.name!r}.")
        self._conns = {name: expand(net, proj, dt=dt, seed=seed) for name, proj in net.projections.items()}
        problems = delay_problems(net, self._conns, dt) if loihi else []
        if problems:
            more = f" (and {len(problems) - 1} more)" if len(problems) > 1 else ""
            raise UnsupportedFeatureError(f"Backend {backend!r} cannot run {problems[0]}{more}.")
        self._values = {name: conns.weight.copy() for name, conns in self._conns.items()}
        self._out_degree = {
            name: np.bincount(conns.pre, minlength=net.populations[net.projections[name].pre].size)
            for name, conns in self._conns.items()
        }
        self._sources = {name: SourceState(pop, dt=dt, seed=seed) for name, pop in net.populations.items() if pop.is_source}
        self._steps = 0
        self._stats = {"steps": 0, "neuron_updates": 0, "spikes": 0, "synaptic_events": 0, "plastic_updates": 0}
        self._run_ns = 0
        self._build_ns = 0
        self._sim: Any = None
        self._built: BuiltNetwork | None = None
        self._clear_records()
        self._build()

    # -- building ------------------------------------------------------------
    def _build(self) -> None:
        self._close()
        if all(pop.is_source for pop in self._network.populations.values()):
            return  # only spike sources: nothing for Nengo to simulate
        started = time.perf_counter_ns()
        voltage = frozenset(pop for pop, var in self._recording if var == "v")
        with quiet_nengo():
            try:
                built = build_network(
                    self._network,
                    self._conns,
                    self._values,
                    dt=self._dt,
                    seed=self._seed,
                    loihi=self._loihi,
                    voltage_populations=voltage,
                    block_shapes=self._block_shapes,
                )
                if self._loihi:
                    sim = new_loihi_simulator(built.net, dt=self._dt, seed=self._seed)
                else:
                    model = nengo.builder.Model(dt=self._dt / 1000.0, label=self._network.name)
                    sim = nengo.Simulator(
                        built.net, dt=self._dt / 1000.0, seed=self._seed % 2**31, model=model, progress_bar=False
                    )
            except (nengo.exceptions.NengoException, NotImplementedError) as exc:
                target = "NengoLoihi" if self._loihi else "Nengo"
                raise UnsupportedFeatureError(
                    f"Backend {self._backend!r}: {target} cannot build network {self._network.name!r}: "
                    f"{type(exc).__name__}: {exc}"
                ) from exc
        self._built, self._sim = built, sim
        self._build_ns += time.perf_counter_ns() - started

    def _close(self) -> None:
        if self._sim is not None:
            self._sim.close()
            self._sim = None

    def close(self) -> None:
        """Release the Nengo simulator (the simulation cannot run afterwards)."""
        self._close()

    def _require_sim(self) -> Any:
        if self._sim is None:
            raise SimulationError(f"Backend {self._backend!r}: the simulation was closed.")
        return self._sim

    @property
    def _sources_only(self) -> bool:
        return all(pop.is_source for pop in self._network.populations.values())

    def _clear_records(self) -> None:
        pops = self._network.populations
        self._counts = {name: np.zeros(pop.size, dtype=np.int64) for name, pop in pops.items()}
        self._trains: dict[str, list[tuple[np.ndarray, np.ndarray]]] = {name: [] for name in pops}
        self._voltages: dict[str, list[np.ndarray]] = {name: [] for name, var in self._recording if var == "v"}

    # -- facts -----------------------------------------------------------------
    @property
    def time(self) -> float:
        """Simulated time since the last reset (ms)."""
        return self._steps * self._dt

    # -- hooks -----------------------------------------------------------------
    def _set_input(self, population: str, value: Any) -> None:
        self._sources[population].set(value)

    def _run(self, n_steps: int) -> None:
        first = self._steps
        sim = None if self._sources_only else self._require_sim()
        for name, source in self._sources.items():
            raster = source.raster(first, n_steps)
            if self._built is not None:
                for feed in self._built.feeds.get(name, []):
                    feed.load(raster, first_step=first + 1)
            self._record_spikes(name, raster, first, source_stamps=True)
        if sim is not None:
            built = self._built
            assert built is not None
            started = time.perf_counter_ns()
            with quiet_nengo():
                sim.run_steps(n_steps)
            self._run_ns += time.perf_counter_ns() - started
            for name, probe in built.spike_probes.items():
                self._record_spikes(name, np.asarray(sim.data[probe]) > 0, first, source_stamps=False)
            for name, probe in built.voltage_probes.items():
                self._voltages[name].append(self._to_mv(name, np.asarray(sim.data[probe], dtype=np.float64)))
            sim.clear_probes()
        self._steps += n_steps
        n_neurons = sum(pop.size for pop in self._network.populations.values() if not pop.is_source)
        self._stats["steps"] += n_steps
        self._stats["neuron_updates"] += n_steps * n_neurons

    def _record_spikes(self, name: str, raster: np.ndarray, first: int, *, source_stamps: bool) -> None:
        rows, idx = np.nonzero(raster)
        # a source spike is stamped at the start of its step, a neuron spike at the end
        times = (first + rows + (0 if source_stamps else 1)) * self._dt
        self._trains[name].append((times, idx))
        counts = np.bincount(idx, minlength=raster.shape[1])
        self._counts[name] += counts
        self._stats["spikes"] += int(idx.size)
        for pname, proj in self._network.projections.items():
            if proj.pre == name:
                self._stats["synaptic_events"] += int(counts @ self._out_degree[pname])

    def _to_mv(self, name: str, values: np.ndarray) -> np.ndarray:
        assert self._built is not None
        mapping = self._built.mappings[name]
        if self._loihi:
            values = values / loihi_voltage_scale(self._sim, self._built.ensembles[name])
        return mapping.v_zero + values * mapping.v_scale

    def _reset(self) -> None:
        if not self._sources_only:
            sim = self._require_sim()
            with quiet_nengo():
                if self._loihi:
                    reset_loihi_simulator(sim, seed=self._seed)
                else:
                    sim.reset(seed=self._seed % 2**31)
                sim.clear_probes()
            assert self._built is not None
            for feeds in self._built.feeds.values():
                for feed in feeds:
                    feed.clear()
        self._steps = 0
        self._clear_records()

    def _set_plasticity(self, on: bool) -> None:
        """Nothing learns here (plastic synapses are refused at compile)."""

    def _set_recording(self, population: str, variable: str, neurons: np.ndarray) -> None:
        if variable != "v":
            del self._recording[(population, variable)]
            raise UnsupportedFeatureError(f"record: backend {self._backend!r} records only 'v', not {variable!r}.")
        if population in self._voltages:
            return
        if self._steps:
            del self._recording[(population, variable)]
            raise SimulationError(
                f"record: backend {self._backend!r} adds probes by rebuilding the network; "
                f"call reset() before recording {variable!r} of {population!r}."
            )
        self._voltages[population] = []
        self._build()

    def _spike_counts(self, population: str) -> np.ndarray:
        return self._counts[population].copy()

    def _spike_trains(self, population: str) -> tuple[np.ndarray, np.ndarray]:
        parts = self._trains[population]
        if not parts:
            return np.zeros(0), np.zeros(0, dtype=np.int64)
        times = np.concatenate([p[0] for p in parts])
        idx = np.concatenate([p[1] for p in parts])
        order = np.lexsort((idx, times))
        return times[order], idx[order]

    def _trace(self, population: str, variable: str) -> tuple[np.ndarray, np.ndarray]:
        neurons = self._recording[(population, variable)]
        parts = self._voltages.get(population, [])
        values = np.concatenate(parts) if parts else np.zeros((0, self._network.populations[population].size))
        times = (np.arange(values.shape[0]) + 1) * self._dt
        return times, values[:, neurons]

    def _connections(self, projection: str) -> tuple[np.ndarray, np.ndarray]:
        conns = self._conns[projection]
        return conns.pre, conns.post

    def _weights(self, projection: str) -> np.ndarray:
        return self._values[projection].copy()

    def _set_weights(self, projection: str, values: np.ndarray) -> None:
        if isinstance(self._network.projections[projection].connector, ConvolutionConnector):
            raise UnsupportedFeatureError(
                f"set_weights: projection {projection!r} is convolutional; its shared kernel is fixed at compile."
            )
        if self._steps:
            raise SimulationError(
                f"set_weights: backend {self._backend!r} rebuilds the network to change weights; "
                f"call reset() before setting the weights of {projection!r}."
            )
        self._values[projection] = values
        self._build()

    def _learned_state(self, population: str) -> dict[str, np.ndarray]:
        return {}

    def _statistics(self) -> Mapping[str, int]:
        stats = dict(self._stats)
        stats["run_wall_ns"] = self._run_ns
        stats["build_wall_ns"] = self._build_ns
        return stats

    # -- NengoLoihi's mapping --------------------------------------------------
    def loihi_blocks(self) -> list[dict[str, Any]]:
        """NengoLoihi's blocks (one per core) after its own splitting, with their resource use.

        Returns
        -------
        list of dict
            One entry per on-chip block: ``population``, ``block`` (NengoLoihi's label),
            ``compartments``, ``in_axons``, ``out_axons``, ``synapse_bits`` and the
            ``limits`` NengoLoihi enforces.

        Raises
        ------
        SimulationError
            On the ``nengo`` backend, which maps nothing to cores.
        """
        if not self._loihi:
            raise SimulationError(f"loihi_blocks: backend {self._backend!r} does not map onto Loihi cores.")
        assert self._built is not None
        return block_report(self._require_sim(), self._built)["blocks"]

    def loihi_usage(self) -> dict[str, Any]:
        """Cores and chips of NengoLoihi's mapping: ``{"cores", "chips", "blocks", "inputs"}``.

        ``chips`` comes from NengoLoihi's greedy allocator (the one its hardware target
        uses); compiled with a hardware spec, its chips and cores per chip bound the
        allocation (``chips`` is ``None`` when they are not enough).
        """
        if not self._loihi:
            raise SimulationError(f"loihi_usage: backend {self._backend!r} does not map onto Loihi cores.")
        assert self._built is not None
        chip = getattr(self._hardware, "chip", None)
        return block_report(
            self._require_sim(),
            self._built,
            max_chips=getattr(chip, "n_chips", None),
            cores_per_chip=getattr(chip, "cores_per_chip", None),
        )
