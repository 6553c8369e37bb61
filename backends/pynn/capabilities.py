"""What the PyNN backends can run, and the finer limits of each PyNN simulator.

``pynn`` runs PyNN on NEST; ``pynn:brian2`` runs PyNN on Brian2. Both take the same
IR types; :func:`feature_problems` lists the parameter combinations one of the two
simulators cannot express, each with the reason, so that compile refuses them by
name instead of running something else.
"""

from __future__ import annotations

import dataclasses
from types import MappingProxyType
from typing import Literal

import numpy as np

from neurovpr.backendkit.capabilities import EVERY_CONNECTOR
from neurovpr.backendkit.pynn_names import CELL_TYPES, NOT_STANDARD_PYNN
from neurovpr.ir.network import Network
from neurovpr.ir.synapses import STDPMechanism
from neurovpr.runtime.backend import Capabilities

__all__ = ["CAPABILITIES_NEST", "CAPABILITIES_BRIAN2", "Simulator", "feature_problems"]

Simulator = Literal["nest", "brian2"]

#: Conformance cases PyNN on NEST cannot pass, with the reason.
_UNSUPPORTED_NEST: dict[str, str] = {
    "stdp_same_instant": "NEST's stdp_synapse treats the whole delay d as dendritic and pairs t_pre with "
    "t_post + d; its amplitudes are rescaled so that every pair outside -2 d <= dt_pair <= 0 changes the weight "
    "as the IR does, but inside that window (dt_pair = 0 included) NEST potentiates (or, at -2 d, does nothing) "
    "where the IR depresses",
}

CAPABILITIES_BRIAN2 = Capabilities(
    cell_types=frozenset(CELL_TYPES),
    connectors=EVERY_CONNECTOR,
    synapses=frozenset({"StaticSynapse", "STDPMechanism"}),
    learns=True,
    heterogeneous_delays=True,
    recordables=frozenset({"v", "gsyn_exc", "gsyn_inh"}),
    reasons=NOT_STANDARD_PYNN,
)

CAPABILITIES_NEST = dataclasses.replace(CAPABILITIES_BRIAN2, unsupported=MappingProxyType(_UNSUPPORTED_NEST))


def feature_problems(network: Network, simulator: Simulator) -> list[str]:
    """Parameter combinations of ``network`` that ``simulator`` under PyNN cannot express.

    Parameters
    ----------
    network
        The network to check (its types are already known to be supported).
    simulator
        ``"nest"`` or ``"brian2"``.

    Returns
    -------
    list of str
        One description per problem, naming the projection or population and the reason.
    """
    problems: list[str] = []
    pops = network.populations
    tau_minus_by_post: dict[str, tuple[float, str]] = {}
    for proj in network.projections.values():
        syn = proj.synapse
        if not isinstance(syn, STDPMechanism):
            continue
        post = pops[proj.post]
        if proj.receptor_type == "inhibitory" and not post.cell_type.conductance_based:
            problems.append(
                f"STDPMechanism onto the inhibitory receptor of current-based population {proj.post!r} "
                f"(projection {proj.name!r}): PyNN gives such weights a negative sign, which the "
                f"{'NEST' if simulator == 'nest' else 'Brian2'} STDP model of PyNN cannot learn"
            )
        wdep = syn.weight_dependence
        if simulator == "nest":
            timing = syn.timing_dependence
            if timing.A_plus == 0.0 and timing.A_minus > 0.0:
                problems.append(
                    f"STDPMechanism with A_plus=0 and A_minus={timing.A_minus:g} (projection {proj.name!r}): "
                    "NEST's stdp_synapse scales depression by A_plus (lambda)"
                )
            if wdep.w_min != 0.0:
                problems.append(
                    f"STDPMechanism with w_min={wdep.w_min:g} (projection {proj.name!r}): NEST's stdp_synapse "
                    "keeps the lower weight bound at 0"
                )
            tau = syn.timing_dependence.tau_minus
            seen = tau_minus_by_post.setdefault(proj.post, (tau, proj.name))
            if seen[0] != tau:
                problems.append(
                    f"STDPMechanism tau_minus={tau:g} ms on projection {proj.name!r} and {seen[0]:g} ms on "
                    f"{seen[1]!r}: NEST keeps tau_minus on the postsynaptic neurons of {proj.post!r}, so all "
                    "plastic projections onto one population need the same tau_minus"
                )
    if simulator == "brian2":
        for pop in pops.values():
            cell = pop.cell_type
            if type(cell).__name__ == "IF_curr_exp":
                for syn_name in ("tau_syn_E", "tau_syn_I"):
                    equal = np.isclose(np.asarray(cell.tau_m), np.asarray(getattr(cell, syn_name)), rtol=1e-9, atol=0)
                    if np.any(equal):
                        problems.append(
                            f"IF_curr_exp with tau_m == {syn_name} == {float(np.asarray(cell.tau_m).ravel()[0]):g} ms "
                            f"in population {pop.name!r}: Brian2's exact integrator divides by tau_m - {syn_name}"
                        )
            tau_refrac = getattr(cell, "tau_refrac", None)
            if isinstance(tau_refrac, np.ndarray) and np.ptp(tau_refrac) > 0:
                problems.append(
                    f"per-neuron tau_refrac in population {pop.name!r}: pyNN.brian2 supports one refractory "
                    "period per population"
                )
    return problems
