"""Build functions: one per IR type, each creating the Brian2 objects for one node.

Builders are registered per IR class and found along the class's MRO, so a subclass
of a cell or synapse type inherits its builder. Every Brian2 object gets an
explicit, generated name (``pop0``, ``syn3``, ``mon1``...), the simulation's own
``Clock``, an explicit (empty or constant-only) namespace and the code-generation
target's code object class; nothing relies on Brian2's magic network, its default
clock or the caller's local variables. Names and values from the network never
enter Brian2's code: names of populations map to the generated names here, and
values are set as numbers after the objects exist.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import brian2 as b2
import numpy as np
from brian2.devices.device import RuntimeDevice

from neurovpr.backendkit.params import per_neuron
from neurovpr.backendkit.sources import array_events
from neurovpr.backendkit.timing import delay_steps
from neurovpr.errors import SimulationError, UnsupportedFeatureError
from neurovpr.ir.cells import (
    IF_cond_exp,
    IF_cond_exp_adaptive,
    IF_curr_exp,
    IF_curr_exp_ca2_adaptive,
    SpikeSourceArray,
    SpikeSourcePoisson,
)
from neurovpr.ir.connectivity import Connections
from neurovpr.ir.network import Population, Projection
from neurovpr.ir.synapses import DiehlCookSTDP, StaticSynapse, STDPMechanism

from .translation import RECORD_MAP, TAU_SEPARATION, NeuronModel, SynapseModel, neuron_model, synapse_model

__all__ = [
    "BuildContext",
    "PopulationHandle",
    "ProjectionHandle",
    "build_population",
    "build_projection",
    "build_state_monitor",
    "array_spikes",
    "carry_last_spikes",
    "set_values",
    "get_values",
]


@dataclass
class BuildContext:
    """What every build function shares: clock, code object class, time step, names."""

    clock: Any
    codeobj_class: Any
    dt: float
    _counters: dict[str, int] = field(default_factory=dict)

    def name(self, kind: str) -> str:
        """A fresh Brian2 object name (``pop0``, ``pop1``, ``syn0``...)."""
        k = self._counters.get(kind, 0)
        self._counters[kind] = k + 1
        return f"{kind}{k}"


@dataclass
class PopulationHandle:
    """The Brian2 objects of one population.

    Attributes
    ----------
    group
        ``NeuronGroup``, ``PoissonGroup`` or ``SpikeGeneratorGroup``.
    spikes
        Its ``SpikeMonitor``.
    kind
        ``"neuron"``, ``"poisson"`` or ``"array"``.
    stamp_offset
        Steps to add to Brian2's spike step: 1 for neurons (a spike detected in step ``j``
        is stamped ``(j + 1) dt``), 0 for sources (stamped at the start of their step).
    model
        The neuron template and values (``None`` for sources).
    conductance_based
        Whether synaptic input is a conductance (uS) rather than a current (nA).
    """

    name: str
    size: int
    group: Any
    spikes: Any
    kind: str
    stamp_offset: int
    model: NeuronModel | None = None
    conductance_based: bool = False


@dataclass
class ProjectionHandle:
    """The Brian2 ``Synapses`` of one projection and its canonical-order bookkeeping.

    Attributes
    ----------
    pre, post
        Canonical connection indices (from :func:`neurovpr.ir.connectivity.expand`).
    order
        ``order[k]`` is Brian2's synapse index of canonical connection ``k``.
    out_degree
        Connections per presynaptic neuron (synaptic events per presynaptic spike).
    """

    name: str
    synapses: Any
    model: SynapseModel
    pre: np.ndarray
    post: np.ndarray
    order: np.ndarray
    out_degree: np.ndarray
    pre_population: str


def set_values(obj: Any, name: str, values: Any) -> None:
    """Write SI values into a Brian2 variable's array directly (no code generation)."""
    obj.variables[name].set_value(np.asarray(values, dtype=np.float64))


def get_values(obj: Any, name: str) -> np.ndarray:
    """A copy of a Brian2 variable's SI values."""
    return np.array(obj.variables[name].get_value(), dtype=np.float64, copy=True)


def carry_last_spikes(handle: PopulationHandle, step: int, dt: float) -> None:
    """Put the spikes a neuron population fired in Brian2's step ``step`` back into its spikespace.

    Arrivals run in the ``start`` slot of the step after a spike, but Brian2's thresholder
    empties the spikespace when a run ends, which would lose the spikes of a run's last
    step. Called after every run with its last step, this makes a split run (``run(a)``,
    ``run(b)``) identical to one run of ``a + b``. The neurons that fired are those whose
    ``lastspike`` is that step.
    """
    last = np.rint(get_values(handle.group, "lastspike") / (dt * 1e-3))
    fired = np.flatnonzero(last == step).astype(np.int32)
    space = handle.group.variables["_spikespace"].get_value()
    space[: fired.size] = fired
    space[-1] = fired.size


def _lookup(registry: dict[type, Callable[..., Any]], obj: object, what: str) -> Callable[..., Any]:
    for cls in type(obj).__mro__:
        if cls in registry:
            return registry[cls]
    raise UnsupportedFeatureError(f"Backend 'brian2' cannot run {what} {type(obj).__name__}.")


# -- populations ------------------------------------------------------------------------------


def _build_neurons(pop: Population, ctx: BuildContext) -> PopulationHandle:
    model = neuron_model(pop.cell_type, pop.size, ctx.dt, pop.v_init)  # type: ignore[arg-type]
    if model.adjusted:
        warnings.warn(
            f"Population {pop.name!r}: {', '.join(model.adjusted)} equals tau_m for some neurons only; backend "
            f"'brian2' moves it {TAU_SEPARATION:g} (relative) away from tau_m there, where Brian2's exact "
            "solution is singular.",
            stacklevel=2,
        )
    group = b2.NeuronGroup(
        pop.size,
        model.equations,
        threshold=model.threshold,
        reset=model.reset,
        refractory=model.refractory,
        method=model.method,
        clock=ctx.clock,
        namespace={},
        name=ctx.name("pop"),
        codeobj_class=ctx.codeobj_class,
    )
    group.run_regularly(model.clamp, when="groups", order=1, name=ctx.name("clamp"), codeobj_class=ctx.codeobj_class)
    for var, values in {**model.params, **model.initial}.items():
        set_values(group, var, values)
    if "learn" in group.variables:
        set_values(group, "learn", 1.0)
    spikes = b2.SpikeMonitor(group, record=True, name=ctx.name("spk"), codeobj_class=ctx.codeobj_class)
    return PopulationHandle(pop.name, pop.size, group, spikes, "neuron", 1, model, pop.cell_type.conductance_based)


def _build_poisson(pop: Population, ctx: BuildContext) -> PopulationHandle:
    cell = pop.cell_type
    assert isinstance(cell, SpikeSourcePoisson)
    rates = per_neuron(cell.rate, pop.size)
    group = b2.PoissonGroup(
        pop.size,
        rates=rates * b2.Hz,
        clock=ctx.clock,
        namespace={},
        name=ctx.name("pop"),
        codeobj_class=ctx.codeobj_class,
    )
    spikes = b2.SpikeMonitor(group, record=True, name=ctx.name("spk"), codeobj_class=ctx.codeobj_class)
    return PopulationHandle(pop.name, pop.size, group, spikes, "poisson", 0)


def array_spikes(population: str, src: SpikeSourceArray, dt: float, from_step: int) -> tuple[np.ndarray, np.ndarray]:
    """Neuron indices and grid steps of a spike array's spikes at or after ``from_step``.

    Times are rounded to the grid (``round(t / dt)``). Brian2's ``SpikeGeneratorGroup``
    emits at most one spike per neuron and step, so a neuron with two spikes rounding
    to the same step is refused.
    """
    steps, neurons = array_events(src, dt)
    keep = steps >= from_step
    neurons, steps = neurons[keep], steps[keep]
    order = np.lexsort((neurons, steps))
    neurons, steps = neurons[order], steps[order]
    twice = (np.diff(steps) == 0) & (np.diff(neurons) == 0)
    if np.any(twice):
        k = int(np.flatnonzero(twice)[0])
        raise UnsupportedFeatureError(
            f"SpikeSourceArray population {population!r}: neuron {int(neurons[k])} has two spikes in the step at "
            f"{steps[k] * dt:g} ms, but backend 'brian2' (SpikeGeneratorGroup) emits at most one spike per "
            f"neuron and {dt:g} ms step."
        )
    return neurons, steps


def _build_array(pop: Population, ctx: BuildContext) -> PopulationHandle:
    cell = pop.cell_type
    assert isinstance(cell, SpikeSourceArray)
    neurons, steps = array_spikes(pop.name, cell, ctx.dt, 0)
    group = b2.SpikeGeneratorGroup(
        pop.size,
        neurons,
        steps * (ctx.dt * 1e-3) * b2.second,
        clock=ctx.clock,
        name=ctx.name("pop"),
        codeobj_class=ctx.codeobj_class,
    )
    spikes = b2.SpikeMonitor(group, record=True, name=ctx.name("spk"), codeobj_class=ctx.codeobj_class)
    return PopulationHandle(pop.name, pop.size, group, spikes, "array", 0)


_POPULATION_BUILDERS: dict[type, Callable[[Population, BuildContext], PopulationHandle]] = {
    IF_curr_exp: _build_neurons,
    IF_cond_exp: _build_neurons,
    IF_cond_exp_adaptive: _build_neurons,
    IF_curr_exp_ca2_adaptive: _build_neurons,
    SpikeSourcePoisson: _build_poisson,
    SpikeSourceArray: _build_array,
}


def build_population(pop: Population, ctx: BuildContext) -> PopulationHandle:
    """Build the Brian2 objects of one population."""
    return _lookup(_POPULATION_BUILDERS, pop.cell_type, "cell type")(pop, ctx)


# -- projections ------------------------------------------------------------------------------


def _build_synapses(
    proj: Projection,
    conns: Connections,
    ctx: BuildContext,
    pre: PopulationHandle,
    post: PopulationHandle,
) -> ProjectionHandle:
    conductance = post.conductance_based
    model = synapse_model(proj.synapse, conductance=conductance, receptor=proj.receptor_type)
    steps = delay_steps(conns.delay, ctx.dt)
    # Arrivals run at the start of the step they act in (the pathway runs in the 'start'
    # slot and sees the spikes of the previous step). A neuron's spike found in Brian2's
    # step j is stamped (j + 1) dt, a source's at j dt; either is pushed at the start of
    # step j + 1 and delivered D steps later, so D = steps for neurons, steps - 1 for sources.
    brian_steps = steps - (1 if pre.stamp_offset == 0 else 0)
    homogeneous = brian_steps.size == 0 or np.all(brian_steps == brian_steps[0])
    delay = None
    if homogeneous:
        delay = (int(brian_steps[0]) if brian_steps.size else 0) * ctx.dt * 1e-3 * b2.second
    unit = b2.siemens if conductance else b2.amp
    syn = b2.Synapses(
        pre.group,
        post.group,
        model=model.model,
        on_pre=model.on_pre,
        on_post=model.on_post or None,
        delay=delay,
        namespace={"w_unit": model.unit_si * unit},
        clock=ctx.clock,
        name=ctx.name("syn"),
        codeobj_class=ctx.codeobj_class,
    )
    if len(conns):
        syn.connect(i=conns.pre.astype(np.int32), j=conns.post.astype(np.int32))
    else:
        syn.connect(False)  # no synapses (Brian2 refuses empty index arrays)
    if isinstance(b2.get_device(), RuntimeDevice):
        order = _canonical_order(proj.name, conns, np.asarray(syn.i[:]), np.asarray(syn.j[:]))
    else:  # a standalone device: indices are readable only after its run; it keeps the given order
        order = np.arange(len(conns))
    weights = np.empty(len(conns))
    weights[order] = conns.weight
    set_values(syn, "w", weights)
    if not homogeneous:
        d = np.empty(len(conns))
        d[order] = brian_steps * ctx.dt * 1e-3
        set_values(syn.pre, "delay", d)
    for var, value in model.shared.items():
        set_values(syn, var, value)
    syn.pre.when = "start"
    if model.plastic:
        set_values(syn, "plastic", 1.0)
    n_pre = pre.size
    out_degree = np.bincount(conns.pre, minlength=n_pre).astype(np.int64)
    return ProjectionHandle(proj.name, syn, model, conns.pre, conns.post, order, out_degree, proj.pre)


def _canonical_order(name: str, conns: Connections, bi: np.ndarray, bj: np.ndarray) -> np.ndarray:
    """Brian2's synapse index of each canonical connection."""
    if bi.size != len(conns):
        raise SimulationError(f"Projection {name!r}: Brian2 created {bi.size} synapses for {len(conns)} connections.")
    if np.array_equal(bi, conns.pre) and np.array_equal(bj, conns.post):
        return np.arange(len(conns))
    canon = np.lexsort((conns.post, conns.pre))
    brian = np.lexsort((bj, bi))
    order = np.empty(len(conns), dtype=np.int64)
    order[canon] = brian
    return order


_PROJECTION_BUILDERS: dict[type, Callable[..., ProjectionHandle]] = {
    StaticSynapse: _build_synapses,
    STDPMechanism: _build_synapses,
    DiehlCookSTDP: _build_synapses,
}


def build_projection(
    proj: Projection, conns: Connections, ctx: BuildContext, pre: PopulationHandle, post: PopulationHandle
) -> ProjectionHandle:
    """Build the Brian2 ``Synapses`` of one projection from its expanded connections."""
    return _lookup(_PROJECTION_BUILDERS, proj.synapse, "synapse type")(proj, conns, ctx, pre, post)


# -- recording --------------------------------------------------------------------------------


def build_state_monitor(handle: PopulationHandle, variable: str, neurons: np.ndarray, ctx: BuildContext) -> Any:
    """A ``StateMonitor`` sampling ``variable`` at the end of every step (after threshold and reset)."""
    brian_var, _ = RECORD_MAP[variable]
    return b2.StateMonitor(
        handle.group,
        brian_var,
        record=np.asarray(neurons, dtype=np.int64),
        when="end",
        name=ctx.name("mon"),
        codeobj_class=ctx.codeobj_class,
    )
