"""A network run through Sinabs's chip-faithful simulation of Speck's layers.

The network is placed on Speck by neurovpr's checker (Sinabs's mapping rules,
:mod:`neurovpr.hardware.speck`); each layer is Sinabs's discretised ``DynapcnnLayer``
(:mod:`.translation`), whose torch forward pass is Sinabs's simulation of the chip's
integer IAF neurons. ``run`` feeds the layers in the order spikes take, each the whole
window at once as Sinabs's ``DynapcnnNetwork`` does: a source spike at ``j dt`` is input
row ``j``; a layer's spikes of row ``j`` (stamped ``(j + 1) dt``, as every backend stamps a
neuron's spikes) are the next layer's input row ``j`` (Speck has no synaptic delays). The
layers' membranes carry over between ``run`` calls (and between the chunks a long run is fed
in); ``reset`` zeroes them.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from neurovpr.backendkit.hosted import HostedSimulation
from neurovpr.errors import UnsupportedFeatureError
from neurovpr.hardware.check import HardwareTarget
from neurovpr.hardware.speck_values import speck_problems, speck_values, threshold_problems
from neurovpr.ir.network import Network

from .compat import import_dynapcnn
from .translation import dynapcnn_layer

__all__ = ["SinabsSimulation"]

#: Steps x neurons of the spike-count rasters one chunk of a run holds (a long run is fed to Sinabs in
#: chunks of this size; the layers' membranes carry over, so the spikes are those of one window).
_CHUNK_VALUES = 1 << 22


class SinabsSimulation(HostedSimulation):
    """``network`` as Sinabs's discretised DYNAP-CNN layers; ``hardware`` is its fit on the ``speck`` hwspec."""

    def __init__(self, network: Network, *, dt: float, seed: int, hardware: HardwareTarget) -> None:
        super().__init__(network, backend="speck", dt=dt, seed=seed, hardware=hardware)
        self._spec = hardware.spec
        self._refuse(speck_problems(self._network, self._spec, dt))
        self._sinabs = import_dynapcnn()
        self._layers: list[tuple[Any, Any]] = []
        self._build()
        self._clear_records()

    def _build(self) -> None:
        started = time.perf_counter_ns()
        values = speck_values(self._network, dt=self._dt, seed=self._seed, weights=self._values)
        self._refuse(threshold_problems(values, self._spec))
        self._layers = [(v, dynapcnn_layer(v, self._spec, self._sinabs)) for v in values]
        self._build_ns += time.perf_counter_ns() - started

    @property
    def layers(self) -> list[Any]:
        """Sinabs's discretised ``DynapcnnLayer`` of every layer, in the order spikes take."""
        return [layer for _, layer in self._layers]

    def _record_counts(self, population: str, counts: np.ndarray, first: int, *, source: bool) -> None:
        """Record a ``(steps, size)`` raster of spike counts (several spikes of one neuron in one step each once)."""
        for k in range(1, int(counts.max(initial=0)) + 1):
            self._record.add(population, counts >= k, first, source=source)

    def _run(self, n_steps: int) -> None:
        started = time.perf_counter_ns()
        sizes = sum(p.size for p in self._network.populations.values())
        chunk = max(1, _CHUNK_VALUES // max(1, sizes))
        for first in range(0, n_steps, chunk):
            self._run_chunk(min(chunk, n_steps - first))
        self._run_ns += time.perf_counter_ns() - started

    def _run_chunk(self, n_steps: int) -> None:
        """Run ``n_steps`` steps: every layer over the whole chunk, in the order spikes take."""
        import torch

        first = self._steps
        maps: dict[str, np.ndarray] = {}
        for name, source in self._sources.items():
            steps, neurons = source.events(first, n_steps)
            counts = np.zeros((n_steps, self._network.populations[name].size), dtype=np.int64)
            np.add.at(counts, (steps - first, neurons), 1)
            self._record_counts(name, counts, first, source=True)
            maps[name] = counts
        with torch.no_grad():
            for values, layer in self._layers:
                x = torch.tensor(maps[values.source].reshape(n_steps, *values.input_shape), dtype=torch.float32)
                out = layer(x).reshape(n_steps, -1).numpy().astype(np.int64)
                self._record_counts(values.population, out, first, source=False)
                maps[values.population] = out
        self._record.add_steps(n_steps)
        self._steps += n_steps

    def _reset(self) -> None:
        for _, layer in self._layers:
            layer.spk_layer.reset_states()
        self._steps = 0
        self._clear_records()

    def _set_recording(self, population: str, variable: str, neurons: np.ndarray) -> None:
        del self._recording[(population, variable)]
        raise UnsupportedFeatureError(f"record: backend 'speck' reads spikes back from Sinabs, not {variable!r}.")
