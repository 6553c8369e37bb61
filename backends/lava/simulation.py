"""The ``lava`` and ``lava-fixed`` simulations: a Lava runtime driven in chunks of ring-buffer length."""

from __future__ import annotations

import time
import weakref
from typing import Any

import numpy as np

from neurovpr.backendkit.hosted import HostedSimulation
from neurovpr.errors import SimulationError, UnsupportedFeatureError, ValidationError
from neurovpr.hardware.check import HardwareTarget
from neurovpr.ir.network import Network

from .build import build_network
from .capabilities import compile_problems
from .compat import import_lava

__all__ = ["LavaSimulation"]


def _stop(process: Any) -> None:
    """Stop the Lava runtime of ``process`` and its worker processes.

    A runtime that was created but never started cannot be stopped through Lava
    (its workers wait for a first command), so its workers are terminated.
    """
    runtime = getattr(process, "runtime", None)
    if runtime is None:
        return
    if runtime._is_started:
        process.stop()
        return
    infrastructure = runtime._messaging_infrastructure
    for actor in infrastructure.actors:
        actor.terminate()
    if infrastructure.smm is not None:
        infrastructure.smm.shutdown()


class LavaSimulation(HostedSimulation):
    """A network as Lava processes on ``Loihi2SimCfg``.

    Parameters
    ----------
    network, backend, dt, seed, hardware
        As for :class:`~neurovpr.runtime.simulation.Simulation`.
    fixed
        Select the ``fixed_pt`` (bit-accurate Loihi 2) process models instead of ``floating_pt``.
    buffer_steps
        Steps per Lava run call (capacity of the injector and extractor channels);
        longer runs are split into chunks of this length.

    Notes
    -----
    Lava's runtime lives in worker processes; :meth:`close` stops them (they are
    also stopped when the simulation is garbage-collected or the interpreter exits).
    Recording ``v`` runs one step per Lava call, which is much slower.
    """

    def __init__(
        self,
        network: Network,
        *,
        backend: str,
        dt: float,
        seed: int,
        fixed: bool,
        hardware: HardwareTarget | None = None,
        buffer_steps: int = 1000,
    ) -> None:
        super().__init__(network, backend=backend, dt=dt, seed=seed, hardware=hardware)
        if isinstance(buffer_steps, bool) or not isinstance(buffer_steps, (int, np.integer)) or buffer_steps < 1:
            raise ValidationError(f"Backend {backend!r}: buffer_steps must be an integer >= 1, got {buffer_steps!r}.")
        self._fixed = fixed
        self._buffer = int(buffer_steps)
        self._refuse(compile_problems(self._network, self._conns, dt, fixed=fixed))
        self._built: Any = None
        self._finalizer: Any = None
        self._clear_records()
        self._build()

    # -- building --------------------------------------------------------------
    def _build(self) -> None:
        self.close()
        if not self._neuron_pops:
            return
        import_lava()
        started = time.perf_counter_ns()
        built = build_network(self._network, self._conns, self._values, dt=self._dt, fixed=self._fixed, buffer_steps=self._buffer)
        anchor = built.anchor
        config = built.run_config()
        anchor.create_runtime(run_cfg=config)
        self._finalizer = weakref.finalize(self, _stop, anchor)
        try:
            # Lava sets variables only in a started runtime: run one silent step, then restore the initial state
            for injector in built.injectors.values():
                injector.send(np.zeros(injector.out_port.shape))
            anchor.run(condition=import_lava().RunSteps(num_steps=1, blocking=True), run_cfg=config)
            for extractor in built.extractors.values():
                extractor.receive()
            self._built = built
            self._reset_processes()
        except Exception:
            self.close()
            raise
        self._build_ns += time.perf_counter_ns() - started

    def close(self) -> None:
        """Stop Lava's runtime (the simulation cannot run afterwards)."""
        if self._finalizer is not None:
            self._finalizer()
            self._finalizer = None
        self._built = None

    # -- facts -----------------------------------------------------------------
    def process_kinds(self) -> dict[str, str]:
        """The Lava process class each projection became.

        ``Dense``, ``Sparse``, ``DelayDense``, ``DelaySparse`` (the first group of
        delays), or ``Conv`` (a convolution as a :class:`~.connections.DelayConv`).
        """
        return dict(self._built.kinds) if self._built is not None else {}

    # -- running ---------------------------------------------------------------
    def _run(self, n_steps: int) -> None:
        if self._neuron_pops and self._built is None:
            raise SimulationError(f"Backend {self._backend!r}: the simulation was closed.")
        done = 0
        while done < n_steps:
            length = min(self._buffer, n_steps - done)
            self._run_chunk(length)
            done += length
        self._record.add_steps(n_steps)

    def _run_chunk(self, length: int) -> None:
        """Queue the sources' spikes, run ``length`` steps (one by one when recording ``v``), collect the spikes."""
        built = self._built
        first = self._steps
        for name, source in self._sources.items():
            raster = source.raster(first, length)
            self._record.add(name, raster, first, source=True)
            if built is not None and name in built.injectors:
                for row in raster.astype(np.float64):
                    built.injectors[name].send(row)
        if built is not None:
            lava = import_lava()
            config = built.run_config()
            per_call = 1 if self._voltages else length
            for _ in range(length // per_call):
                started = time.perf_counter_ns()
                built.anchor.run(condition=lava.RunSteps(num_steps=per_call, blocking=True), run_cfg=config)
                self._run_ns += time.perf_counter_ns() - started
                for name in self._voltages:
                    self._voltages[name].append(self._read_voltage(name)[None, :])
            for name, extractor in built.extractors.items():
                spikes = np.stack([extractor.receive() for _ in range(length)]) > 0
                self._record.add(name, spikes, first, source=False)
        self._steps += length

    def _read_voltage(self, name: str) -> np.ndarray:
        params = self._built.params[name]
        v = np.asarray(self._built.lifs[name].v.get(), dtype=np.float64)
        if self._fixed:
            v = v / params.integers.v_scale
        return params.compartment.to_mv(v)

    def _reset(self) -> None:
        self._reset_processes()
        self._steps = 0
        self._clear_records()

    def _reset_processes(self) -> None:
        """Membranes, currents, refractoriness and spikes in flight back to their initial values.

        Each process restores its own state at its next step (:mod:`.resets`): one
        message per process, where setting the variables takes one per element.
        """
        built = self._built
        if built is not None:
            request = np.ones(1, dtype=np.int64)
            for process in built.resettable:
                process.reset_request.set(request)

    def _set_recording(self, population: str, variable: str, neurons: np.ndarray) -> None:
        if variable != "v":
            del self._recording[(population, variable)]
            raise UnsupportedFeatureError(f"record: backend {self._backend!r} records only 'v', not {variable!r}.")
        self._voltages.setdefault(population, [])
