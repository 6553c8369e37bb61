"""sPyNNaker's own mapping of a neurovpr network onto a virtual SpiNN-5 board.

The oracle of the SpiNNaker checker: the network is written as the equivalent PyNN
script for ``pyNN.spiNNaker`` (sPyNNaker's own AllToAll/OneToOne connectors where one
delay serves all synapses, explicit lists otherwise, as the checker assumes), mapped on a
virtual one-board machine (``n_boards_required=1``), and the placements and synaptic
matrix sizes are read back before ``end()``.
"""

from __future__ import annotations

import os
import tempfile
from dataclasses import dataclass, field

import numpy as np

import neurovpr as nv


@dataclass
class OracleMapping:
    placements: list[tuple[str, int, int, int, int, int]] = field(default_factory=list)
    matrix_bytes: dict[str, int] = field(default_factory=dict)
    chips: int = 0
    error: str | None = None


def _cell(sim, pop: nv.Population):
    ct = pop.cell_type
    if isinstance(ct, nv.SpikeSourcePoisson):
        return sim.SpikeSourcePoisson(rate=10.0)
    if isinstance(ct, nv.SpikeSourceArray):
        return sim.SpikeSourceArray(spike_times=[[1.0] for _ in range(pop.size)])
    if isinstance(ct, nv.IF_curr_exp_ca2_adaptive):
        return sim.extra_models.IFCurrExpCa2Adaptive()
    if isinstance(ct, (nv.IF_cond_exp, nv.IF_cond_exp_adaptive)):
        return sim.IF_cond_exp()
    return sim.IF_curr_exp()


def _synapse(sim, proj: nv.Projection, weight, delay):
    if proj.plastic:
        return sim.STDPMechanism(
            timing_dependence=sim.SpikePairRule(tau_plus=20.0, tau_minus=20.0, A_plus=0.01, A_minus=0.01),
            weight_dependence=sim.AdditiveWeightDependence(w_min=0.0, w_max=1.0),
            weight=weight, delay=delay,
        )
    return sim.StaticSynapse(weight=weight, delay=delay)


def spinnaker_mapping(network: nv.Network, workdir: str | os.PathLike, seed: int = 0) -> OracleMapping:
    """Map ``network`` with sPyNNaker on a virtual SpiNN-5 board and read the result.

    ``workdir`` holds the configuration and sPyNNaker's reports; it must outlive the
    process (sPyNNaker writes into it at exit).
    """
    tmp = tempfile.mkdtemp(dir=workdir)
    with open(os.path.join(tmp, ".spynnaker.cfg"), "w", encoding="utf-8") as f:
        f.write(f"[Machine]\nvirtual_board = True\nversion = 5\n[Reports]\ndefault_report_file_path = {tmp}\n")
    old = os.environ.get("XDG_CONFIG_HOME")
    os.environ["XDG_CONFIG_HOME"] = tmp
    try:
        return _map(network, seed)
    finally:
        if old is None:
            os.environ.pop("XDG_CONFIG_HOME", None)
        else:
            os.environ["XDG_CONFIG_HOME"] = old


def _map(network: nv.Network, seed: int) -> OracleMapping:
    import pyNN.spiNNaker as sim  # noqa: N813 - PyNN's conventional alias
    from spynnaker.pyNN.data import SpynnakerDataView
    from spynnaker.pyNN.models.neuron.population_machine_vertex import PopulationMachineVertex

    sim.setup(timestep=1.0, n_boards_required=1)
    out = OracleMapping()
    try:
        pops = {p.name: sim.Population(p.size, _cell(sim, p), label=p.name) for p in network.populations.values()}
        for proj in network.projections.values():
            conn = proj.connector
            delay = proj.synapse.delay
            native = (
                isinstance(conn, (nv.AllToAllConnector, nv.OneToOneConnector))
                and isinstance(proj.synapse.weight, float)
                and (delay is None or isinstance(delay, float))
            )
            c = nv.expand(network, proj, dt=1.0, seed=seed)
            weight = np.abs(c.weight)
            if native:
                w = abs(proj.synapse.weight)
                d = 1.0 if delay is None else float(delay)
                if isinstance(conn, nv.AllToAllConnector):
                    pconn = sim.AllToAllConnector(allow_self_connections=conn.allow_self_connections)
                else:
                    pconn = sim.OneToOneConnector()
                syn = _synapse(sim, proj, w, d)
            else:
                rows = np.stack([c.pre, c.post, weight, c.delay], axis=1)
                pconn = sim.FromListConnector(rows)
                syn = _synapse(sim, proj, 0.0, 1.0)
            sim.Projection(pops[proj.pre], pops[proj.post], pconn, syn,
                           receptor_type=proj.receptor_type, label=proj.name)
        try:
            sim.run(1.0)
        except Exception as exc:  # sPyNNaker raises PacmanPlaceException and others
            out.error = f"{type(exc).__name__}: {exc}"
            return out
        chips = set()
        for pl in SpynnakerDataView.iterate_placemements():
            v = pl.vertex
            app = getattr(v, "app_vertex", None)
            if app is None or str(v.label).startswith("SYSTEM"):
                continue
            sl = v.vertex_slice
            out.placements.append((str(app.label), sl.lo_atom, sl.hi_atom, pl.x, pl.y, pl.p))
            chips.add((pl.x, pl.y))
            if isinstance(v, PopulationMachineVertex):
                region = PopulationMachineVertex.SYNAPSE_REGIONS.synaptic_matrix
                cost = v.sdram_required.regions.get(region)
                if cost is not None:
                    out.matrix_bytes[str(app.label)] = int(cost.get_total_sdram(0))
        out.chips = len(chips)
        return out
    finally:
        sim.end()
