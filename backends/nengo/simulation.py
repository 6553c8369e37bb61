"""The ``nengo`` and ``nengo-loihi`` simulations: run, read spikes and voltages, reset, count activity."""

from __future__ import annotations

import time
from collections.abc import Mapping
from typing import Any

import nengo
import numpy as np

from neurovpr.backendkit.hosted import HostedSimulation
from neurovpr.errors import SimulationError, UnsupportedFeatureError, ValidationError
from neurovpr.hardware.check import HardwareTarget
from neurovpr.ir.network import Network

from .build import BuiltNetwork, build_network, quiet_nengo
from .capabilities import delay_problems
from .loihi import block_report, loihi_voltage_scale, new_loihi_simulator, reset_loihi_simulator

__all__ = ["NengoSimulation"]


class NengoSimulation(HostedSimulation):
    """A network on Nengo's reference simulator or on NengoLoihi's Loihi emulator.

    Parameters
    ----------
    network, backend, dt, seed
        As for :class:`~neurovpr.runtime.simulation.Simulation`.
    loihi
        Run on NengoLoihi's emulator (``target="sim"``) instead of ``nengo.Simulator``.
    hardware
        The hardware target (NengoLoihi only; its chips and cores per chip bound the
        allocation :meth:`loihi_usage` reports).
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
        hardware: HardwareTarget | None = None,
        block_shapes: Mapping[str, tuple[tuple[int, ...], tuple[int, ...]]] | None = None,
    ) -> None:
        super().__init__(network, backend=backend, dt=dt, seed=seed, hardware=hardware)
        net = self._network
        self._loihi = loihi
        self._block_shapes = dict(block_shapes or {})
        for name in self._block_shapes:
            if name not in net.populations or net.populations[name].is_source:
                raise ValidationError(f"block_shapes: {name!r} is not a neuron population of {net.name!r}.")
        self._refuse(delay_problems(net, self._conns, dt) if loihi else [])
        self._sim: Any = None
        self._built: BuiltNetwork | None = None
        self._clear_records()
        self._build()

    # -- building ------------------------------------------------------------
    def _build(self) -> None:
        self._close()
        if not self._neuron_pops:
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
                sim = self._new_simulator(built)
            except (nengo.exceptions.NengoException, NotImplementedError) as exc:
                target = "NengoLoihi" if self._loihi else "Nengo"
                raise UnsupportedFeatureError(
                    f"Backend {self._backend!r}: {target} cannot build network {self._network.name!r}: "
                    f"{type(exc).__name__}: {exc}"
                ) from exc
        self._built, self._sim = built, sim
        self._build_ns += time.perf_counter_ns() - started

    def _new_simulator(self, built: BuiltNetwork) -> Any:
        """The simulator of the built network: NengoLoihi's emulator or ``nengo.Simulator`` (a subclass may change it)."""
        if self._loihi:
            return new_loihi_simulator(built.net, dt=self._dt, seed=self._seed)
        model = nengo.builder.Model(dt=self._dt / 1000.0, label=self._network.name)
        return nengo.Simulator(built.net, dt=self._dt / 1000.0, seed=self._seed % 2**31, model=model, progress_bar=False)

    def _reset_simulator(self, sim: Any) -> None:
        """Return the simulator to its initial state (a subclass may change how)."""
        if self._loihi:
            reset_loihi_simulator(sim, seed=self._seed)
        else:
            sim.reset(seed=self._seed % 2**31)

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

    # -- hooks -----------------------------------------------------------------
    def _run(self, n_steps: int) -> None:
        first = self._steps
        sim = self._require_sim() if self._neuron_pops else None
        for name, source in self._sources.items():
            raster = source.raster(first, n_steps)
            if self._built is not None:
                for feed in self._built.feeds.get(name, []):
                    feed.load(raster, first_step=first + 1)
            self._record.add(name, raster, first, source=True)
        if sim is not None:
            built = self._built
            assert built is not None
            started = time.perf_counter_ns()
            with quiet_nengo():
                sim.run_steps(n_steps)
            self._run_ns += time.perf_counter_ns() - started
            for name, probe in built.spike_probes.items():
                self._record.add(name, np.asarray(sim.data[probe]) > 0, first, source=False)
            for name, probe in built.voltage_probes.items():
                self._voltages[name].append(self._to_mv(name, np.asarray(sim.data[probe], dtype=np.float64)))
            sim.clear_probes()
        self._steps += n_steps
        self._record.add_steps(n_steps)

    def _to_mv(self, name: str, values: np.ndarray) -> np.ndarray:
        assert self._built is not None
        if self._loihi:
            values = values / loihi_voltage_scale(self._sim, self._built.ensembles[name])
        return self._built.mappings[name].to_mv(values)

    def _reset(self) -> None:
        if self._neuron_pops:
            sim = self._require_sim()
            with quiet_nengo():
                self._reset_simulator(sim)
                sim.clear_probes()
            assert self._built is not None
            for feeds in self._built.feeds.values():
                for feed in feeds:
                    feed.clear()
        self._steps = 0
        self._clear_records()

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
        chip = None if self._hardware is None else self._hardware.spec.chip
        return block_report(
            self._require_sim(),
            self._built,
            max_chips=None if chip is None else chip.n_chips,
            cores_per_chip=None if chip is None else chip.cores_per_chip,
        )
