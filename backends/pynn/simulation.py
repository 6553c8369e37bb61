"""Run a network through PyNN on NEST or Brian2.

PyNN keeps one simulator state per process (``setup()`` / ``end()`` are global),
so one :class:`PyNNSimulation` per PyNN simulator can be live in a process at a
time. Compiling a second one takes PyNN over: the first keeps what it had recorded
(spikes, traces, weights) for reading, and every call that would drive it raises
:class:`~neurovpr.errors.SimulationError`. The owner is recorded on PyNN's own
state object, the global it guards.

``reset()`` rebuilds the network (PyNN's own ``reset`` cannot clear NEST's spikes in flight,
NEST 3.10 refuses to set ``iaf_psc_exp``'s ``I_syn_ex``/``I_syn_in``, and Brian2's restores the
initial weights), carrying the current weights over:
those it was built or last set with, read back from the simulator only after a run with
plasticity on in a network with plastic projections (the only way they can move there).

``statistics()`` counts from the recorded spikes, as the reference backend defines the
counts: steps, neuron updates (steps x non-source neurons), spikes of every population,
synaptic events (each spike times its neuron's number of outgoing connections) and
plastic updates (each spike's arrivals on plastic connections plus each postsynaptic
spike times its number of incoming plastic connections; the reference backend leaves
out updates whose trace is exactly zero, so this is an upper bound on its count).
Like the backend kit's, it also reports ``run_wall_ns`` (wall time inside the simulator's
``run``) and ``build_wall_ns`` (building the network, and tearing it down and building it
again at every ``reset()``), so that a benchmark can tell simulating from rebuilding.
"""

from __future__ import annotations

import time
import weakref
from typing import Any

import numpy as np

from neurovpr.backendkit.pynn_names import RECORDABLES
from neurovpr.backendkit.sources import SourceState
from neurovpr.errors import SimulationError
from neurovpr.ir.network import Network
from neurovpr.runtime.simulation import Simulation

from .build import (
    Built,
    BuiltPart,
    build_network,
    first_deliverable,
    load_simulator,
    nest_connections,
    nest_lambdas,
    nest_order,
    quiet,
    release_neurons,
    set_nest_plasticity,
    time_offset,
)
from .capabilities import Simulator
from .translation import connection_degrees, deferred_potentiation, from_pynn_weights, to_pynn_weights, translate

__all__ = ["PyNNSimulation"]

_OWNER = "_neurovpr_owner"
_EPS = 1e-6


class PyNNSimulation(Simulation):
    """A network compiled to PyNN standard models on NEST or Brian2.

    Parameters
    ----------
    network, dt, seed
        As for :func:`neurovpr.compile`.
    backend
        The backend's name.
    simulator
        ``"nest"`` or ``"brian2"``.
    codegen_target
        Brian2's code generation target (``"numpy"`` or ``"cython"``).
    threads
        NEST's threads (``local_num_threads``); 1 for Brian2.
    """

    def __init__(
        self,
        network: Network,
        *,
        backend: str,
        simulator: Simulator,
        dt: float,
        seed: int,
        codegen_target: str = "numpy",
        threads: int = 1,
    ) -> None:
        super().__init__(network, backend=backend, dt=dt, seed=seed)
        self._simulator: Simulator = simulator
        self._plan = translate(self._network, dt=dt, seed=seed)
        self._sim = load_simulator(simulator, codegen_target=codegen_target)
        self._sources = {
            name: SourceState(pop, dt=dt, seed=seed) for name, pop in self._network.populations.items() if pop.is_source
        }
        self._record_from: dict[tuple[str, str], int] = {}
        self._cache: dict[str, tuple[int, np.ndarray, np.ndarray]] = {}
        self._frozen: dict[str, dict[Any, Any]] | None = None
        self._threads = threads
        self._offset = time_offset(simulator, dt)
        self._late_spikes = 0
        self._done = {"steps": 0, "neuron_updates": 0, "spikes": 0, "synaptic_events": 0, "plastic_updates": 0}
        # wall time in the simulator's run and in (re)building the network, as the backend kit reports them
        self._done.update(run_wall_ns=0, build_wall_ns=0)
        self._n_neurons = sum(p.size for p in self._network.populations.values() if not p.is_source)
        self._degrees = connection_degrees(self._network, self._plan)
        weights = {name: conns.weight.copy() for name, conns in self._plan.connections.items()}
        #: plastic projections: a run with plasticity on may change their weights in the simulator
        self._has_plastic = any(part.synapse.kind == "STDPMechanism" for part in self._plan.parts)
        self._build(weights, check=True)

    # -- ownership of PyNN's global state ----------------------------------
    def _state(self) -> Any:
        return self._sim.simulator.state

    def _check_live(self) -> None:
        if self._frozen is not None:
            raise SimulationError(
                f"This {self._backend!r} simulation of network {self._network.name!r} is closed: PyNN runs one "
                "simulation per process and another one was compiled (or close() was called); its recorded "
                "results can still be read; compile it again to run it."
            )

    def close(self) -> None:
        """End the PyNN simulation, keeping its results readable, and free PyNN for another one."""
        if self._frozen is not None:
            return
        held, names = self._held, self._network.projections  # held: known weights (NEST reads back ~6 us each)
        self._frozen = {
            "spikes": {name: self._all_spikes(name) for name in self._network.populations},
            "traces": {key: self._live_trace(*key) for key in self._recording},
            "weights": {name: held[name].copy() if held is not None else self._live_weights(name) for name in names},
        }
        state = self._state()
        owner = getattr(state, _OWNER, None)
        if owner is not None and owner() is self:
            setattr(state, _OWNER, None)
        with quiet():
            self._sim.end()

    def _build(self, weights: dict[str, np.ndarray], *, check: bool) -> None:
        """Build the network with these IR weights; ``check``: verify the connections PyNN made (the first build).

        A rebuild makes the same PyNN calls with the same lists, so it is not checked again.
        """
        state = self._state()
        owner = getattr(state, _OWNER, None)
        previous = owner() if owner is not None else None
        if previous is not None and previous is not self:
            previous.close()
        setattr(state, _OWNER, weakref.ref(self))
        started = time.perf_counter_ns()
        self._built: Built = build_network(
            self._sim, self._simulator, self._plan, weights, threads=self._threads, check=check
        )
        #: the IR weights the simulator holds, while they are known without reading them back
        self._held: dict[str, np.ndarray] | None = weights
        self._steps = 0
        self._first_run = True
        self._cache.clear()
        for (pop, var), idx in self._recording.items():
            self._start_recording(pop, var, idx)
            self._record_from[(pop, var)] = 0
        if not self._plastic:
            self._apply_plasticity(False)
        self._done["build_wall_ns"] += time.perf_counter_ns() - started

    # -- Simulation hooks ----------------------------------------------------
    @property
    def time(self) -> float:
        """Simulated time since the last reset (ms)."""
        return self._steps * self._dt

    @property
    def late_source_spikes(self) -> int:
        """Source spikes NEST could not deliver on time since compile (see :func:`.build.first_deliverable`)."""
        return self._late_spikes

    def _set_input(self, population: str, value: Any) -> None:
        self._check_live()
        self._sources[population].set(value)

    def _run(self, n_steps: int) -> None:
        self._check_live()
        for name in self._sources:
            self._feed_source(name, self._steps, n_steps)
        started = time.perf_counter_ns()
        with quiet():
            if self._simulator == "nest" and self._first_run:
                # pre-roll: PyNN's first run simulates one step more, reaching the offset
                self._sim.run(self._offset - self._dt)
                release_neurons(self._built, self._plan)
                # and one step beyond the run, which NEST then stays ahead by
                self._sim.run((n_steps + 1) * self._dt)
            else:
                self._sim.run(n_steps * self._dt)
        self._done["run_wall_ns"] += time.perf_counter_ns() - started
        if self._plastic and self._has_plastic:
            self._held = None
        self._steps += n_steps
        self._done["steps"] += n_steps
        self._done["neuron_updates"] += n_steps * self._n_neurons
        self._first_run = False
        self._cache.clear()

    def _source_spikes(self, name: str, s0: int, n_steps: int) -> tuple[np.ndarray, np.ndarray]:
        """``(neuron, time)`` of the source's spikes in steps ``s0 .. s0 + n_steps - 1``.

        Poisson spikes are drawn in chunks of steps (the same draws as one block) to bound memory.
        """
        source = self._sources[name]
        chunk = max(1, 2_000_000 // max(self._network.populations[name].size, 1))
        neurons, steps = [np.zeros(0, np.int64)], [np.zeros(0, np.int64)]
        for a in range(s0, s0 + n_steps, chunk):
            step, neuron = source.events(a, min(chunk, s0 + n_steps - a))
            steps.append(step)
            neurons.append(neuron)
        return np.concatenate(neurons), np.concatenate(steps) * self._dt

    def _feed_source(self, name: str, s0: int, n_steps: int) -> None:
        neurons, times = self._source_spikes(name, s0, n_steps)
        dt = self._dt
        pop = self._built.populations[name]
        earliest = first_deliverable(self._simulator, s0 * dt, dt, self._first_run)
        late = times < earliest - _EPS * dt
        self._late_spikes += int(late.sum())
        times = np.where(late, earliest, times)
        order = np.lexsort((times, neurons))
        neurons, times = neurons[order], times[order]
        if self._simulator == "brian2":
            steps = np.rint(times / dt).astype(np.int64)
            if neurons.size > 1:
                dup = (neurons[1:] == neurons[:-1]) & (steps[1:] == steps[:-1])
                if dup.any():
                    k = int(np.flatnonzero(dup)[0])
                    raise SimulationError(
                        f"pyNN.brian2 emits at most one spike per neuron and step: neuron {int(neurons[k])} of "
                        f"{name!r} has several spikes at {times[k]:g} ms."
                    )
            import brian2

            group = pop.brian2_group
            group.set_spikes(neurons, times * brian2.ms)
            return
        import nest

        bounds = np.searchsorted(neurons, np.arange(pop.size + 1))
        generator = times + self._offset - dt  # the relay neuron fires one step after its generator
        params = [{"spike_times": generator[bounds[i] : bounds[i + 1]].tolist()} for i in range(pop.size)]
        with quiet():
            nest.SetStatus(pop.node_collection_source, params)

    def _reset(self) -> None:
        self._check_live()
        for key, value in self._live_statistics().items():
            self._done[key] += value
        # the weights carry over: those the network was built or set with, unless learning may have moved them
        weights = self._held if self._held is not None else {name: self._weights(name) for name in self._network.projections}
        started = time.perf_counter_ns()
        with quiet():
            self._sim.end()
        self._done["build_wall_ns"] += time.perf_counter_ns() - started  # tearing down is part of the rebuild
        self._build(weights, check=False)

    def _set_plasticity(self, on: bool) -> None:
        self._check_live()
        self._apply_plasticity(on)

    def _apply_plasticity(self, on: bool) -> None:
        for part in self._built.parts:
            if part.plan.synapse.kind != "STDPMechanism":
                continue
            if self._simulator == "brian2":
                part.native.plastic = 1.0 if on else 0.0
            else:
                with quiet():
                    set_nest_plasticity(part, on=on)

    def _start_recording(self, population: str, variable: str, neurons: np.ndarray) -> None:
        pop = self._built.populations[population]
        kind = type(self._network.populations[population].cell_type).__name__
        pynn_var = RECORDABLES[kind][variable]
        with quiet():
            pop[np.asarray(neurons, dtype=np.int64)].record(pynn_var)

    def _set_recording(self, population: str, variable: str, neurons: np.ndarray) -> None:
        self._check_live()
        kind = type(self._network.populations[population].cell_type).__name__
        if variable not in RECORDABLES.get(kind, {}):
            del self._recording[(population, variable)]
            raise SimulationError(
                f"Backend {self._backend!r} cannot record {variable!r} of {kind} population {population!r} "
                f"(PyNN records: {', '.join(RECORDABLES.get(kind, {})) or 'nothing'})."
            )
        self._start_recording(population, variable, neurons)
        self._record_from[(population, variable)] = self._steps

    def _all_spikes(self, population: str) -> tuple[np.ndarray, np.ndarray]:
        if self._frozen is not None:
            return self._frozen["spikes"][population]
        cached = self._cache.get(population)
        if cached is not None and cached[0] == self._steps:
            return cached[1], cached[2]
        pop = self._built.populations[population]
        if self._steps == 0:
            return np.zeros(0), np.zeros(0, np.int64)
        if self._simulator == "nest":
            t_all, i_all = self._nest_events(pop, pop.recorder._spike_detector.device, "times")
        else:
            with quiet():
                trains = pop.get_data("spikes", clear=False).segments[0].spiketrains
            times, idx = [], []
            for k, train in enumerate(trains):
                neuron = int(train.annotations.get("source_index", k))
                t = np.asarray(train.rescale("ms").magnitude, dtype=np.float64)
                times.append(t)
                idx.append(np.full(t.size, neuron, dtype=np.int64))
            t_all = np.concatenate(times) if times else np.zeros(0)
            i_all = np.concatenate(idx) if idx else np.zeros(0, np.int64)
        if self._simulator == "brian2" and not self._plan.populations[population].is_source:
            t_all = t_all + self._dt  # Brian2 stamps the start of the step
        t_all = np.rint((t_all - self._offset) / self._dt) * self._dt
        keep = (t_all <= self.time + _EPS * self._dt) & (t_all > -_EPS * self._dt)
        t_all, i_all = t_all[keep], i_all[keep]
        order = np.lexsort((i_all, t_all))
        self._cache[population] = (self._steps, t_all[order], i_all[order])
        return t_all[order], i_all[order]

    def _spike_counts(self, population: str) -> np.ndarray:
        _, idx = self._all_spikes(population)
        return np.bincount(idx, minlength=self._network.populations[population].size)

    def _spike_trains(self, population: str) -> tuple[np.ndarray, np.ndarray]:
        times, idx = self._all_spikes(population)
        return times.copy(), idx.copy()

    def _trace(self, population: str, variable: str) -> tuple[np.ndarray, np.ndarray]:
        if self._frozen is not None:
            t, values = self._frozen["traces"][(population, variable)]
            return t.copy(), values.copy()
        return self._live_trace(population, variable)

    def _live_trace(self, population: str, variable: str) -> tuple[np.ndarray, np.ndarray]:
        wanted = self._recording[(population, variable)]
        kind = type(self._network.populations[population].cell_type).__name__
        pynn_var = RECORDABLES[kind][variable]
        pop = self._built.populations[population]
        first = self._record_from.get((population, variable), 0)
        if self._steps <= first:
            return np.zeros(0), np.zeros((0, wanted.size))
        steps = np.arange(first + 1, self._steps + 1)
        if self._simulator == "nest":
            nest_var = pop.celltype.variable_map[pynn_var]
            values, neuron = self._nest_events(pop, pop.recorder._multimeter.device, nest_var)
            times, _ = self._nest_events(pop, pop.recorder._multimeter.device, "times")
            values = values * pop.celltype.scale_factors[pynn_var]
            k = np.rint((times - self._offset) / self._dt).astype(np.int64)
        else:
            with quiet():
                signal = pop.get_data(pynn_var, clear=False).segments[0].filter(name=pynn_var)[0]
            channels = np.asarray(signal.array_annotations["channel_index"], dtype=np.int64)
            k_sig = np.rint(np.asarray(signal.times.rescale("ms").magnitude) / self._dt).astype(np.int64)
            magnitude = np.asarray(signal.magnitude, dtype=np.float64)
            k = np.repeat(k_sig, channels.size)
            neuron = np.tile(channels, k_sig.size)
            values = magnitude.ravel()
        table = np.full((steps.size, self._network.populations[population].size), np.nan)
        inside = (k >= steps[0]) & (k <= steps[-1])
        table[k[inside] - steps[0], neuron[inside]] = values[inside]
        out = table[:, wanted]
        if np.isnan(out).any():
            row = int(np.flatnonzero(np.isnan(out).any(axis=1))[0])
            raise SimulationError(
                f"{self._backend}: no {variable!r} sample of {population!r} at {steps[row] * self._dt:g} ms."
            )
        return steps * self._dt, out

    @staticmethod
    def _nest_events(pop: Any, device: Any, key: str) -> tuple[np.ndarray, np.ndarray]:
        """``(events[key], neuron index)`` of a NEST recording device attached by PyNN."""
        import nest

        with quiet():
            events = nest.GetStatus(device, "events")[0]
        senders = np.asarray(events["senders"], dtype=np.int64)
        index = np.asarray(pop.id_to_index(senders), dtype=np.int64) if senders.size else np.zeros(0, np.int64)
        return np.asarray(events[key], dtype=np.float64), index

    def _connections(self, projection: str) -> tuple[np.ndarray, np.ndarray]:
        conns = self._plan.connections[projection]
        return conns.pre, conns.post

    def _part_weights(self, part: BuiltPart) -> np.ndarray:
        """The part's PyNN weights in the part's canonical order."""
        if self._simulator == "nest":
            with quiet():
                conns = nest_connections(part)
                order, _ = nest_order(part, conns, self._dt)
                native = np.asarray(np.atleast_1d(conns.get("weight")), dtype=np.float64)
        else:
            order, native = part.order, np.asarray(part.native.weight_[:], dtype=np.float64)
        out = np.empty(native.size)
        out[order] = native / part.pynn_sign
        return out

    def _weights(self, projection: str) -> np.ndarray:
        if self._frozen is not None:
            return self._frozen["weights"][projection].copy()
        return self._live_weights(projection)

    def _live_weights(self, projection: str) -> np.ndarray:
        total = np.zeros(len(self._plan.connections[projection]))
        for k in self._plan.parts_of[projection]:
            part = self._built.parts[k]
            w = from_pynn_weights(part.plan.mode, self._part_weights(part))
            if self._simulator == "nest" and part.plan.synapse.kind == "STDPMechanism" and self._plastic:
                w = self._nest_pending(part, w)
            total += w
        return total

    def _set_weights(self, projection: str, values: np.ndarray) -> None:
        self._check_live()
        if self._held is not None:
            self._held = {**self._held, projection: np.array(values, dtype=np.float64)}
        for k in self._plan.parts_of[projection]:
            part = self._built.parts[k]
            pynn = to_pynn_weights(part.plan.mode, values)
            if self._simulator == "nest":
                with quiet():
                    conns = nest_connections(part)
                    order, _ = nest_order(part, conns, self._dt)
                    conns.set({"weight": (pynn[order] * part.pynn_sign).tolist()})
            else:
                part.native.weight_[:] = pynn[part.order] * part.pynn_sign

    def _learned_state(self, population: str) -> dict[str, np.ndarray]:
        return {}

    # -- activity counts ------------------------------------------------------
    def _live_statistics(self) -> dict[str, int]:
        """Spikes, synaptic events and plastic updates since the last (re)build, from the recorded spikes."""
        spikes = events = plastic = 0
        if self._steps == 0:
            return {"spikes": 0, "synaptic_events": 0, "plastic_updates": 0}
        for name in self._network.populations:
            _, idx = self._all_spikes(name)
            out_all, out_plastic, in_plastic = self._degrees[name]
            spikes += int(idx.size)
            events += int(out_all[idx].sum())
            plastic += int(out_plastic[idx].sum() + in_plastic[idx].sum())
        return {"spikes": spikes, "synaptic_events": events, "plastic_updates": plastic}

    def _statistics(self) -> dict[str, int]:
        live = self._live_statistics()
        return {key: int(self._done[key] + live.get(key, 0)) for key in self._done}

    # -- NEST's deferred potentiation -----------------------------------------
    def _nest_pending(self, part: BuiltPart, weights: np.ndarray) -> np.ndarray:
        """Weights with the potentiation NEST has not applied yet.

        NEST's ``stdp_synapse`` applies the potentiation of postsynaptic spikes when
        the synapse's next presynaptic spike arrives; the IR applies it at the
        postsynaptic spike. This adds, for reading, the potentiation of every
        postsynaptic spike since each synapse's last presynaptic spike
        (:func:`.translation.deferred_potentiation`, from NEST's ``Kplus`` traces).
        """
        plan = part.plan
        with quiet():
            conns = nest_connections(part)
            order, _ = nest_order(part, conns, self._dt)
            kplus_native = np.asarray(np.atleast_1d(conns.get("Kplus")), dtype=np.float64)
        kplus = np.empty(kplus_native.size)
        kplus[order] = kplus_native
        pre = self._all_spikes(plan.pre_population)
        post = self._all_spikes(plan.post_population)
        sizes = (self._network.populations[plan.pre_population].size, self._network.populations[plan.post_population].size)
        return deferred_potentiation(plan, weights, kplus, nest_lambdas(part, plan.delay), pre, post, sizes)
