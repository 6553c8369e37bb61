"""Translate the IR into sPyNNaker's PyNN objects (called inside a set-up sPyNNaker session).

Populations become sPyNNaker's standard types (``IF_curr_exp``, ``IF_cond_exp``,
``SpikeSourcePoisson``, ``SpikeSourceArray``) or ``extra_models.IFCurrExpCa2Adaptive``.
A projection becomes sPyNNaker's own ``AllToAllConnector`` or ``OneToOneConnector``
when that connector makes exactly the canonical synapses of
:func:`neurovpr.ir.connectivity.expand` (:func:`uses_native_connector`: one weight and
one delay for every synapse, and for all-to-all without self-connections, a
projection of a population onto itself, the only case in which sPyNNaker leaves
``i -> i`` out). Every other projection is a ``FromListConnector`` holding the
canonical connections; that includes the random connectors, whose sPyNNaker
counterparts would draw other synapses with sPyNNaker's own generator. The mapped
synaptic matrices are therefore exactly those of every other backend for the same
seed, and those the SpiNNaker fit checker (:mod:`neurovpr.hardware.spinnaker`) sizes.

sPyNNaker takes non-negative weights and lets the receptor give the sign: a
projection onto the excitatory receptor of a current-based population whose
weights are all negative goes onto its inhibitory receptor with their magnitudes,
and one with weights of both signs is mapped as two projections, the non-negative
weights onto the excitatory and the magnitudes of the negative ones onto the
inhibitory receptor (:func:`signed_parts`), as one would deploy it on SpiNNaker.
"""

from __future__ import annotations

from types import ModuleType
from typing import Any

import numpy as np

from neurovpr.backendkit.pynn_names import (
    CELL_PARAMETERS,
    INITIAL_VALUES,
    SPYNNAKER_CELL_TYPES,
    TIMING_DEPENDENCES,
    WEIGHT_DEPENDENCES,
)
from neurovpr.ir.cells import SpikeSourceArray, SpikeSourcePoisson
from neurovpr.ir.connectivity import expand
from neurovpr.ir.connectors import AllToAllConnector, OneToOneConnector
from neurovpr.ir.network import Network, Population, Projection
from neurovpr.ir.node import field_values
from neurovpr.ir.synapses import STDPMechanism

__all__ = [
    "build_population",
    "build_projection",
    "build_network",
    "uses_native_connector",
    "signed_parts",
    "spike_times",
]

#: sPyNNaker's stand-in for an unbounded Poisson duration (ms).
_LONG = 1e12


def _cell_class(sim: ModuleType, kind: str) -> Any:
    name = SPYNNAKER_CELL_TYPES[kind]
    if name.startswith("extra_models."):
        from spynnaker.pyNN import extra_models

        return getattr(extra_models, name.split(".", 1)[1])
    return getattr(sim, name)


def build_population(sim: ModuleType, pop: Population) -> Any:
    """Create the sPyNNaker population of an IR population (labelled with its name)."""
    kind = type(pop.cell_type).__name__
    cell = pop.cell_type
    if isinstance(cell, SpikeSourceArray):
        return sim.Population(pop.size, sim.SpikeSourceArray(spike_times=spike_times(cell)), label=pop.name)
    values = field_values(cell)
    params = {py: _scaled(values[ir], scale) for ir, py, scale in CELL_PARAMETERS[kind]}
    if isinstance(cell, SpikeSourcePoisson) and not np.isfinite(params["duration"]):
        params["duration"] = _LONG
    initial: dict[str, Any] = {}
    for ir, py, scale in INITIAL_VALUES.get(kind, ()):
        value = pop.v_init if ir == "v_init" else values[ir]
        if ir == "v_init" and value is None:
            value = values["v_rest"]
        initial[py] = _scaled(value, scale)
    population = sim.Population(pop.size, _cell_class(sim, kind)(**params), label=pop.name)
    if initial:
        population.initialize(**initial)
    return population


def spike_times(cell: SpikeSourceArray) -> list[list[float]]:
    """The ``spike_times`` argument of sPyNNaker's ``SpikeSourceArray`` for ``cell``.

    One list per neuron, or ``[]`` (sPyNNaker's "no spike times") when no neuron
    fires at all: given one empty list per neuron, sPyNNaker 1!7.4.1 takes the most
    common spike time of an empty ``Counter`` and fails with ``IndexError``
    (``SpikeSourceArrayVertex._check_density_double_list``,
    spynnaker/pyNN/models/spike_source/spike_source_array_vertex.py).
    """
    if cell.times.size == 0:
        return []
    return [cell.times[cell.offsets[i] : cell.offsets[i + 1]].tolist() for i in range(cell.n_neurons)]


def _scaled(value: Any, scale: float) -> Any:
    return np.asarray(value, dtype=np.float64) * scale if isinstance(value, np.ndarray) else float(value) * scale


def uses_native_connector(proj: Projection) -> bool:
    """Whether sPyNNaker's own connector makes exactly the canonical synapses of ``proj``.

    True for ``AllToAllConnector`` and ``OneToOneConnector`` with one (float) weight
    and one delay (or none) for every synapse; sPyNNaker's all-to-all leaves ``i -> i``
    out only when a population projects onto itself, so an all-to-all without
    self-connections between two populations is an explicit list.
    """
    conn = proj.connector
    delay = proj.synapse.delay
    if not isinstance(conn, (AllToAllConnector, OneToOneConnector)):
        return False
    if isinstance(conn, AllToAllConnector) and not conn.allow_self_connections and proj.pre != proj.post:
        return False
    return isinstance(proj.synapse.weight, float) and (delay is None or isinstance(delay, float))


def signed_parts(network: Network, proj: Projection, weight: np.ndarray) -> list[tuple[np.ndarray, str, str]]:
    """``(mask, receptor, label)`` of each sPyNNaker projection of ``proj`` given its weights.

    Onto the excitatory receptor of a current-based population, non-negative weights
    stay there and negative ones go to the inhibitory receptor (two projections when
    both occur, labelled ``name[+]`` and ``name[-]``); otherwise one projection.
    """
    every = np.ones(weight.size, dtype=bool)
    current = not network.populations[proj.post].cell_type.conductance_based
    if proj.receptor_type != "excitatory" or not current or not weight.size or weight.min() >= 0:
        return [(every, proj.receptor_type, proj.name)]
    if weight.max() < 0:
        return [(every, "inhibitory", proj.name)]
    return [(weight >= 0, "excitatory", f"{proj.name}[+]"), (weight < 0, "inhibitory", f"{proj.name}[-]")]


def _synapse(sim: ModuleType, proj: Projection, **values: float) -> Any:
    syn = proj.synapse
    if not isinstance(syn, STDPMechanism):
        return sim.StaticSynapse(**values)
    t_name, t_rows = TIMING_DEPENDENCES[type(syn.timing_dependence).__name__]
    w_name, w_rows = WEIGHT_DEPENDENCES[type(syn.weight_dependence).__name__]
    t_vals = field_values(syn.timing_dependence)
    w_vals = field_values(syn.weight_dependence)
    return sim.STDPMechanism(
        timing_dependence=getattr(sim, t_name)(**{py: float(t_vals[ir]) * s for ir, py, s in t_rows}),
        weight_dependence=getattr(sim, w_name)(**{py: float(w_vals[ir]) * s for ir, py, s in w_rows}),
        **values,
    )


def _steps(delay_ms: np.ndarray | float) -> np.ndarray:
    """Delays (ms) rounded to whole steps of at least one of the step sPyNNaker runs.

    sPyNNaker's step is a whole number of microseconds (``dt`` rounded up, see
    :func:`neurovpr.hardware.spinnaker.spynnaker_step_us`); delays are rounded as its
    ``FromListConnector`` and ``AbstractSynapseDynamics.round_delay`` round them,
    ``rint(delay * steps per ms) * step``, so that sPyNNaker keeps them as given.
    """
    from spynnaker.pyNN.data import SpynnakerDataView

    per_ms = SpynnakerDataView.get_simulation_time_step_per_ms()
    step = SpynnakerDataView.get_simulation_time_step_ms()
    return np.maximum(np.rint(np.asarray(delay_ms, dtype=np.float64) * per_ms), 1) * step


def _native_projection(sim: ModuleType, network: Network, proj: Projection, populations: dict[str, Any], *, dt: float) -> Any:
    weight = float(proj.synapse.weight)
    bounds = proj.synapse.weight_bounds
    if bounds is not None:
        weight = float(np.clip(weight, *bounds))
    delay = float(_steps(dt if proj.synapse.delay is None else proj.synapse.delay))
    ((_, receptor, label),) = signed_parts(network, proj, np.array([weight]))
    conn = proj.connector
    if isinstance(conn, AllToAllConnector):
        connector = sim.AllToAllConnector(allow_self_connections=conn.allow_self_connections)
    else:
        connector = sim.OneToOneConnector()
    return sim.Projection(
        populations[proj.pre],
        populations[proj.post],
        connector,
        synapse_type=_synapse(sim, proj, weight=abs(weight), delay=delay),
        receptor_type=receptor,
        label=label,
    )


def build_projection(
    sim: ModuleType, network: Network, proj: Projection, populations: dict[str, Any], *, dt: float, seed: int
) -> list[Any]:
    """Create the sPyNNaker projection(s) of an IR projection with its canonical connections."""
    if uses_native_connector(proj):
        return [_native_projection(sim, network, proj, populations, dt=dt)]
    conns = expand(network, proj, dt=dt, seed=seed)
    delay = _steps(conns.delay)
    made = []
    for keep, receptor, label in signed_parts(network, proj, conns.weight):
        if not keep.any():
            continue
        rows = np.column_stack([conns.pre[keep], conns.post[keep], np.abs(conns.weight[keep]), delay[keep]])
        connector = sim.FromListConnector(rows, column_names=["weight", "delay"])
        made.append(
            sim.Projection(
                populations[proj.pre],
                populations[proj.post],
                connector,
                synapse_type=_synapse(sim, proj),
                receptor_type=receptor,
                label=label,
            )
        )
    return made


def build_network(sim: ModuleType, network: Network, *, dt: float, seed: int) -> dict[str, Any]:
    """Create every population and projection of ``network``; returns the populations by name."""
    populations = {name: build_population(sim, pop) for name, pop in network.populations.items()}
    for proj in network.projections.values():
        build_projection(sim, network, proj, populations, dt=dt, seed=seed)
    return populations
