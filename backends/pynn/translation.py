"""Translate the IR into PyNN terms: standard cell types, parameters and explicit connections.

Nothing here imports PyNN; the result is a :class:`NetworkPlan` of plain values that
:mod:`.build` turns into PyNN objects. Every projection becomes one or two PyNN
projections ("parts") with a ``FromListConnector`` holding the canonical connections
of :func:`neurovpr.ir.connectivity.expand`, so connections and initial weights are
those of every other backend for the same seed. Each part keeps the canonical index
of each of its connections, which maps PyNN's order back to the canonical one.

PyNN's sign convention differs from the IR's in two places:

- weights onto the inhibitory receptor of a current-based neuron are negative in
  PyNN (positive in the IR);
- PyNN refuses negative weights onto an excitatory receptor, which the IR allows for
  current-based neurons (signed currents). Such a static projection becomes two
  parts holding every connection: the positive part of each weight onto the
  excitatory receptor and the negative part onto the inhibitory one. This is exact
  when ``tau_syn_E == tau_syn_I`` and refused otherwise.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np

from neurovpr.backendkit.pynn_names import CELL_PARAMETERS, CELL_TYPES, INITIAL_VALUES, TIMING_DEPENDENCES, WEIGHT_DEPENDENCES
from neurovpr.backendkit.timing import delay_steps
from neurovpr.errors import UnsupportedFeatureError
from neurovpr.ir.connectivity import Connections, expand
from neurovpr.ir.network import Network, Population, Projection
from neurovpr.ir.node import field_values
from neurovpr.ir.synapses import STDPMechanism

__all__ = [
    "PopulationPlan",
    "connection_degrees",
    "deferred_potentiation",
    "SynapsePlan",
    "PartPlan",
    "NetworkPlan",
    "WeightMode",
    "translate",
    "to_pynn_weights",
    "from_pynn_weights",
]

#: How a part's PyNN weight derives from the IR weight: as is, negated, or its positive / negative part.
WeightMode = Literal["plain", "negate", "positive", "negative"]


@dataclass(frozen=True, slots=True)
class PopulationPlan:
    """One PyNN population."""

    name: str
    size: int
    ir_type: str
    pynn_type: str
    parameters: dict[str, Any]
    initial_values: dict[str, Any]
    is_source: bool
    conductance_based: bool


@dataclass(frozen=True, slots=True)
class SynapsePlan:
    """A PyNN synapse type: ``StaticSynapse`` or ``STDPMechanism`` with its components."""

    kind: str
    timing: tuple[str, dict[str, float]] | None = None
    weight_dependence: tuple[str, dict[str, float]] | None = None


@dataclass(frozen=True, slots=True)
class PartPlan:
    """One PyNN projection: all or part of one IR projection.

    ``index`` holds the canonical index of each of its connections; ``pre``,
    ``post`` and ``delay`` (ms, a whole number of steps) are in that order.
    """

    label: str
    projection: str
    pre_population: str
    post_population: str
    receptor_type: str
    mode: WeightMode
    synapse: SynapsePlan
    index: np.ndarray
    pre: np.ndarray
    post: np.ndarray
    delay: np.ndarray


@dataclass(frozen=True, slots=True)
class NetworkPlan:
    """Everything needed to build the network in PyNN (and to rebuild it after a reset)."""

    dt: float
    populations: dict[str, PopulationPlan]
    parts: list[PartPlan]
    connections: dict[str, Connections]
    parts_of: dict[str, list[int]] = field(default_factory=dict)

    @property
    def max_delay(self) -> float:
        """Longest delay of any connection (ms), at least two steps."""
        longest = max((float(p.delay.max()) for p in self.parts if p.delay.size), default=0.0)
        return max(longest, 2.0 * self.dt)


def to_pynn_weights(mode: WeightMode, ir_weights: np.ndarray) -> np.ndarray:
    """PyNN weights of a part from IR weights (nA or uS)."""
    w = np.asarray(ir_weights, dtype=np.float64)
    if mode == "plain":
        return w.copy()
    if mode == "negate":
        return -w
    if mode == "positive":
        return np.maximum(w, 0.0)
    return np.minimum(w, 0.0)


def from_pynn_weights(mode: WeightMode, pynn_weights: np.ndarray) -> np.ndarray:
    """The IR weight contribution of a part's PyNN weights (parts of one projection add up)."""
    w = np.asarray(pynn_weights, dtype=np.float64)
    return -w if mode == "negate" else w.copy()


def _population_plan(pop: Population) -> PopulationPlan:
    kind = type(pop.cell_type).__name__
    values = field_values(pop.cell_type)
    params = {py: values[ir] * scale for ir, py, scale in CELL_PARAMETERS[kind]}
    initial: dict[str, Any] = {}
    for ir, py, scale in INITIAL_VALUES.get(kind, ()):
        value = pop.v_init if ir == "v_init" else values[ir]
        if ir == "v_init" and value is None:
            value = values["v_rest"]
        initial[py] = value * scale
    return PopulationPlan(
        name=pop.name,
        size=pop.size,
        ir_type=kind,
        pynn_type=CELL_TYPES[kind],
        parameters=params,
        initial_values=initial,
        is_source=pop.is_source,
        conductance_based=pop.cell_type.conductance_based,
    )


def _synapse_plan(proj: Projection) -> SynapsePlan:
    syn = proj.synapse
    if not isinstance(syn, STDPMechanism):
        return SynapsePlan(kind="StaticSynapse")
    t_name, t_rows = TIMING_DEPENDENCES[type(syn.timing_dependence).__name__]
    w_name, w_rows = WEIGHT_DEPENDENCES[type(syn.weight_dependence).__name__]
    t_vals = field_values(syn.timing_dependence)
    w_vals = field_values(syn.weight_dependence)
    return SynapsePlan(
        kind="STDPMechanism",
        timing=(t_name, {py: float(t_vals[ir]) * s for ir, py, s in t_rows}),
        weight_dependence=(w_name, {py: float(w_vals[ir]) * s for ir, py, s in w_rows}),
    )


def _check_signed(proj: Projection, post: Population) -> None:
    """Refuse negative excitatory current weights that PyNN cannot run exactly."""
    if isinstance(proj.synapse, STDPMechanism):
        raise UnsupportedFeatureError(
            f"Backend 'pynn' cannot run projection {proj.name!r}: STDPMechanism weights below 0 onto the "
            "excitatory receptor (PyNN requires excitatory weights >= 0)."
        )
    tau_e = np.asarray(post.cell_type.tau_syn_E)  # type: ignore[attr-defined]
    tau_i = np.asarray(post.cell_type.tau_syn_I)  # type: ignore[attr-defined]
    if not np.allclose(tau_e, tau_i, rtol=1e-12, atol=0.0):
        raise UnsupportedFeatureError(
            f"Backend 'pynn' cannot run projection {proj.name!r}: its negative excitatory weights would go "
            f"through PyNN's inhibitory synapse of {post.name!r}, exact only when tau_syn_E == tau_syn_I "
            f"(got {np.unique(tau_e).tolist()[:3]} and {np.unique(tau_i).tolist()[:3]} ms)."
        )


def translate(network: Network, *, dt: float, seed: int) -> NetworkPlan:
    """Translate ``network`` into a :class:`NetworkPlan` for PyNN.

    Parameters
    ----------
    network
        The network (its types are already known to be supported).
    dt
        Time step (ms); delays are rounded to whole steps.
    seed
        Compile seed of the connectivity expansion.

    Raises
    ------
    UnsupportedFeatureError
        For negative excitatory weights PyNN cannot run exactly.
    """
    pops = {name: _population_plan(pop) for name, pop in network.populations.items()}
    parts: list[PartPlan] = []
    parts_of: dict[str, list[int]] = {}
    connections: dict[str, Connections] = {}
    for proj in network.projections.values():
        conns = expand(network, proj, dt=dt, seed=seed)
        steps = delay_steps(conns.delay, dt)
        conns = Connections(pre=conns.pre, post=conns.post, weight=conns.weight, delay=steps * dt)
        connections[proj.name] = conns
        post = network.populations[proj.post]
        synapse = _synapse_plan(proj)
        index = np.arange(len(conns), dtype=np.int64)
        current = not post.cell_type.conductance_based
        if proj.receptor_type == "excitatory" and current and conns.weight.size and conns.weight.min() < 0:
            _check_signed(proj, post)
            modes: list[tuple[WeightMode, str, str]] = [
                ("positive", "excitatory", f"{proj.name}[+]"),
                ("negative", "inhibitory", f"{proj.name}[-]"),
            ]
        elif proj.receptor_type == "inhibitory" and current:
            modes = [("negate", "inhibitory", proj.name)]
        else:
            modes = [("plain", proj.receptor_type, proj.name)]
        parts_of[proj.name] = []
        for mode, receptor, label in modes:
            parts_of[proj.name].append(len(parts))
            parts.append(
                PartPlan(
                    label=label,
                    projection=proj.name,
                    pre_population=proj.pre,
                    post_population=proj.post,
                    receptor_type=receptor,
                    mode=mode,
                    synapse=synapse,
                    index=index,
                    pre=conns.pre,
                    post=conns.post,
                    delay=conns.delay,
                )
            )
    return NetworkPlan(dt=float(dt), populations=pops, parts=parts, connections=connections, parts_of=parts_of)


def connection_degrees(network: Network, plan: NetworkPlan) -> dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """Per population: outgoing connections, outgoing plastic connections, incoming plastic connections."""
    sizes = {name: pop.size for name, pop in network.populations.items()}
    out = {name: (np.zeros(n, np.int64), np.zeros(n, np.int64), np.zeros(n, np.int64)) for name, n in sizes.items()}
    for name, proj in network.projections.items():
        conns = plan.connections[name]
        out[proj.pre][0][:] += np.bincount(conns.pre, minlength=sizes[proj.pre])
        if proj.synapse.plastic:
            out[proj.pre][1][:] += np.bincount(conns.pre, minlength=sizes[proj.pre])
            out[proj.post][2][:] += np.bincount(conns.post, minlength=sizes[proj.post])
    return out


def deferred_potentiation(
    plan: PartPlan, weights: np.ndarray, kplus: np.ndarray, lam: np.ndarray,
    pre: tuple[np.ndarray, np.ndarray], post: tuple[np.ndarray, np.ndarray], sizes: tuple[int, int],
) -> np.ndarray:  # fmt: skip
    """IR weights of an STDP part with the potentiation NEST has not applied yet.

    NEST's ``stdp_synapse`` applies the potentiation of a postsynaptic spike when the
    synapse's next presynaptic spike arrives; the IR applies it at the postsynaptic spike.
    ``weights`` are the part's IR weights as NEST holds them, ``kplus`` and ``lam`` its
    connections' presynaptic traces and potentiation amplitudes (canonical order), ``pre``
    and ``post`` the ``(times, neurons)`` of the two populations' spikes, ``sizes`` their sizes.
    """
    assert plan.synapse.timing is not None and plan.synapse.weight_dependence is not None
    tau_plus = plan.synapse.timing[1]["tau_plus"]
    w_max = plan.synapse.weight_dependence[1]["w_max"]
    multiplicative = plan.synapse.weight_dependence[0] == "MultiplicativeWeightDependence"
    (pre_t, pre_i), (post_t, post_i) = pre, post
    t_last = np.full(sizes[0], -np.inf)
    np.maximum.at(t_last, pre_i, pre_t)
    out = np.abs(weights) if plan.mode == "negate" else weights.copy()
    candidates = np.flatnonzero((kplus > 0) & (lam > 0) & np.isfinite(t_last[plan.pre]))
    by_post = np.argsort(post_i, kind="stable")
    starts = np.searchsorted(post_i[by_post], np.arange(sizes[1] + 1))
    for j in np.unique(plan.post[candidates]):
        spikes = post_t[by_post[starts[j] : starts[j + 1]]]
        if spikes.size == 0:
            continue
        conns = candidates[plan.post[candidates] == j]
        origin = t_last[plan.pre[conns]] - plan.delay[conns]
        lag = origin[:, None] - spikes[None, :]
        kick = np.where(lag < 0, kplus[conns, None] * np.exp(lag / tau_plus), 0.0) * lam[conns, None]
        if multiplicative:
            remain = np.prod(np.maximum(1.0 - kick, 0.0), axis=1)
            out[conns] = w_max - (w_max - out[conns]) * remain
        else:
            out[conns] = np.minimum(out[conns] + w_max * kick.sum(axis=1), w_max)
    return -out if plan.mode == "negate" else out
