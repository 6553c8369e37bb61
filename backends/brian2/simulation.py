"""Brian2Simulation: a network built as Brian2 objects in one explicit ``Network``.

Time: Brian2 tests the threshold in the step that integrates ``[j dt, (j + 1) dt)`` and
stamps the spike with the step's start ``j dt``; the semantics stamp it at the end,
``(j + 1) dt``, so neuron spike times and recorded samples are shifted by one step on
read-out (sources are stamped at the start of their step in both). Random numbers come
from Brian2's global generator, which is seeded right before every run from the
simulation's seed and a run counter, so two simulations with the same seed give
identical results whatever runs in between. ``reset()`` restores the snapshot stored at
compile time (``Network.store``) and writes back the learned weights and thresholds;
state monitors are rebuilt empty. Nothing here uses Brian2's magic network, default
clock or global device; the only global state touched is the random seed and, for the
cython target, the cache folder preference while code is compiled.
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator
from typing import Any

import brian2 as b2
import numpy as np

from neurovpr.backendkit.params import per_neuron
from neurovpr.backendkit.timing import window_steps
from neurovpr.errors import BackendUnavailableError, SimulationError, UnsupportedFeatureError
from neurovpr.ir.cells import SpikeSourceArray, SpikeSourcePoisson
from neurovpr.ir.connectivity import expand
from neurovpr.ir.network import Network
from neurovpr.paths import cache_dir
from neurovpr.runtime.simulation import Simulation

from . import build
from .translation import RECORD_MAP

__all__ = ["Brian2Simulation"]

_INITIAL = "neurovpr_initial"
_CACHE_PREF = "codegen.runtime.cython.cache_dir"


class Brian2Simulation(Simulation):
    """A network compiled to Brian2 objects.

    Parameters
    ----------
    network, dt, seed
        See :func:`neurovpr.compile`.
    target
        Brian2's code-generation target: ``"numpy"`` (default) or ``"cython"``
        (compiled once into ``neurovpr.paths.cache_dir("brian2")``, then reused).
    """

    def __init__(self, network: Network, *, dt: float, seed: int, target: str = "numpy") -> None:
        super().__init__(network, backend="brian2", dt=dt, seed=seed)
        self._target = target
        self._cache = cache_dir("brian2") if target == "cython" else None
        if target == "cython":
            from brian2.codegen.runtime.cython_rt import CythonCodeObject

            with self._cython_cache():
                if not CythonCodeObject.is_available():
                    raise BackendUnavailableError(
                        "Backend 'brian2': the cython target needs Cython and a working C compiler; install "
                        "them with: pip install 'neurovpr[brian2]' (and a C compiler), or use target='numpy'."
                    )
            codeobj_class: Any = CythonCodeObject
        else:
            from brian2.codegen.runtime.numpy_rt import NumpyCodeObject

            codeobj_class = NumpyCodeObject
        clock = b2.Clock(dt=dt * 1e-3 * b2.second, name="neurovpr_clock")
        self._ctx = build.BuildContext(clock=clock, codeobj_class=codeobj_class, dt=dt)
        self._pops = {name: build.build_population(pop, self._ctx) for name, pop in network.populations.items()}
        self._projs = {}
        for name, proj in network.projections.items():
            conns = expand(network, proj, dt=dt, seed=seed)
            self._projs[name] = build.build_projection(proj, conns, self._ctx, self._pops[proj.pre], self._pops[proj.post])
        objects: list[Any] = []
        for handle in self._pops.values():
            objects += [handle.group, handle.spikes]
        objects += [handle.synapses for handle in self._projs.values()]
        self._net = b2.Network(*objects, name="neurovpr_network")
        self._rates: dict[str, np.ndarray] = {}
        self._windows: dict[str, tuple[float, float]] = {}
        self._arrays: dict[str, SpikeSourceArray] = {}
        for name, pop in network.populations.items():
            cell = pop.cell_type
            if isinstance(cell, SpikeSourcePoisson):
                self._rates[name] = per_neuron(cell.rate, pop.size)
                first, end = window_steps(cell.start, cell.duration, dt)
                self._windows[name] = (float(first), end)
            elif isinstance(cell, SpikeSourceArray):
                self._arrays[name] = cell
        self._monitors: dict[tuple[str, str], Any] = {}
        self._step = 0
        self._runs = 0
        self._done = {"steps": 0, "neuron_updates": 0, "spikes": 0, "synaptic_events": 0, "plastic_updates": 0}
        self._n_neurons = sum(h.size for h in self._pops.values() if h.kind == "neuron")
        self._net.store(_INITIAL)

    # -- helpers ------------------------------------------------------------------------------
    @contextlib.contextmanager
    def _cython_cache(self) -> Iterator[None]:
        """Point Brian2's Cython cache at the project-owned folder while code is compiled."""
        if self._cache is None:
            yield
            return
        prefs = b2.prefs
        old = prefs[_CACHE_PREF]
        prefs[_CACHE_PREF] = str(self._cache)
        try:
            yield
        finally:
            prefs[_CACHE_PREF] = old

    def _seed_value(self) -> int:
        state = np.random.SeedSequence([self._seed, self._runs]).generate_state(1, dtype=np.uint32)
        return int(state[0])

    def _segments(self, n_steps: int) -> list[int]:
        """Split points so that no Poisson source's start/stop window changes inside a segment."""
        j0, j1 = self._step, self._step + n_steps
        cuts = {j1}
        for start, stop in self._windows.values():
            for edge in (start, stop):
                if j0 < edge < j1:
                    cuts.add(int(edge))
        return sorted(cuts)

    def _apply_rates(self, step: int) -> None:
        for name, rates in self._rates.items():
            start, stop = self._windows[name]
            active = start <= step < stop
            build.set_values(self._pops[name].group, "rates", rates if active else np.zeros_like(rates))

    def _apply_array(self, name: str) -> None:
        src = self._arrays[name]
        neurons, steps = build.array_spikes(name, src, self._dt, self._step)
        group = self._pops[name].group
        group.set_spikes(neurons, steps * (self._dt * 1e-3) * b2.second)

    def _live_statistics(self) -> dict[str, int]:
        counts = {name: np.asarray(h.spikes.count[:], dtype=np.int64) for name, h in self._pops.items()}
        events = plastic = 0
        for handle in self._projs.values():
            if handle.model.plastic:
                events += int(np.rint(build.get_values(handle.synapses, "n_events").sum()))
                plastic += int(np.rint(build.get_values(handle.synapses, "n_plastic").sum()))
            else:
                events += int(counts[handle.pre_population] @ handle.out_degree)
        return {
            "spikes": int(sum(int(c.sum()) for c in counts.values())),
            "synaptic_events": events,
            "plastic_updates": plastic,
        }

    def _new_monitor(self, population: str, variable: str, neurons: np.ndarray) -> None:
        old = self._monitors.pop((population, variable), None)
        if old is not None:
            self._net.remove(old)
        mon = build.build_state_monitor(self._pops[population], variable, neurons, self._ctx)
        self._monitors[(population, variable)] = mon
        self._net.add(mon)

    # -- Simulation hooks ---------------------------------------------------------------------
    @property
    def time(self) -> float:
        return self._step * self._dt

    @property
    def target(self) -> str:
        """The code-generation target (``"numpy"`` or ``"cython"``)."""
        return self._target

    def _set_input(self, population: str, value: Any) -> None:
        if isinstance(value, SpikeSourceArray):
            previous = self._arrays[population]
            self._arrays[population] = value
            try:
                self._apply_array(population)
            except UnsupportedFeatureError:  # two spikes of one neuron in a step: keep the old ones
                self._arrays[population] = previous
                raise
        else:
            self._rates[population] = np.asarray(value, dtype=float).copy()

    def _run(self, n_steps: int) -> None:
        dt_s = self._dt * 1e-3 * b2.second
        b2.seed(self._seed_value())
        self._runs += 1
        with self._cython_cache():
            for cut in self._segments(n_steps):
                self._apply_rates(self._step)
                length = cut - self._step
                self._net.run(length * dt_s, namespace={}, report=None)
                reached = int(np.rint(float(self._net.t_) / (self._dt * 1e-3)))
                if reached != cut:
                    raise SimulationError(f"Backend 'brian2': Brian2 ran to step {reached} instead of {cut}.")
                self._step = cut
                for handle in self._pops.values():
                    if handle.kind == "neuron":
                        build.carry_last_spikes(handle, cut - 1, self._dt)
        self._done["steps"] += n_steps
        self._done["neuron_updates"] += n_steps * self._n_neurons

    def _reset(self) -> None:
        weights = {name: build.get_values(h.synapses, "w") for name, h in self._projs.items()}
        learned = {name: self._learned_state(name) for name in self._pops}
        for key, value in self._live_statistics().items():
            self._done[key] += value
        for mon in self._monitors.values():
            self._net.remove(mon)
        self._net.restore(_INITIAL)
        self._step = 0
        for name, handle in self._projs.items():
            build.set_values(handle.synapses, "w", weights[name])
        for name, state in learned.items():
            for var, values in state.items():
                build.set_values(self._pops[name].group, var, values * 1e-3)
        self._set_plasticity(self._plastic)
        for name in self._arrays:
            self._apply_array(name)
        old, self._monitors = self._monitors, {}
        for (pop, var), mon in old.items():
            self._new_monitor(pop, var, np.asarray(mon.record, dtype=np.int64))

    def _set_plasticity(self, on: bool) -> None:
        value = 1.0 if on else 0.0
        for handle in self._projs.values():
            if handle.model.plastic:
                build.set_values(handle.synapses, "plastic", value)
        for handle in self._pops.values():
            if handle.kind == "neuron" and "learn" in handle.group.variables:
                build.set_values(handle.group, "learn", value)

    def _set_recording(self, population: str, variable: str, neurons: np.ndarray) -> None:
        self._new_monitor(population, variable, neurons)

    def _spike_counts(self, population: str) -> np.ndarray:
        return np.asarray(self._pops[population].spikes.count[:], dtype=np.int64).copy()

    def _spike_trains(self, population: str) -> tuple[np.ndarray, np.ndarray]:
        handle = self._pops[population]
        t = np.asarray(handle.spikes.t_[:], dtype=np.float64)
        i = np.asarray(handle.spikes.i[:], dtype=np.int64)
        steps = np.rint(t / (self._dt * 1e-3)).astype(np.int64) + handle.stamp_offset
        order = np.lexsort((i, steps))
        return steps[order] * self._dt, i[order]

    def _trace(self, population: str, variable: str) -> tuple[np.ndarray, np.ndarray]:
        mon = self._monitors[(population, variable)]
        brian_var, scale = RECORD_MAP[variable]
        steps = np.rint(np.asarray(mon.t_[:], dtype=np.float64) / (self._dt * 1e-3)).astype(np.int64)
        raw = np.asarray(getattr(mon, brian_var + "_"), dtype=np.float64)
        values = raw.reshape(len(mon.record), steps.size).T * scale
        return (steps + 1) * self._dt, values

    def _connections(self, projection: str) -> tuple[np.ndarray, np.ndarray]:
        handle = self._projs[projection]
        return handle.pre, handle.post

    def _weights(self, projection: str) -> np.ndarray:
        handle = self._projs[projection]
        return build.get_values(handle.synapses, "w")[handle.order]

    def _set_weights(self, projection: str, values: np.ndarray) -> None:
        handle = self._projs[projection]
        current = build.get_values(handle.synapses, "w")
        current[handle.order] = values
        build.set_values(handle.synapses, "w", current)

    def _learned_state(self, population: str) -> dict[str, np.ndarray]:
        handle = self._pops[population]
        model = handle.model
        if model is None or "theta" not in model.learned:
            return {}
        return {"theta": build.get_values(handle.group, "theta") * 1e3}

    def _statistics(self) -> dict[str, int]:
        live = self._live_statistics()
        return {key: int(self._done[key] + live.get(key, 0)) for key in self._done}
