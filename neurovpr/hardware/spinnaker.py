"""sPyNNaker's rules for putting a network onto a SpiNNaker board.

The network is translated as the spinnaker backend translates it for sPyNNaker:
``AllToAllConnector`` and ``OneToOneConnector`` with one weight and one delay for all
synapses are sPyNNaker's own connectors (an all-to-all without self-connections only
from a population onto itself, the one case where sPyNNaker leaves ``i -> i`` out);
every other projection (random, convolution or explicit connectors, per-synapse
weights or delays) is the explicit list of its connections (``FromListConnector``), so
that the synapses are exactly those of :func:`neurovpr.expand`. Synaptic words hold
unsigned weights: a list onto the excitatory receptor of a current-based population
with weights of both signs is two projections, the negative weights onto the
inhibitory receptor. Delays are rounded to whole time steps, as sPyNNaker rounds them.

With sPyNNaker's default 1 ms step every population is one application vertex on
combined neuron-and-synapse cores (``PopulationVertex.use_combined_core``), split into
fixed slices of at most the per-core maximum (``SplitterPopulationVertexFixed``); Poisson
sources are sliced in the same way with their own maximum, a ``SpikeSourceArray`` is one
core. Delays beyond a core's ring buffer add one delay-extension core per slice of the
presynaptic population (``extra_algorithms/delay_support_adder.py``). Each core's
synaptic matrix is sized as ``PopulationVertex.get_synapses_size`` does (the longest row
of each incoming projection for a full core, one block per presynaptic slice, blocks
aligned by the master population table). Cores are then placed on the board's chips in
the order of PACMAN's ``ApplicationPlacer`` (chips filled core by core, moving to
neighbouring chips of the current board, new start chips in x-then-y order).

Below a 1 ms step (``split_core_below_ms``) sPyNNaker gives each population with
synaptic input separate cores (``SplitterPopulationVertexNeuronsSynapses``): per slice
one neuron core fed by as many synapse cores as ``PopulationVertex.n_synapse_cores_required``
estimates from the synaptic events per second (every source assumed to fire at the
configured rate) and what one synapse core processes (static or STDP), plus the cores of
any one-to-one Poisson source simulated next to it; these cores share one chip. The lead
synapse core holds the synaptic matrix. Populations without synaptic input keep a
combined core.

sPyNNaker runs a whole number of microseconds per step: it rounds the requested step up
(:func:`spynnaker_step_us`), and delays, the delay slots and the sub-ms rule all use
that step (:func:`partition_spinnaker` takes a spec already on it, see
:func:`spynnaker_timing`).

All counts and sizes come from the hwspec (``[core]``, ``[spinnaker]``).
"""

from __future__ import annotations

import dataclasses
import math

from tqdm import tqdm

from neurovpr.ir.cells import SpikeSourceArray, SpikeSourcePoisson
from neurovpr.ir.connectors import OneToOneConnector
from neurovpr.ir.network import Network, Projection

from .architectures import Architecture
from .cores import CoreSlice, Partition, Violation
from .hwspec import HwSpec
from .spinnaker_rows import (
    SpinnakerRules,
    align_block,
    delay_steps,
    longest_delay,
    native_connector,
    row_lengths,
    row_words,
)

__all__ = ["partition_spinnaker", "n_bits", "spynnaker_step_us", "spynnaker_timing", "SPINNAKER"]

#: Link directions of a SpiNNaker chip, in link-id order (spinn_machine/machine.py LINK_ADD_TABLE).
_LINKS = ((1, 0), (1, 1), (0, 1), (-1, 0), (-1, -1), (0, -1))


def n_bits(n_values: int) -> int:
    """Bits needed for ``n_values`` values (``pacman.utilities.utility_calls.get_n_bits``)."""
    if n_values <= 1:
        return max(n_values, 0)
    return math.ceil(math.log2(n_values))


def spynnaker_step_us(dt_ms: float) -> int:
    """The time step (whole microseconds) sPyNNaker runs when asked for ``dt_ms``.

    sPyNNaker 1!7.4.1 sets its step to ``math.ceil(timestep * MICRO_TO_MILLISECOND_CONVERSION)``
    microseconds (spynnaker/pyNN/spinnaker.py ``SpiNNaker._set_up_timings``, with
    ``MICRO_TO_MILLISECOND_CONVERSION = 1000.0`` from
    spinn_front_end_common/utilities/constants.py) and uses that number / 1000.0 as its step
    in ms (spinn_front_end_common/data/fec_data_writer.py ``_set_simulation_time_step``). The
    same float expression is used here: 0.1234 ms runs as 124 us, 0.9995 ms as 1000 us and,
    by float rounding (2.007 * 1000.0 > 2007), 2.007 ms as 2008 us.
    """
    return math.ceil(float(dt_ms) * 1000.0)


def spynnaker_timing(spec: HwSpec) -> HwSpec:
    """``spec`` with ``[timing].time_step_ms`` the step sPyNNaker runs (:func:`spynnaker_step_us` / 1000.0).

    Apply it once: a step already in whole microseconds can round up again in float
    arithmetic (2.008 ms is not exactly 2008 us).
    """
    step_ms = spynnaker_step_us(spec.timing.time_step_ms) / 1000.0
    return dataclasses.replace(spec, timing=dataclasses.replace(spec.timing, time_step_ms=step_ms))


def _max_atoms(pop, spec: HwSpec) -> int:
    rules = spec.rules
    assert isinstance(rules, SpinnakerRules)
    if isinstance(pop.cell_type, SpikeSourcePoisson):
        return min(rules.poisson_sources_per_core, pop.size)
    if isinstance(pop.cell_type, SpikeSourceArray):
        return pop.size if rules.array_sources_per_core == 0 else min(rules.array_sources_per_core, pop.size)
    return min(spec.core.max_neurons, pop.size)


class _Placer:
    """PACMAN's ``ApplicationPlacer`` with cores as the only resource.

    An application vertex is a list of same-chip groups (one core each, or a neuron core
    with its synapse and Poisson cores), placed from a start chip onto neighbouring chips
    of the same board; a chip too full for a group is skipped, and if the neighbourhood
    runs out the attempt is dropped and repeated from the next start chip
    (``_prepare_placements``). Start chips tried for one vertex are offered first to the
    next vertex; new start chips come in x-then-y order.
    """

    def __init__(self, spec: HwSpec) -> None:
        rules = spec.rules
        assert rules is not None
        reduced = {tuple(c) for c in rules.reduced_core_chips}
        coords = sorted((x, y) for y, lo, hi in rules.chip_rows for x in range(lo, hi + 1))
        self.free: dict[tuple[int, int], list[int]] = {}
        for xy in coords:
            n_cores = spec.chip.cores_per_chip - (1 if xy in reduced else 0)
            taken = rules.system_cores_per_chip + (rules.ethernet_chip_extra_cores if xy == coords[0] else 0)
            self.free[xy] = list(range(taken, n_cores))
        self.order = iter(coords)
        self.full: set[tuple[int, int]] = set()
        self.starts_tried: list[tuple[int, int]] = []
        self.restored: list[tuple[int, int]] = []
        self.neighbours: dict[tuple[int, int], None] = {}

    def _space(self, xy: tuple[int, int], n_cores: int, prepared: set) -> list[int] | None:
        """Free cores of ``xy`` if a group of ``n_cores`` fits (``_space_on_chip``)."""
        if not self.free[xy]:
            self.full.add(xy)
            return None
        prepared.add(xy)
        if len(self.free[xy]) < n_cores:
            return None
        for dx, dy in _LINKS:
            n = (xy[0] + dx, xy[1] + dy)
            if n in self.free and n not in self.full and n not in prepared:
                self.neighbours[n] = None
        return list(self.free[xy])

    def _start(self, n_cores: int, prepared: set) -> tuple[tuple[int, int], list[int]] | None:
        self.neighbours.clear()
        while True:
            start = None
            while self.restored:
                chip = self.restored.pop(0)
                if chip not in self.full:
                    start = chip
                    break
            if start is None:
                start = next((c for c in self.order if c not in self.full), None)
                if start is None:
                    return None
            self.starts_tried.append(start)
            cores = self._space(start, n_cores, prepared)
            if cores is not None:
                return start, cores

    def place_vertex(self, groups: list[int]) -> list[tuple[int, int, int]] | None:
        """Cores ``(x, y, p)`` for one vertex of same-chip groups of ``groups`` cores, or None
        when no chip is left."""
        self.restored.extend(self.starts_tried)
        self.starts_tried = []
        while True:
            prepared: set = set()
            current: tuple[tuple[int, int], list[int]] | None = None
            out: list[tuple[int, int, int]] = []
            for n_cores in groups:
                if current is None:
                    current = self._start(n_cores, prepared)
                    if current is None:
                        return None
                elif len(current[1]) < n_cores:
                    current = None
                    while self.neighbours:
                        cand = next(iter(self.neighbours))
                        del self.neighbours[cand]
                        cores = self._space(cand, n_cores, prepared)
                        if cores is not None:
                            current = (cand, cores)
                            break
                    if current is None:
                        break
                out += [(current[0][0], current[0][1], current[1].pop(0)) for _ in range(n_cores)]
            else:
                for x, y, p in out:
                    self.free[(x, y)].remove(p)
                return out


def _direct_poisson(network: Network, proj: Projection, spec: HwSpec, n_out: dict[str, int]) -> bool:
    """Whether ``proj`` is a Poisson source sPyNNaker simulates next to the neuron core
    (``splitter_utils.is_direct_poisson_source``): its only projection, one-to-one onto a
    population of its size, static, with a delay of one step."""
    pre, post = network.populations[proj.pre], network.populations[proj.post]
    if not (isinstance(pre.cell_type, SpikeSourcePoisson) and n_out[proj.pre] == 1 and pre.size == post.size
            and isinstance(proj.connector, OneToOneConnector) and native_connector(proj) and not proj.plastic):
        return False
    delay = proj.synapse.delay  # one float (a native connector)
    return delay is None or bool(delay_steps(delay, spec.timing.time_step_ms) <= 1)


def _synapse_cores(network: Network, spec: HwSpec, projs: list[Projection], events: dict[str, list[int]],
                   n_out: dict[str, int]) -> tuple[int, list[str]]:
    """Synapse cores of a population fed by ``projs`` (``n_synapse_cores_required``; 0 means a
    combined core) and the Poisson sources simulated on its chips, at a sub-ms step.

    ``events`` holds the estimated longest row of each sPyNNaker projection, ``n_out`` the
    number of sPyNNaker projections leaving each population.
    """
    rules = spec.rules
    assert isinstance(rules, SpinnakerRules)
    pops = network.populations
    step_us = round(spec.timing.time_step_ms * 1000.0)  # whole microseconds (spynnaker_timing)
    scale = max(1, math.ceil(step_us / rules.time_scale_step_us))
    plastic = any(p.plastic and events[p.name] for p in projs)
    per_core = (rules.stdp_synapses_per_second if plastic else rules.static_synapses_per_second) * scale
    max_cores = spec.chip.cores_per_chip - rules.system_cores_per_chip - 1
    counted = direct_count = 0
    poisson: list[Projection] = []  # incoming_poisson_projections: one projection from a Poisson source
    for pre in dict.fromkeys(p.pre for p in projs):
        from_pre = [p for p in projs if p.pre == pre]
        count = sum(math.ceil(n * rules.spikes_per_second * pops[pre].size) for p in from_pre for n in events[p.name])
        single = sum(len(events[p.name]) for p in from_pre) == 1
        if single and isinstance(pops[pre].cell_type, SpikeSourcePoisson):
            poisson.append(from_pre[0])
        if single and _direct_poisson(network, from_pre[0], spec, n_out):
            direct_count += count
        else:
            counted += count
    n = math.ceil(counted / per_core)
    if n + len(poisson) >= max_cores:
        n = min(math.ceil((counted + direct_count) / per_core), max_cores)
    if n == 0 or len(poisson) + n + 1 >= spec.chip.cores_per_chip - rules.scamp_cores_per_chip:
        return n, []
    return n, [p.pre for p in poisson if _direct_poisson(network, p, spec, n_out)]


def _core_groups(name: str, kind: str, size: int, per_core: int, spec: HwSpec, matrix: int, n_syn: int,
                 feeders: list[str]) -> list[list[dict]]:
    """The cores of one application vertex as same-chip groups, one group per slice.

    A population with synapse cores has per slice its lead synapse core (holding the
    synaptic matrix), the other synapse cores, the cores of the Poisson sources
    ``feeders`` and the neuron core, in sPyNNaker's order.
    """
    groups = []
    for lo in range(0, size, per_core):
        hi = min(lo + per_core, size)
        if kind != "neurons":
            label = f"{name}:delays" if kind == "delays" else name
            groups.append([dict(population=label, lo=lo, hi=hi, kind=kind, usage={"neurons": hi - lo},
                                limits={"neurons": per_core})])
            continue
        neuron = dict(population=name, lo=lo, hi=hi, kind="neurons", usage={"neurons": hi - lo},
                      limits={"neurons": spec.core.max_neurons})
        if n_syn == 0:
            neuron["usage"]["synaptic_matrix_bytes"] = matrix
            groups.append([neuron])
            continue
        group = [dict(population=f"{name}:synapses", lo=lo, hi=hi, kind="synapses",
                      usage={"synaptic_matrix_bytes": matrix} if k == 0 else {}, limits={}) for k in range(n_syn)]
        group += [dict(population=src, lo=lo, hi=hi, kind="sources", usage={"neurons": hi - lo},
                       limits={"neurons": per_core}) for src in feeders]
        groups.append([*group, neuron])
    return groups


def partition_spinnaker(network: Network, spec: HwSpec, *, seed: int = 0) -> Partition:
    """Split and place ``network`` on a SpiNNaker board with sPyNNaker's rules (module docstring).

    ``spec.timing.time_step_ms`` must be a step sPyNNaker runs, in whole microseconds
    (:func:`spynnaker_timing`, which the architecture's ``runs_at`` applies before
    :func:`neurovpr.hardware.partition.partition` calls this).
    """
    rules = spec.rules
    assert isinstance(rules, SpinnakerRules), "the spinnaker partitioner needs [spinnaker]"
    step = spec.timing.time_step_ms
    pops = network.populations
    max_atoms = {name: _max_atoms(p, spec) for name, p in pops.items()}
    violations: list[Violation] = []

    # Pass 1: delay slots each core offers, the delay each projection needs, delay stages.
    incoming: dict[str, list[Projection]] = {n: [] for n in pops}
    for proj in network.projections.values():
        incoming[proj.post].append(proj)
    type_bits = n_bits(rules.synapse_types)
    plan: dict[str, tuple[float, list[tuple[Projection, float]]]] = {}
    delay_pre: dict[str, int] = {}
    extended: set[tuple[str, str]] = set()  # (pre, post) edges with a delay extension
    for name, pop in pops.items():
        if pop.is_source:
            continue
        slots = 2 ** (rules.ring_buffer_bits - (n_bits(max_atoms[name]) + type_bits))
        pre_order = list(dict.fromkeys(p.pre for p in incoming[name]))
        projs = sorted(incoming[name], key=lambda p: pre_order.index(p.pre))
        delays = [longest_delay(network, p, spec, seed) for p in projs]
        support = min(2 ** n_bits(math.ceil(max(delays, default=step) / step - 1e-9)), slots)
        max_ms = support * step
        plan[name] = (max_ms, list(zip(projs, delays, strict=True)))
        for proj, delay in plan[name][1]:
            if delay <= max_ms:
                continue
            extended.add((proj.pre, name))
            delay_pre[proj.pre] = max(delay_pre.get(proj.pre, 0), math.ceil(delay / max_ms) - 1)
            limit_ms = (rules.delay_extension_stages + 1) * max_ms
            if delay > limit_ms + 1e-9:
                violations.append(
                    Violation(limit="delay", where=proj.name, value=delay / step, maximum=limit_ms / step,
                              message=(f"Projection {proj.name!r}: delay of {delay / step:g} steps exceeds the "
                                       f"{limit_ms / step:g} steps a delay extension supports onto {name!r}."))
                )

    # Pass 2: synaptic matrix bytes of a core of each population (get_synapses_size).
    matrix: dict[str, int] = {}
    events: dict[str, list[int]] = {}
    for name, (max_ms, projs) in tqdm(plan.items(), desc=f"synaptic matrices for {spec.name}", unit="population",
                                      leave=False, disable=len(plan) < 20):
        address = rules.matrix_base_bytes
        for proj, _ in projs:
            n_sub = max_atoms[proj.pre]
            n_edges = -(-pops[proj.pre].size // n_sub)
            stages = delay_pre.get(proj.pre, 0)
            parts, events[proj.name] = row_lengths(network, proj, spec, seed, max_atoms[name], max_ms,
                                                    (proj.pre, name) in extended)
            for n_syn, n_stage in [pair for r in parts for pair in ((r.undelayed, 1), (r.delayed, stages))]:
                words = row_words(n_syn, proj.plastic, rules)
                if words > rules.max_row_words:
                    violations.append(
                        Violation(limit="synaptic row length", where=proj.name, value=words,
                                  maximum=rules.max_row_words,
                                  message=(f"Projection {proj.name!r}: a synaptic row of {words} words exceeds the "
                                           f"{rules.max_row_words}-word maximum on {spec.name}."))
                    )
                if words == 0 or n_stage == 0:
                    continue
                size = n_sub * (words + rules.row_header_words) * rules.bytes_per_word * n_stage
                for _ in range(n_edges):
                    address = align_block(address, rules) + size
        matrix[name] = address

    # Below split_core_below_ms: synapse cores per population and Poisson sources on its chips.
    n_syn: dict[str, int] = {}
    feeders: dict[str, list[str]] = {}
    if step < rules.split_core_below_ms:
        n_out = {name: 0 for name in pops}
        for proj in network.projections.values():
            n_out[proj.pre] += len(events[proj.name])
        for name, (_, projs) in plan.items():
            n_syn[name], feeders[name] = _synapse_cores(network, spec, [p for p, _ in projs], events, n_out)
    direct = {src for srcs in feeders.values() for src in srcs}

    # Application vertices in sPyNNaker's order: populations, then delay extensions.
    vertices: list[tuple[str, str, int]] = [(n, "sources" if p.is_source else "neurons", max_atoms[n])
                                            for n, p in pops.items() if n not in direct]
    vertices += [(pre, "delays", max_atoms[pre]) for pre in dict.fromkeys(
        p.pre for p in network.projections.values() if p.pre in delay_pre)]
    placer = _Placer(spec)
    cores: list[CoreSlice] = []
    chips_seen: dict[tuple[int, int], int] = {}
    unplaced = 0
    for name, kind, per_core in vertices:
        groups = _core_groups(name, kind, pops[name].size, per_core, spec, matrix.get(name, 0), n_syn.get(name, 0),
                              feeders.get(name, []))
        where = placer.place_vertex([len(g) for g in groups]) if not unplaced else None
        made = [core for group in groups for core in group]
        if where is None:
            unplaced += len(made)
            where = [None] * len(made)
        for core, loc in zip(made, where, strict=True):
            chip = -1 if loc is None else chips_seen.setdefault(loc[:2], len(chips_seen))
            cores.append(CoreSlice(chip=chip, location=loc, **core))
    if unplaced:
        capacity = sum(len(v) for v in _Placer(spec).free.values())
        first = next(c.population for c in cores if c.location is None)
        violations.append(
            Violation(limit="cores", where=network.name, value=len(cores), maximum=capacity,
                      message=(f"Network {network.name!r} needs {len(cores)} cores but {spec.name} offers "
                               f"{capacity} application cores; {first!r} and later populations could not be placed."))
        )
    sdram: dict[tuple[int, int], int] = {}
    for c in cores:
        if c.location is not None:
            sdram[c.location[:2]] = sdram.get(c.location[:2], 0) + c.usage.get("synaptic_matrix_bytes", 0)
    for xy, used in sdram.items():
        if used > rules.sdram_per_chip_bytes:
            violations.append(
                Violation(limit="SDRAM per chip", where=f"chip {xy}", value=used, maximum=rules.sdram_per_chip_bytes,
                          message=(f"Chip {xy}: synaptic matrices of {used} bytes exceed its "
                                   f"{rules.sdram_per_chip_bytes} bytes of SDRAM."))
            )
    notes = (
        "AllToAll/OneToOne with one weight and delay use sPyNNaker's connectors; other projections are lists.",
        "Placement counts cores only; SDRAM is checked per chip for synaptic matrices.",
    )
    if any(n_syn.values()):
        notes += (f"Step {step:g} ms < {rules.split_core_below_ms:g} ms: separate neuron and synapse cores, synapse "
                  f"cores estimated as sPyNNaker does from {rules.spikes_per_second:g} spikes/s per source.",)
    return Partition(hardware=spec.name, cores=tuple(cores), chips=len(chips_seen) + (1 if unplaced else 0),
                     violations=tuple(violations), notes=notes)


def _spynnaker_run(spec: HwSpec) -> tuple[HwSpec, tuple[str, ...]]:
    """The spec at sPyNNaker's whole-microsecond step, for its rules and the delays, with a note if it changed."""
    asked = spec.timing.time_step_ms
    run = spynnaker_timing(spec)
    if run.timing.time_step_ms == asked:
        return run, ()
    return run, (f"sPyNNaker runs whole microseconds: the {asked:g} ms step runs as {run.timing.time_step_ms:g} ms.",)


#: sPyNNaker's and PACMAN's rules, for hwspecs with ``partitioner = "spinnaker"`` (entry point ``neurovpr.architectures``).
SPINNAKER = Architecture(
    name="spinnaker",
    table="spinnaker",
    rules=SpinnakerRules,
    partition=partition_spinnaker,
    runs_at=_spynnaker_run,
)
