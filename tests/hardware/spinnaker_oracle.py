"""sPyNNaker's own mapping of a neurovpr network onto a virtual SpiNN-5 board.

The oracle of the SpiNNaker checker is the spinnaker backend's mapping
(:func:`neurovpr.backends.spinnaker.mapping.map_network`): the network is translated
with sPyNNaker's own AllToAll/OneToOne connectors where they make exactly the
canonical synapses and explicit lists otherwise (the rule the checker assumes), then
partitioned, placed and routed by sPyNNaker on one virtual SpiNN-5 board
(``n_boards_required=1``).

sPyNNaker has no Diehl & Cook neuron or learning rule, so a network using them is
mapped as its sPyNNaker equivalent (:func:`spynnaker_equivalent`): the same sizes,
connections and weights with ``IF_cond_exp`` for ``IF_cond_exp_adaptive`` and pair
STDP for ``DiehlCookSTDP``, which sPyNNaker partitions in the same way. The checker
reports those models as violations of their own.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field

import neurovpr as nv
from neurovpr.backends.spinnaker.mapping import map_network
from neurovpr.errors import ValidationError


@dataclass
class OracleMapping:
    """What sPyNNaker made of a network.

    ``placements`` holds ``(population, lo_atom, hi_atom, x, y, p)`` per core in
    sPyNNaker's placement order (``hi_atom`` inclusive; delay-extension cores are
    labelled ``"<pre>:delays"`` and the separate synapse cores of sub-ms steps
    ``"<population>:synapses"``, as the checker labels them), ``kinds`` the kind of each
    core (``neurons``, ``synapses``, ``source`` or ``delays``), ``core_matrix_bytes`` the
    synaptic matrix region of each of those cores (``None`` where there is none),
    ``matrix_bytes`` that region per population, and ``error`` sPyNNaker's reason when
    it cannot map the network.
    """

    placements: list[tuple[str, int, int, int, int, int]] = field(default_factory=list)
    kinds: list[str] = field(default_factory=list)
    core_matrix_bytes: list[int | None] = field(default_factory=list)
    matrix_bytes: dict[str, int] = field(default_factory=dict)
    chips: int = 0
    error: str | None = None


def spynnaker_equivalent(network: nv.Network) -> nv.Network:
    """``network`` with the models sPyNNaker lacks replaced by ones it partitions alike.

    ``IF_cond_exp_adaptive`` becomes ``IF_cond_exp`` (two synapse types, 256 neurons
    per core either way) and ``DiehlCookSTDP`` becomes an ``STDPMechanism`` with the
    same weights and delays (plastic rows of the same length). Sizes, connections and
    projection names, which seed the connectivity, are kept.
    """
    net = network.copy()
    for pop in network.populations.values():
        if isinstance(pop.cell_type, nv.IF_cond_exp_adaptive):
            net.replace_population(nv.Population(name=pop.name, size=pop.size, cell_type=nv.IF_cond_exp()))
    for proj in network.projections.values():
        syn = proj.synapse
        if isinstance(syn, nv.DiehlCookSTDP):
            stdp = nv.STDPMechanism(
                weight_dependence=nv.AdditiveWeightDependence(w_min=0.0, w_max=syn.w_max), weight=syn.weight, delay=syn.delay
            )
            net.replace_projection(
                nv.Projection(
                    name=proj.name,
                    pre=proj.pre,
                    post=proj.post,
                    connector=proj.connector,
                    synapse=stdp,
                    receptor_type=proj.receptor_type,
                )
            )
    return net


def spinnaker_mapping(network: nv.Network, workdir: str | os.PathLike | None = None, seed: int = 0,
                      dt: float = 1.0) -> OracleMapping:
    """Map ``network`` (its sPyNNaker equivalent) with sPyNNaker on one virtual SpiNN-5 board
    at a time step of ``dt`` ms (sPyNNaker's default 1 ms unless given).

    ``workdir`` is accepted for older callers and not used: ``map_network`` keeps
    sPyNNaker's configuration and reports in a temporary folder of its own.
    """
    del workdir
    out = OracleMapping()
    try:
        mapped = map_network(spynnaker_equivalent(network), dt=dt, seed=seed, n_boards=1)
    except ValidationError as exc:  # sPyNNaker's own reason, in one sentence
        out.error = str(exc)
        return out
    for row in mapped["placements"]:
        label = f"{row['population']}:{row['kind']}" if row["kind"] in ("delays", "synapses") else row["population"]
        out.kinds.append(row["kind"])
        out.placements.append((label, row["lo_atom"], row["hi_atom"], row["x"], row["y"], row["p"]))
        out.core_matrix_bytes.append(row["synaptic_matrix_bytes"])
        if row["synaptic_matrix_bytes"] is not None:
            out.matrix_bytes[label] = row["synaptic_matrix_bytes"]
    out.chips = mapped["chips"]
    return out
