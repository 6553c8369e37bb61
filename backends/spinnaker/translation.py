"""Translate the IR into sPyNNaker's PyNN objects (called inside a set-up sPyNNaker session).

Populations become sPyNNaker's standard types (``IF_curr_exp``, ``IF_cond_exp``,
``SpikeSourcePoisson``, ``SpikeSourceArray``) or ``extra_models.IFCurrExpCa2Adaptive``;
each projection becomes a ``FromListConnector`` holding the canonical connections of
:func:`neurovpr.connectivity.expand`, so the mapped synaptic matrices are exactly
those of every other backend for the same seed. sPyNNaker takes non-negative weights
and lets the receptor give the sign; negative weights onto the excitatory receptor of
a current-based population (signed currents) are mapped as two projections, the
positive weights onto the excitatory and the magnitudes of the negative ones onto
the inhibitory receptor, as one would deploy them on SpiNNaker.
"""

from __future__ import annotations

from types import ModuleType
from typing import Any

import numpy as np

from neurovpr.cells import SpikeSourceArray, SpikeSourcePoisson
from neurovpr.connectivity import expand
from neurovpr.network import Network, Population, Projection
from neurovpr.node import field_values
from neurovpr.pynn_names import (
    CELL_PARAMETERS,
    INITIAL_VALUES,
    SPYNNAKER_CELL_TYPES,
    TIMING_DEPENDENCES,
    WEIGHT_DEPENDENCES,
)
from neurovpr.synapses import STDPMechanism

__all__ = ["build_population", "build_projection", "build_network"]

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
        times = [cell.times[cell.offsets[i] : cell.offsets[i + 1]].tolist() for i in range(pop.size)]
        return sim.Population(pop.size, sim.SpikeSourceArray(spike_times=times), label=pop.name)
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


def _scaled(value: Any, scale: float) -> Any:
    return np.asarray(value, dtype=np.float64) * scale if isinstance(value, np.ndarray) else float(value) * scale


def _synapse(sim: ModuleType, proj: Projection) -> Any:
    syn = proj.synapse
    if not isinstance(syn, STDPMechanism):
        return sim.StaticSynapse()
    t_name, t_rows = TIMING_DEPENDENCES[type(syn.timing_dependence).__name__]
    w_name, w_rows = WEIGHT_DEPENDENCES[type(syn.weight_dependence).__name__]
    t_vals = field_values(syn.timing_dependence)
    w_vals = field_values(syn.weight_dependence)
    return sim.STDPMechanism(
        timing_dependence=getattr(sim, t_name)(**{py: float(t_vals[ir]) * s for ir, py, s in t_rows}),
        weight_dependence=getattr(sim, w_name)(**{py: float(w_vals[ir]) * s for ir, py, s in w_rows}),
    )


def build_projection(
    sim: ModuleType, network: Network, proj: Projection, populations: dict[str, Any], *, dt: float, seed: int
) -> list[Any]:
    """Create the sPyNNaker projection(s) of an IR projection with its canonical connections."""
    conns = expand(network, proj, dt=dt, seed=seed)
    delay = np.maximum(np.rint(conns.delay / dt), 1) * dt
    current = not network.populations[proj.post].cell_type.conductance_based
    if proj.receptor_type == "excitatory" and current and conns.weight.size and conns.weight.min() < 0:
        parts = [
            (conns.weight >= 0, "excitatory", f"{proj.name}[+]"),
            (conns.weight < 0, "inhibitory", f"{proj.name}[-]"),
        ]
    else:
        parts = [(np.ones(len(conns), dtype=bool), proj.receptor_type, proj.name)]
    made = []
    for keep, receptor, label in parts:
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
