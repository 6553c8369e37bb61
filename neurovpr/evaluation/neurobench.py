"""NeuroBench's metrics for a neurovpr network and its runs, by NeuroBench's own definitions.

NeuroBench (package ``neurobench``, 2.3.0) is the field's common yardstick for neuromorphic
solutions. This module computes its static and workload metrics from a network's structure and
a run's recorded spikes (and, for membrane updates, membrane traces) on any backend, without
importing ``neurobench``; ``tests/evaluation/test_neurobench_agreement.py`` checks the counts
against the package itself on an snnTorch model imported through NIR.

Definitions (NeuroBench file in brackets, and how a neurovpr network maps onto it)
---------------------------------------------------------------------------------
A NeuroBench *connection layer* (``nn.Linear``, ``nn.Conv*``) is a neurovpr projection; an
*activation layer* (an snnTorch ``SpikingNeuron``) is a population that is not a spike source.

footprint (``metrics/static/footprint.py``)
    Bytes of a model's parameters and buffers. Here: every stored synapse's weight plus three
    values per spiking neuron (its membrane decay, its threshold and its membrane potential, as
    snnTorch's ``Leaky`` stores ``beta``, ``threshold`` and, once it has stepped, ``mem``), at
    ``value_bytes`` each (4: float32, as torch stores them). snnTorch also keeps two scalars per
    neuron layer (``graded_spikes_factor``, float32, and ``reset_mechanism_val``, int64: 12
    bytes) that have no counterpart here.
connection sparsity (``metrics/static/connection_sparsity.py``)
    Zero weights over all weights of the connection layers. A projection's weights are its
    stored synapses (an all-to-all projection stores ``n_pre x n_post``, as ``nn.Linear``).
    NeuroBench rounds to 4 decimals; this module does not.
activation sparsity (``metrics/workload/activation_sparsity.py``)
    Zero outputs over all outputs of the activation layers, over every step of every sample:
    ``1 - spikes / (neurons x steps x samples)``; input spikes are not counted.
synaptic operations (``metrics/workload/synaptic_operations.py``, ``metrics/utils/layers/macs.py``)
    Per step and connection layer, the layer is applied with its weights binarised
    (non-zero -> 1) to its binarised input: the effective operations are the synapses with a
    non-zero weight whose presynaptic neuron is non-zero in that step; ``Dense`` applies the
    all-ones layer to an all-ones input, i.e. every stored synapse every step. A layer whose
    input holds only 0 and +-1 counts them as accumulates (``Effective_ACs``), otherwise as
    multiply-accumulates (``Effective_MACs``). Spikes are binary, so every neurovpr projection
    counts ACs and ``Effective_MACs`` is 0. Totals are divided by the number of samples.
membrane updates (``metrics/workload/membrane_updates.py``, ``hooks/neuron.py``)
    Per activation layer, every neuron counts on a sample's first step, then on each later
    step where its membrane potential changed (after-step value differs from the one before).
    Totals are divided by the number of samples. Needs the membrane trace (``record(pop, "v")``);
    without it the block gives ``None`` and the dense bound (neurons x steps) instead.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from neurovpr.errors import SimulationError, ValidationError
from neurovpr.ir.connectivity import Connections, expand
from neurovpr.ir.network import Network

__all__ = [
    "NEUROBENCH_VERSION",
    "NeuroBenchCounter",
    "static_metrics",
    "neurobench_from_activity",
    "neurobench_block",
    "synaptic_op_summary",
]

#: The NeuroBench release whose definitions this module follows.
NEUROBENCH_VERSION = "2.3.0"
#: Values stored per spiking neuron by the footprint: membrane decay, threshold, membrane potential.
NEURON_VALUES = 3


def _connections(network: Network, dt: float, seed: int) -> dict[str, Connections]:
    return {name: expand(network, proj, dt=dt, seed=seed) for name, proj in network.projections.items()}


def _spiking(network: Network) -> list[str]:
    return [name for name, pop in network.populations.items() if not pop.is_source]


def static_metrics(
    network: Network,
    *,
    dt: float = 1.0,
    seed: int = 0,
    value_bytes: int = 4,
    connections: Mapping[str, Connections] | None = None,
) -> dict[str, Any]:
    """NeuroBench's static metrics of ``network``: footprint and connection sparsity.

    Parameters
    ----------
    network
        The network.
    dt, seed
        Time step and compile seed with which random connectors are expanded.
    value_bytes
        Bytes per stored value (4 for float32, NeuroBench's usual case).
    connections
        Already expanded connections per projection name (else expanded here).

    Returns
    -------
    dict
        ``footprint_bytes``, ``footprint_weight_bytes``, ``footprint_neuron_bytes``,
        ``connection_sparsity``, ``synapses``, ``zero_weights``.
    """
    if isinstance(value_bytes, bool) or not isinstance(value_bytes, int) or value_bytes < 1:
        raise ValidationError(f"static_metrics: value_bytes must be an integer >= 1, got {value_bytes!r}.")
    conns = dict(connections) if connections is not None else _connections(network, dt, seed)
    synapses = sum(len(c) for c in conns.values())
    zeros = sum(int(np.count_nonzero(c.weight == 0)) for c in conns.values())
    neurons = sum(network.populations[p].size for p in _spiking(network))
    weight_bytes = synapses * value_bytes
    neuron_bytes = neurons * NEURON_VALUES * value_bytes
    return {
        "footprint_bytes": weight_bytes + neuron_bytes,
        "footprint_weight_bytes": weight_bytes,
        "footprint_neuron_bytes": neuron_bytes,
        "connection_sparsity": zeros / synapses if synapses else 0.0,
        "synapses": synapses,
        "zero_weights": zeros,
    }


class NeuroBenchCounter:
    """Accumulates NeuroBench's workload metrics over samples (inferences) of one network.

    Parameters
    ----------
    network
        The network that runs.
    dt, seed
        Time step and compile seed (for expanding random connectors).
    connections
        The connections per projection as the simulation holds them (e.g. after learning:
        ``Connections`` built from ``sim.connections`` and ``sim.weights(..., "list")``);
        expanded from ``network`` when omitted.
    """

    def __init__(
        self, network: Network, *, dt: float, seed: int = 0, connections: Mapping[str, Connections] | None = None
    ) -> None:
        self._network = network
        self._conns = dict(connections) if connections is not None else _connections(network, dt, seed)
        self._spiking = _spiking(network)
        # per presynaptic neuron: stored synapses with a non-zero weight, summed over its projections
        self._fan_out: dict[str, np.ndarray] = {}
        for name, conn in self._conns.items():
            pre = network.projections[name].pre
            fan = self._fan_out.setdefault(pre, np.zeros(network.populations[pre].size, dtype=np.int64))
            fan += np.bincount(conn.pre[conn.weight != 0], minlength=fan.size)
        self._dense_per_step = sum(len(c) for c in self._conns.values())
        self._neurons = sum(network.populations[p].size for p in self._spiking)
        self.samples = 0
        self.steps = 0
        self._acs = 0
        self._spikes = 0
        self._updates: int | None = 0

    def add_sample(
        self,
        *,
        steps: int,
        spike_counts: Mapping[str, np.ndarray],
        membrane: Mapping[str, np.ndarray] | None = None,
    ) -> None:
        """Add one sample of ``steps`` steps.

        Parameters
        ----------
        steps
            Steps of the sample (NeuroBench's time steps of one input).
        spike_counts
            Spikes per neuron in this sample, for every population (sources included).
        membrane
            ``(steps, neurons)`` membrane potential after each step, for every spiking
            population; when omitted (for any sample) membrane updates are not reported.
        """
        if isinstance(steps, bool) or not isinstance(steps, int) or steps < 1:
            raise ValidationError(f"NeuroBenchCounter.add_sample: steps must be an integer >= 1, got {steps!r}.")
        checked: dict[str, np.ndarray] = {}
        for name, pop in self._network.populations.items():
            counts = np.asarray(spike_counts.get(name, ()), dtype=np.int64)
            if counts.shape != (pop.size,):
                raise ValidationError(
                    f"NeuroBenchCounter.add_sample: spike counts of {name!r} must have shape ({pop.size},), got {counts.shape}."
                )
            checked[name] = counts
        updates = None
        if membrane is not None and self._updates is not None:
            updates = 0
            for name in self._spiking:
                v = np.asarray(membrane.get(name, np.empty((0, 0))))
                size = self._network.populations[name].size
                if v.shape != (steps, size):
                    raise ValidationError(
                        f"NeuroBenchCounter.add_sample: membrane of {name!r} must have shape ({steps}, {size}), got {v.shape}."
                    )
                updates += size + int(np.count_nonzero(v[1:] != v[:-1]))
        for name, counts in checked.items():
            if name in self._fan_out:
                self._acs += int(counts @ self._fan_out[name])
            if not self._network.populations[name].is_source:
                self._spikes += int(counts.sum())
        self._updates = None if updates is None else self._updates + updates
        self.samples += 1
        self.steps += steps

    def add_run(self, sim: Any, *, steps: int | None = None) -> None:
        """Add the run a Simulation made since its last reset as one sample.

        Membrane updates are counted when ``v`` of every neuron of every spiking population
        was recorded; ``steps`` defaults to the rows of those traces, else to ``sim.time / dt``.
        """
        counts = {name: sim.spike_counts(name) for name in self._network.populations}
        membrane: dict[str, np.ndarray] | None = {}
        for name in self._spiking:
            try:
                if sim.recorded_neurons(name, "v").size != self._network.populations[name].size:
                    membrane = None
                    break
                membrane[name] = sim.trace(name, "v")[1]
            except SimulationError:  # not recorded
                membrane = None
                break
        if steps is None:
            steps = next(iter(membrane.values())).shape[0] if membrane else max(1, round(sim.time / sim.dt))
        if membrane is not None:
            membrane = {k: v[-steps:] for k, v in membrane.items()}
        self.add_sample(steps=steps, spike_counts=counts, membrane=membrane)

    def result(self) -> dict[str, Any]:
        """NeuroBench's workload metrics per sample (its averaging), and the counts behind them."""
        n = max(self.samples, 1)
        total = self._neurons * self.steps
        return {
            "samples": self.samples,
            "steps_per_sample": self.steps / n,
            "activation_sparsity": (total - self._spikes) / total if total else 0.0,
            "synaptic_operations": {
                "Effective_MACs": 0.0,
                "Effective_ACs": self._acs / n,
                "Dense": self._dense_per_step * self.steps / n,
            },
            "membrane_updates": None if self._updates is None else self._updates / n,
            "membrane_updates_dense": total / n,
        }


def neurobench_from_activity(
    network: Network, activity: Mapping[str, Any], *, dt: float | None = None, seed: int = 0
) -> dict[str, Any]:
    """NeuroBench block from a run's per-inference activity counts (``activity.json``).

    A run that kept only totals (``Simulation.statistics()``) gives NeuroBench's metrics to
    the extent totals allow: ``Dense`` = stored synapses x steps; ``Effective_ACs`` = the
    synaptic events the backend delivered (every stored synapse of a spiking neuron, so a
    zero weight counts here while NeuroBench skips it); activation sparsity from the spikes of
    the non-source populations (``population_spikes``) over neurons x steps; membrane updates
    are not in the totals (``None``; ``membrane_updates_dense`` bounds them).
    """
    step = dt if dt is not None else (activity.get("dt_ms") or 1.0)
    conns = _connections(network, float(step), seed)
    block = static_metrics(network, connections=conns)
    steps = float(activity.get("steps", 0.0))
    neurons = sum(network.populations[p].size for p in _spiking(network))
    pops = activity.get("population_spikes")
    if isinstance(pops, Mapping):
        spikes = sum(float(v) for k, v in pops.items() if k in network.populations and not network.populations[k].is_source)
        sparsity: float | None = 1.0 - spikes / (neurons * steps) if neurons * steps else 0.0
    else:
        sparsity = None
        block["activation_sparsity_reason"] = "the activity has no spikes per population (population_spikes)"
    block.update(
        {
            "version": NEUROBENCH_VERSION,
            "basis": "per-inference activity totals",
            "steps_per_sample": steps,
            "activation_sparsity": sparsity,
            "synaptic_operations": {
                "Effective_MACs": 0.0,
                "Effective_ACs": float(activity.get("synaptic_events", 0.0)),
                "Dense": sum(len(c) for c in conns.values()) * steps,
            },
            "membrane_updates": None,
            "membrane_updates_dense": neurons * steps,
        }
    )
    return block


def neurobench_block(run_dir: str | Path) -> dict[str, Any]:
    """The ``"neurobench"`` block of ``neurovpr eval --json`` for a run directory.

    Built by :func:`neurobench_from_activity` from ``RUN_DIR/activity.json`` (the last
    evaluation's per-inference counts) and ``RUN_DIR/network.h5``; a run without either
    gets ``{"reason": ...}`` saying which is missing.
    """
    from neurovpr.apps.rundir import NETWORK_FILE, RunDir
    from neurovpr.hardware.energy import ACTIVITY_FILE, read_activity

    run = RunDir(run_dir)
    for name in (ACTIVITY_FILE, NETWORK_FILE):
        if not run.part(name).is_file():
            return {"reason": f"the run directory has no {name}"}
    return neurobench_from_activity(run.load_network(), read_activity(run.part(ACTIVITY_FILE)))


def synaptic_op_summary(activity: Mapping[str, Any]) -> str:
    """One sentence stating the synaptic-operation counts an energy estimate multiplies."""
    events = float(activity.get("synaptic_events", 0.0))
    plastic = float(activity.get("plastic_updates", 0.0))
    return (
        f"synaptic operations per inference: {events:g} accumulates (NeuroBench Effective_ACs, "
        f"0 MACs: spikes are binary) x energy per synaptic op; {plastic:g} plastic updates x energy per synaptic update"
    )
