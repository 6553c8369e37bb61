"""Build a :class:`~.translation.NetworkPlan` with PyNN on NEST or Brian2.

The PyNN objects are standard cell types, ``FromListConnector`` projections and
``StaticSynapse`` / ``STDPMechanism``; a static projection's connections are made by one
``nest.Connect`` or ``Synapses.connect`` of arrays with the values PyNN would set
(:func:`_connect_nest_arrays`, :func:`_connect_brian2_arrays`; PyNN's own connector makes them one
target at a time). Where a simulator's own convention differs
from the IR semantics, the build adjusts native settings after PyNN has created the
objects (see each function); the documented differences that remain are listed in
this package's README.md.

Spike sources are built as ``SpikeSourceArray``: Poisson spikes are drawn by
neurovpr, one Bernoulli trial per step as the semantics prescribe, so NEST and
Brian2 receive the same input spikes for the same seed.
"""

from __future__ import annotations

import contextlib
import copy
import importlib
import io
import logging
import warnings
from collections.abc import Iterator
from dataclasses import dataclass, field
from types import ModuleType
from typing import Any

import numpy as np

from neurovpr.errors import SimulationError, UnsupportedFeatureError
from neurovpr.paths import cache_dir

from .capabilities import Simulator
from .translation import NetworkPlan, PartPlan, PopulationPlan, to_pynn_weights

__all__ = ["Built", "BuiltPart", "quiet", "load_simulator", "build_network"]

#: Brian2 weight units (SI value per PyNN unit): nA for current, uS for conductance synapses.
_BRIAN2_SCALE = {False: 1e-9, True: 1e-6}


@contextlib.contextmanager
def quiet() -> Iterator[None]:
    """Silence the simulators' banners, PyNN's notices and deprecation warnings for a while."""
    logger = logging.getLogger("PyNN")
    level = logger.level
    logger.setLevel(logging.ERROR)
    try:
        with warnings.catch_warnings(), contextlib.redirect_stdout(io.StringIO()):
            warnings.simplefilter("ignore")
            yield
    finally:
        logger.setLevel(level)


def load_simulator(simulator: Simulator, *, codegen_target: str = "numpy") -> ModuleType:
    """Import ``pyNN.nest`` or ``pyNN.brian2`` (quietly) and configure the simulator."""
    with quiet():
        module = importlib.import_module("pyNN.nest" if simulator == "nest" else "pyNN.brian2")
    if simulator == "brian2":
        import brian2

        brian2.prefs.codegen.target = codegen_target
        if codegen_target == "cython":
            brian2.prefs.codegen.runtime.cython.cache_dir = str(cache_dir("brian2_cython"))
    return module


@dataclass(slots=True)
class BuiltPart:
    """One PyNN projection and its native connections.

    ``pynn_sign`` converts a PyNN weight to the simulator's native value. For Brian2,
    ``native`` is the ``Synapses`` object and ``order[k]`` the position in the part's
    canonical arrays of its ``k``-th synapse. NEST reorders its connections when it
    prepares a run, so for NEST :func:`nest_connections` fetches them afresh and
    :func:`nest_order` matches them each time.
    """

    plan: PartPlan
    projection: Any
    pynn_sign: float
    native: Any = None
    order: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))


@dataclass(slots=True)
class Built:
    """The PyNN objects of one build."""

    simulator: Simulator
    sim: ModuleType
    populations: dict[str, Any]
    parts: list[BuiltPart] = field(default_factory=list)


# -- populations ------------------------------------------------------------
#: PyNN's Brian2 conductance synapses, with the membrane seeing each step's mean conductance.
_BRIAN2_MEAN_CONDUCTANCE = """
    dge/dt = -ge/tau_syn_e  : siemens
    dgi/dt = -gi/tau_syn_i  : siemens
    i_syn = ge*mean_e*(e_rev_e - v) + gi*mean_i*(e_rev_i - v)  : amp
    mean_e = tau_syn_e/dt*(1 - exp(-dt/tau_syn_e))  : 1
    mean_i = tau_syn_i/dt*(1 - exp(-dt/tau_syn_i))  : 1
    tau_syn_e               : second
    tau_syn_i               : second
    e_rev_e                 : volt
    e_rev_i                 : volt
"""


def _brian2_cell_type(sim: ModuleType, plan: PopulationPlan) -> Any:
    """PyNN's Brian2 LIF types with the IR's threshold test (``v >= v_thresh``) and step.

    Current-based types integrate exactly. Conductance-based types take the IR's
    step: exponential Euler on the membrane with each step's mean conductance
    (``g_start tau / dt (1 - exp(-dt / tau))``), instead of Brian2's default for these
    equations (forward Euler, unstable for the strong inhibitory conductances of the
    VPR models).
    """
    import brian2
    from pyNN.brian2.cells import BaseNeuronGroup
    from pyNN.brian2.standardmodels.cells import leaky_iaf

    method = "exponential_euler" if plan.conductance_based else "exact"
    extra: dict[str, Any] = {}
    if plan.conductance_based:
        extra["eqs"] = leaky_iaf + brian2.Equations(_BRIAN2_MEAN_CONDUCTANCE)

    class _Group(BaseNeuronGroup):
        def __init__(self, n: int, equations: Any, **parameters: Any) -> None:
            equations += """v_thresh : volt (constant)
                            v_reset  : volt (constant)"""
            BaseNeuronGroup.__init__(
                self, n, equations, "v >= v_thresh", reset="v = v_reset", method=method, **parameters
            )

    base = getattr(sim, plan.pynn_type)
    return type(plan.pynn_type, (base,), {"brian2_model": _Group, "__doc__": base.__doc__, **extra})


def _create_population(built: Built, plan: PopulationPlan) -> Any:
    sim = built.sim
    if plan.is_source:
        cell = sim.SpikeSourceArray(spike_times=[])
        pop = sim.Population(plan.size, cell, label=plan.name)
    else:
        params = dict(plan.parameters)
        if built.simulator == "brian2":
            kind = _brian2_cell_type(sim, plan)
            # Brian2 holds v for one step less than ``tau_refrac / dt`` (it counts the spike's own step)
            params["tau_refrac"] = params["tau_refrac"] + sim.get_time_step()
            initial = plan.initial_values
        else:
            # held at rest through the pre-roll (see :func:`release_neurons`)
            kind = getattr(sim, plan.pynn_type)
            params["i_offset"] = 0.0
            initial = {**plan.initial_values, "v": plan.parameters["v_rest"]}
        pop = sim.Population(plan.size, kind(**params), label=plan.name)
        pop.initialize(**initial)
    pop.record("spikes")
    return pop


# -- projections ------------------------------------------------------------
def _synapse_type(built: Built, part: PartPlan) -> Any:
    sim = built.sim
    syn = part.synapse
    if syn.kind == "StaticSynapse":
        return sim.StaticSynapse()
    assert syn.timing is not None and syn.weight_dependence is not None
    timing = getattr(sim, syn.timing[0])(**syn.timing[1])
    wdep = getattr(sim, syn.weight_dependence[0])(**syn.weight_dependence[1])
    if built.simulator == "nest":
        return sim.STDPMechanism(timing_dependence=timing, weight_dependence=wdep, dendritic_delay_fraction=1.0)
    cls = _brian2_stdp_type(sim, multiplicative=syn.weight_dependence[0] == "MultiplicativeWeightDependence")
    return cls(timing_dependence=timing, weight_dependence=wdep, dendritic_delay_fraction=0.0)


def _brian2_stdp_type(sim: ModuleType, *, multiplicative: bool) -> type:
    """PyNN's Brian2 ``STDPMechanism`` with a ``plastic`` gate on the weight update.

    The gate freezes weights while traces keep evolving (``plasticity(False)``); the
    multiplicative form applies ``F+ = w_max - w`` and ``F- = w - w_min``, which
    pyNN.brian2 0.13 replaces by its additive update.
    """
    f_minus = "(weight - w_min)" if multiplicative else "w_max"
    f_plus = "(w_max - weight)" if multiplicative else "w_max"
    pre = f"""
          P += A_plus
          weight = weight + plastic * {f_minus} * M
          weight = int(weight >= w_min)*weight + int(weight < w_min)*w_min
          %(syn_var)s += weight
          """
    post = f"""
           M -= A_minus
           weight = weight + plastic * {f_plus} * P
           weight = int(weight > w_max)*w_max + int(weight <= w_max)*weight
           """
    eqs = sim.STDPMechanism.eqs + "\n             plastic : 1 (shared)"
    return type("STDPMechanism", (sim.STDPMechanism,), {"pre": pre, "post": post, "eqs": eqs})


def nest_connections(part: BuiltPart) -> Any:
    """The part's NEST connections, fetched now (NEST sorts connections before a run)."""
    import nest

    proj = part.projection
    return nest.GetConnections(synapse_model=proj.nest_synapse_model, synapse_label=proj.nest_synapse_label)


def nest_order(part: BuiltPart, conns: Any, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """``(order, delays_ms)`` of NEST connections ``conns``: ``order[k]`` is the canonical position of the k-th."""
    values = conns.get(["source", "target", "delay"])
    proj = part.projection
    pre = np.asarray(proj.pre.id_to_index(np.atleast_1d(values["source"])), dtype=np.int64)
    post = np.asarray(proj.post.id_to_index(np.atleast_1d(values["target"])), dtype=np.int64)
    delay = np.asarray(np.atleast_1d(values["delay"]), dtype=np.float64)
    return _match_order(part.plan, pre, post, delay, dt), delay


def _match_order(part: PartPlan, pre: np.ndarray, post: np.ndarray, delay: np.ndarray, dt: float) -> np.ndarray:
    """Position in the part's canonical arrays of each simulator connection."""
    steps = np.rint(delay / dt).astype(np.int64)
    canon_steps = np.rint(part.delay / dt).astype(np.int64)
    sim_order = np.lexsort((steps, post, pre))
    canon_order = np.lexsort((canon_steps, part.post, part.pre))
    order = np.empty(pre.size, dtype=np.int64)
    order[sim_order] = canon_order
    if pre.size != part.pre.size or not (
        np.array_equal(part.pre[order], pre) and np.array_equal(part.post[order], post)
    ):
        raise SimulationError(
            f"PyNN created {pre.size} connections for {part.label!r} where {part.pre.size} were requested."
        )
    return order


def _by_arrays(built: Built, part: PartPlan, post_pop: Any) -> bool:
    """Whether the part's connections are made from arrays (:func:`_connect_nest_arrays`, :func:`_connect_brian2_arrays`).

    Static synapses with at least one connection; on NEST onto a standard cell type (PyNN's
    per-target path adds a receptor type or a receptor scale otherwise).
    """
    if part.synapse.kind != "StaticSynapse" or part.pre.size == 0:
        return False
    celltype = post_pop.celltype
    return built.simulator == "brian2" or (
        bool(getattr(celltype, "standard_receptor_type", False)) and not hasattr(celltype, "receptor_scale")
    )


def _connect_nest_arrays(projection: Any, part: PartPlan, weights: np.ndarray) -> None:
    """Make a static projection's connections with one ``nest.Connect`` of arrays (NEST's ``one_to_one`` on node ids).

    PyNN's ``FromListConnector`` connects one postsynaptic neuron at a time (a
    ``nest.Connect`` and a ``NodeCollection.tolist()`` per target), which took 24 s to build
    the paper-size LoCS-Net. This makes the same connections as PyNN's per-target calls,
    with the same native values: the synapse type's own translation of the weights and
    delays, inhibitory conductances negated (PyNN's ``_convergent_connect``), PyNN's
    synapse model and label, and PyNN's record of the projection's sources updated.
    """
    import nest

    syn = projection.synapse_type
    space = copy.deepcopy(syn.parameter_space)
    space.shape = (part.pre.size,)
    space.update(weight=weights, delay=part.delay)
    space = syn.translate(space)
    space.evaluate()
    native = dict(space.items())
    weight = np.asarray(native["weight"], dtype=np.float64) * np.ones(part.pre.size)
    delay = np.asarray(native["delay"], dtype=np.float64) * np.ones(part.pre.size)
    if projection.receptor_type == "inhibitory" and projection.post.conductance_based:
        weight = -weight  # NEST wants negative inhibitory conductances
    # the node ids PyNN holds (NodeCollection.tolist() asks NEST for each one)
    pre_ids = np.asarray(projection.pre.all_cells, dtype=np.int64)[part.pre]
    post_ids = np.asarray(projection.post.all_cells, dtype=np.int64)[part.post]
    spec = {
        "synapse_model": projection.nest_synapse_model,
        "synapse_label": projection.nest_synapse_label,
        "weight": weight,
        "delay": delay,
    }
    nest.Connect(pre_ids, post_ids, "one_to_one", spec)
    projection._sources.update(np.unique(pre_ids).tolist())
    projection._simulator.state.stale_connection_cache = True


def _connect_brian2_arrays(projection: Any, part: PartPlan, weights_si: np.ndarray, dt: float) -> None:
    """Make a static projection's synapses on pyNN.brian2 with one ``Synapses.connect`` of index arrays.

    pyNN.brian2 connects a ``FromListConnector`` one postsynaptic neuron at a time and sets each
    synapse's weight and delay one by one in Python (minutes for 10^5 synapses). This makes the
    same synapses (Brian2 numbers repeated pairs itself, PyNN asked for ``synapse_number``) and
    sets the values PyNN would: ``weights_si`` (PyNN's weights in Brian2's base units, as
    :meth:`.simulation.PyNNSimulation` writes them) and the delays rounded to whole steps; a
    static synapse has no other variable.
    """
    syn = projection._brian2_synapses[0][0]
    syn.connect(i=part.pre, j=part.post)
    syn.weight_[:] = weights_si
    syn.delay_[:] = np.round(part.delay / dt) * dt / 1000.0
    projection._n_connections += part.pre.size


def _create_part(built: Built, plan: NetworkPlan, part: PartPlan, ir_weights: np.ndarray, check: bool) -> BuiltPart:
    sim = built.sim
    weights = to_pynn_weights(part.mode, ir_weights)
    pre = built.populations[part.pre_population]
    post = built.populations[part.post_population]
    arrays = _by_arrays(built, part, post)
    # with arrays, PyNN creates the projection empty and the connections are made below
    rows = np.zeros((0, 4)) if arrays else np.column_stack([part.pre, part.post, weights, part.delay])
    connector = sim.FromListConnector(rows, column_names=["weight", "delay"])
    projection = sim.Projection(
        pre, post, connector, _synapse_type(built, part), receptor_type=part.receptor_type, label=part.label
    )
    post_plan = plan.populations[part.post_population]
    if arrays and built.simulator == "nest":
        _connect_nest_arrays(projection, part, weights)
    elif arrays:
        _connect_brian2_arrays(projection, part, weights * _BRIAN2_SCALE[post_plan.conductance_based], plan.dt)
    if built.simulator == "nest":
        inhibitory_cond = part.receptor_type == "inhibitory" and post_plan.conductance_based
        bp = BuiltPart(plan=part, projection=projection, pynn_sign=-1000.0 if inhibitory_cond else 1000.0)
        if check and arrays:  # NEST made one connection per pair or raised: count them
            made = len(nest_connections(bp))
            if made != part.pre.size:
                raise SimulationError(
                    f"NEST created {made} connections for {part.label!r} where {part.pre.size} were requested."
                )
        elif check:
            nest_order(bp, nest_connections(bp), plan.dt)  # checks the connections PyNN made
        if part.synapse.kind == "STDPMechanism":
            set_nest_plasticity(bp, on=True)
        return bp
    native = projection._brian2_synapses[0][0]
    bp = BuiltPart(
        plan=part, projection=projection, pynn_sign=_BRIAN2_SCALE[post_plan.conductance_based], native=native
    )
    s_pre = np.asarray(native.i[:], dtype=np.int64)
    s_post = np.asarray(native.j[:], dtype=np.int64)
    s_delay = np.asarray(native.delay_[:], dtype=np.float64) * 1000.0
    bp.order = _match_order(part, s_pre, s_post, s_delay, plan.dt)
    _adjust_brian2(bp, plan)
    return bp


def _adjust_brian2(part: BuiltPart, plan: NetworkPlan) -> None:
    """Brian2: source delays one step shorter, and post-before-pre at equal times.

    Brian2 stamps a neuron's spike at the start of the step in which it crosses
    threshold and applies an arrival after that step's update, so neuron-to-neuron
    delays already give the IR timing (recorded spike times are shifted by ``dt``
    when read). A spike generator fires at its exact time, so connections from
    sources get ``d - dt`` (0 allowed in Brian2). The post-synaptic pathway runs
    before the pre-synaptic one, so that a presynaptic arrival and a postsynaptic
    spike at the same instant count as ``dt_pair = 0`` (depression), as in the IR.
    """
    syn = part.native
    if plan.populations[part.plan.pre_population].is_source:
        delays_ms = part.plan.delay[part.order] - plan.dt
        syn.delay_[:] = np.maximum(delays_ms, 0.0) / 1000.0
    if part.plan.synapse.kind == "STDPMechanism":
        syn.plastic = 1.0
        syn.pre.order = 2


def nest_lambdas(part: BuiltPart, delay: np.ndarray) -> np.ndarray:
    """NEST's ``lambda`` (potentiation amplitude) of connections with these delays, compensated."""
    timing = part.plan.synapse.timing
    assert timing is not None
    return timing[1]["A_plus"] * np.exp(2.0 * delay / timing[1]["tau_plus"])


def set_nest_plasticity(part: BuiltPart, *, on: bool) -> None:
    """NEST: compensated amplitudes when learning, ``lambda = 0`` when frozen.

    NEST treats the whole delay ``d`` as dendritic: it pairs a presynaptic spike at
    ``t_pre`` with a postsynaptic spike seen at ``t_post + d``, so its interval is the
    IR's ``t_post - (t_pre + d)`` plus ``2 d``. Scaling ``lambda`` (A_plus) by
    ``exp(2 d / tau_plus)`` and the depression amplitude by ``exp(-2 d / tau_minus)``
    makes every pair outside ``-2 d <= dt_pair <= 0`` change the weight exactly as in
    the IR; inside that window NEST potentiates (or, at ``-2 d``, does nothing) where
    the IR depresses. ``lambda = 0`` freezes the weights while the traces go on.
    """
    timing = part.plan.synapse.timing
    assert timing is not None
    conns = nest_connections(part)
    delay = np.asarray(np.atleast_1d(conns.get("delay")), dtype=np.float64)
    if not on:
        conns.set({"lambda": [0.0] * delay.size})
        return
    with np.errstate(over="ignore"):
        lam = nest_lambdas(part, delay)
    if not np.all(np.isfinite(lam)):
        raise UnsupportedFeatureError(
            f"Backend 'pynn' cannot run projection {part.plan.projection!r}: its delay of {delay.max():g} ms is too "
            f"long for NEST's dendritic-delay pairing to be compensated (exp(2 d / tau_plus) overflows)."
        )
    depression = timing[1]["A_minus"] * np.exp(-2.0 * delay / timing[1]["tau_minus"])
    alpha = np.where(lam > 0, depression / np.where(lam > 0, lam, 1.0), 0.0)
    conns.set({"lambda": lam.tolist(), "alpha": alpha.tolist()})


# -- the whole network -------------------------------------------------------
def build_network(
    sim: ModuleType,
    simulator: Simulator,
    plan: NetworkPlan,
    weights: dict[str, np.ndarray],
    *,
    threads: int = 1,
    check: bool = True,
) -> Built:
    """Set up PyNN and create every population and projection of ``plan``.

    Parameters
    ----------
    sim
        ``pyNN.nest`` or ``pyNN.brian2``.
    simulator
        ``"nest"`` or ``"brian2"``.
    plan
        The translated network.
    weights
        Current IR weights of every projection, canonical order.
    threads
        NEST's ``local_num_threads`` (1 for Brian2).
    check
        Verify that NEST made exactly the requested connections (a rebuild of the same
        plan makes the same calls and may leave it out).
    """
    with quiet():
        extra: dict[str, Any] = {}
        if simulator == "nest":
            extra = {"spike_precision": "on_grid", "max_delay": plan.max_delay + plan.dt, "verbosity": "error"}
            extra["threads"] = threads
        sim.setup(timestep=plan.dt, min_delay=plan.dt, **extra)
        if simulator == "nest":
            import nest

            nest.SetDefaults("spike_generator", {"precise_times": False})
        built = Built(simulator=simulator, sim=sim, populations={})
        for pop_plan in plan.populations.values():
            built.populations[pop_plan.name] = _create_population(built, pop_plan)
        for part in plan.parts:
            built.parts.append(_create_part(built, plan, part, weights[part.projection], check))
    return built


#: NEST runs this many steps ahead of the IR clock: a pre-roll of two steps (with the
#: neurons held at rest) lets a relayed source spike at IR time 0 leave its generator
#: one step earlier, at NEST time dt.
NEST_OFFSET_STEPS = 2


def time_offset(simulator: Simulator, dt: float) -> float:
    """Simulator time (ms) at IR time 0."""
    return NEST_OFFSET_STEPS * dt if simulator == "nest" else 0.0


def first_deliverable(simulator: Simulator, t_now: float, dt: float, first_run: bool) -> float:
    """Earliest source spike time (IR ms) a run starting at ``t_now`` delivers on time.

    Brian2 delivers every spike on time. NEST relays a ``SpikeSourceArray`` spike
    through a parrot neuron, so its generator must fire one step before the spike,
    in a step NEST has not simulated yet; after the first run NEST is one step ahead
    (PyNN simulates one step beyond the requested time so that the recorders hold
    every sample), so spikes in the first three steps of a later run are delivered at
    the third. The first run after compile or ``reset()`` delivers every spike on time.
    """
    if simulator == "brian2" or first_run:
        return t_now
    return t_now + 3.0 * dt


def release_neurons(built: Built, plan: NetworkPlan) -> None:
    """NEST: end the pre-roll by giving each neuron its initial membrane and its ``i_offset``."""
    with quiet():
        for pop_plan in plan.populations.values():
            if pop_plan.is_source:
                continue
            pop = built.populations[pop_plan.name]
            pop.set(i_offset=pop_plan.parameters["i_offset"])
            pop.initialize(**pop_plan.initial_values)
