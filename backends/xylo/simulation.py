"""A network run on XyloSim, Rockpool's module around the C++ bit-accurate Xylo Audio 2 simulator.

The network is placed on Xylo by neurovpr's checker (Rockpool's mapper rules,
:mod:`neurovpr.hardware.xylo`): spike-source populations are the input channels, hidden and
output populations get their hardware neuron ids. Its integers are those of the reference
backend's Xylo arithmetic (:func:`neurovpr.backends.reference.xylo.quantise_xylo`: integer
weights on synapse 1, inhibitory ones negated on synapse 2, ``dash = round(log2(tau / dt))``,
threshold ``v_thresh - v_rest``, bias ``i_offset``), written into the matrices
``XyloSim.from_specification`` takes (``weights_in (Nin, Nhid, 2)``, ``weights_rec``,
``weights_out``). ``run`` feeds XyloSim the input raster of the steps it covers (a source
spike at ``j dt`` is row ``j``) and keeps XyloSim's state between calls; a neuron's spikes of
step ``j`` are reported at ``(j + 1) dt``, as the reference backend reports them.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from neurovpr.backendkit.params import per_neuron
from neurovpr.errors import SimulationError
from neurovpr.hardware.check import HardwareTarget
from neurovpr.hardware.xylo import xylo_layout
from neurovpr.ir.cells import SpikeSourceArray
from neurovpr.ir.connectivity import expand
from neurovpr.ir.network import Network
from neurovpr.runtime.simulation import Simulation

from .compat import import_xylo

__all__ = ["XyloSimSimulation"]


def _dash(tau: Any, size: int, dt: float) -> np.ndarray:
    return np.round(np.log2(per_neuron(tau, size).astype(np.float64) / dt)).astype(int)


class XyloSimSimulation(Simulation):
    """``network`` on XyloSim (see the module docstring); ``hardware`` is its fit on the ``xylo`` hwspec."""

    def __init__(self, network: Network, *, dt: float, seed: int, hardware: HardwareTarget) -> None:
        super().__init__(network, backend="xylo", dt=dt, seed=seed, hardware=hardware)
        net = self._network
        self._layout = xylo_layout(net, hardware.spec.rules)
        self._conns = {name: expand(net, name, dt=dt, seed=seed) for name in net.projections}
        self._weight_values = {name: c.weight.copy() for name, c in self._conns.items()}
        self._arrays: dict[str, SpikeSourceArray] = {
            n: p.cell_type for n, p in net.populations.items() if isinstance(p.cell_type, SpikeSourceArray)}
        self._xylo = import_xylo()
        self._build()
        self._reset()

    def _index(self, names: tuple[str, ...]) -> dict[str, int]:
        out, at = {}, 0
        for name in names:
            out[name] = at
            at += self._network.populations[name].size
        return out

    def _build(self) -> None:
        net, lay = self._network, self._layout
        idx_in, idx_hid, idx_out = self._index(lay.inputs), self._index(lay.hidden), self._index(lay.outputs)
        n_in = sum(net.populations[n].size for n in lay.inputs)
        n_hid = sum(net.populations[n].size for n in lay.hidden)
        n_out = sum(net.populations[n].size for n in lay.outputs)
        w_in, w_rec, w_out = np.zeros((n_in, n_hid, 2), int), np.zeros((n_hid, n_hid, 2), int), np.zeros((n_hid, n_out), int)
        for name, proj in net.projections.items():
            c = self._conns[name]
            syn = 1 if proj.receptor_type == "inhibitory" else 0
            w = np.round(self._weight_values[name] * (-1 if syn else 1)).astype(int)
            if proj.pre in idx_in:
                np.add.at(w_in, (idx_in[proj.pre] + c.pre, idx_hid[proj.post] + c.post, syn), w)
            elif proj.post in idx_hid:
                np.add.at(w_rec, (idx_hid[proj.pre] + c.pre, idx_hid[proj.post] + c.post, syn), w)
            else:
                np.add.at(w_out, (idx_hid[proj.pre] + c.pre, idx_out[proj.post] + c.post), w)
        p: dict[str, list[np.ndarray]] = {k: [] for k in ("dm", "ds1", "ds2", "th", "b", "dmo", "dso", "tho", "bo")}
        for names, keys in ((lay.hidden, ("dm", "ds1", "ds2", "th", "b")), (lay.outputs, ("dmo", "dso", None, "tho", "bo"))):
            for name in names:
                cell, n = net.populations[name].cell_type, net.populations[name].size
                values = (_dash(cell.tau_m, n, self._dt), _dash(cell.tau_syn_E, n, self._dt),
                          _dash(cell.tau_syn_I, n, self._dt),
                          np.round(per_neuron(cell.v_thresh, n) - per_neuron(cell.v_rest, n)).astype(int),
                          np.round(per_neuron(cell.i_offset, n)).astype(int))
                for key, value in zip(keys, values, strict=True):
                    if key is not None:
                        p[key].append(value)
        cat = {k: np.concatenate(v) if v else np.zeros(0, int) for k, v in p.items()}
        self._module = self._xylo.sim.XyloSim.from_specification(
            weights_in=w_in, weights_rec=w_rec, weights_out=w_out, dash_mem=cat["dm"], dash_syn=cat["ds1"],
            dash_syn_2=cat["ds2"], threshold=cat["th"], bias=cat["b"], dash_mem_out=cat["dmo"],
            dash_syn_out=cat["dso"], threshold_out=cat["tho"], bias_out=cat["bo"], dt=self._dt / 1000.0,
        )
        self._idx_in, self._idx_hid, self._idx_out = idx_in, idx_hid, idx_out
        self._n_in = n_in

    @property
    def time(self) -> float:
        return self._step * self._dt

    def _set_input(self, population: str, value: Any) -> None:
        if not isinstance(value, SpikeSourceArray):
            raise SimulationError(f"Backend 'xylo' feeds XyloSim spike arrays only; {population!r} got rates.")
        self._arrays[population] = value

    def _raster(self, j0: int, j1: int) -> np.ndarray:
        raster = np.zeros((j1 - j0, self._n_in), dtype=int)
        for name, src in self._arrays.items():
            full = src.for_size(self._network.populations[name].size)
            neuron = np.repeat(np.arange(full.n_neurons), np.diff(full.offsets))
            steps = np.round(np.asarray(full.times, dtype=np.float64) / self._dt).astype(int)
            keep = (steps >= j0) & (steps < j1)
            np.add.at(raster, (steps[keep] - j0, self._idx_in[name] + neuron[keep]), 1)
        return np.minimum(raster, 15)  # XyloSim MAX_NUM_INP_SPIKES

    def _run(self, n_steps: int) -> None:
        j0 = self._step
        out, _, rec = self._module(self._raster(j0, j0 + n_steps), record=True)
        for key, raster in (("hidden", np.asarray(rec["Spikes"])), ("out", np.asarray(out))):
            t, i = np.nonzero(raster)
            counts = raster[t, i].astype(int)
            self._events[key].append((np.repeat(j0 + t + 1, counts), np.repeat(i, counts)))
        self._vmem.append(np.asarray(rec["Vmem"]))
        self._vmem_out.append(np.asarray(rec["Vmem_out"]))
        self._step += n_steps

    def _reset(self) -> None:
        self._module.reset_state()
        self._step = 0
        self._events: dict[str, list[tuple[np.ndarray, np.ndarray]]] = {"hidden": [], "out": []}
        self._vmem: list[np.ndarray] = []
        self._vmem_out: list[np.ndarray] = []

    def _set_plasticity(self, on: bool) -> None:
        """Xylo does not learn: nothing to switch."""

    def _set_recording(self, population: str, variable: str, neurons: np.ndarray) -> None:
        if variable != "v" or (population not in self._idx_hid and population not in self._idx_out):
            raise SimulationError(f"record: backend 'xylo' records 'v' of neuron populations, not {variable!r} of "
                                  f"{population!r}.")

    def _where(self, population: str) -> tuple[str, int]:
        if population in self._idx_hid:
            return "hidden", self._idx_hid[population]
        if population in self._idx_out:
            return "out", self._idx_out[population]
        return "", -1

    def _spike_trains(self, population: str) -> tuple[np.ndarray, np.ndarray]:
        key, start = self._where(population)
        if not key or not self._events[key]:
            return np.zeros(0), np.zeros(0, dtype=np.int64)
        steps = np.concatenate([e[0] for e in self._events[key]])
        idx = np.concatenate([e[1] for e in self._events[key]]) - start
        size = self._network.populations[population].size
        keep = (idx >= 0) & (idx < size)
        order = np.lexsort((idx[keep], steps[keep]))
        return steps[keep][order] * self._dt, idx[keep][order].astype(np.int64)

    def _spike_counts(self, population: str) -> np.ndarray:
        size = self._network.populations[population].size
        if population in self._arrays:
            return np.zeros(size, dtype=np.int64)
        _, idx = self._spike_trains(population)
        return np.bincount(idx, minlength=size).astype(np.int64)

    def _trace(self, population: str, variable: str) -> tuple[np.ndarray, np.ndarray]:
        key, start = self._where(population)
        chunks = self._vmem if key == "hidden" else self._vmem_out
        vm = np.concatenate(chunks) if chunks else np.zeros((0, 0))
        cell = self._network.populations[population].cell_type
        size = self._network.populations[population].size
        neurons = self._recording[(population, variable)]
        values = per_neuron(cell.v_rest, size)[neurons] + vm[:, start + neurons]
        return np.arange(1, vm.shape[0] + 1) * self._dt, values

    def _connections(self, projection: str) -> tuple[np.ndarray, np.ndarray]:
        c = self._conns[projection]
        return c.pre, c.post

    def _weights(self, projection: str) -> np.ndarray:
        return self._weight_values[projection].copy()

    def _set_weights(self, projection: str, values: np.ndarray) -> None:
        self._weight_values[projection] = values.copy()
        self._build()

    def _learned_state(self, population: str) -> dict[str, np.ndarray]:
        return {}
