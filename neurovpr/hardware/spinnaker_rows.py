"""How sPyNNaker sizes synaptic rows, for :mod:`.spinnaker`'s partition.

Delays in whole steps as sPyNNaker rounds them; which projections are sPyNNaker's own
connectors and which become explicit lists (and two lists for signed currents); the
longest row of each onto a post core (``get_max_row_info``,
``FromListConnector.get_n_connections_from_pre_vertex_maximum``); and the words a row
takes. The rules' sources are named in each function and in :mod:`.spinnaker`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from neurovpr.ir.connectors import AllToAllConnector, OneToOneConnector
from neurovpr.ir.network import Network, Projection

from .cores import expand_on_chip
from .hwspec import HwSpec, spec_field

__all__ = [
    "SpinnakerRules",
    "RowLengths",
    "delay_steps",
    "align_block",
    "native_connector",
    "rounded_delay_ms",
    "signed_parts",
    "longest_delay",
    "row_lengths",
    "numpy_group",
    "list_row_max",
    "row_words",
]


@dataclass(frozen=True, slots=True, kw_only=True)
class SpinnakerRules:
    """``[spinnaker]``: sPyNNaker's slicing and synaptic-matrix constants, board geometry, and
    the rules for separate neuron and synapse cores at time steps below ``split_core_below_ms``."""

    poisson_sources_per_core: int = spec_field("int", low=1)
    array_sources_per_core: int = spec_field("int", low=0)
    max_row_words: int = spec_field("int", low=1)
    row_header_words: int = spec_field("int", low=0)
    bytes_per_word: int = spec_field("int", low=1)
    matrix_base_bytes: int = spec_field("int", low=0)
    block_alignment_bytes: int = spec_field("int", low=1)
    plastic_header_bytes: int = spec_field("int", low=0)
    plastic_half_words_per_synapse: int = spec_field("int", low=1)
    fixed_half_words_per_synapse: int = spec_field("int", low=1)
    ring_buffer_bits: int = spec_field("int", low=1)
    delay_extension_stages: int = spec_field("int", low=0)
    synapse_types: int = spec_field("int", low=1)
    chip_rows: tuple[tuple[int, ...], ...] = spec_field("int_rows")
    reduced_core_chips: tuple[tuple[int, ...], ...] = spec_field("int_rows")
    system_cores_per_chip: int = spec_field("int", low=0)
    ethernet_chip_extra_cores: int = spec_field("int", low=0)
    sdram_per_chip_bytes: int = spec_field("int", low=1)
    split_core_below_ms: float = spec_field("float", low=0.0)
    spikes_per_second: float = spec_field("float", low=0.0)
    static_synapses_per_second: int = spec_field("int", low=1)
    stdp_synapses_per_second: int = spec_field("int", low=1)
    scamp_cores_per_chip: int = spec_field("int", low=0)
    time_scale_step_us: int = spec_field("int", low=1)


def delay_steps(delay_ms: np.ndarray | float, step_ms: float) -> np.ndarray:
    """Delays in whole steps of at least one, rounded as sPyNNaker rounds them.

    ``numpy.rint(delay * get_simulation_time_step_per_ms())`` with steps per ms
    ``1000.0 / step_us`` (fec_data_writer.py; the rounding of FromListConnector,
    AbstractSynapseDynamics.round_delay and synapse_io.py).
    """
    per_ms = 1000.0 / round(step_ms * 1000.0)
    return np.maximum(1, np.rint(np.asarray(delay_ms, dtype=np.float64) * per_ms)).astype(np.int64)


def align_block(address: int, rules: SpinnakerRules) -> int:
    scale = rules.block_alignment_bytes
    return -(-address // scale) * scale


@dataclass(slots=True)
class RowLengths:
    """Longest undelayed and delayed rows (in synapses) of one projection onto one post core."""

    undelayed: int
    delayed: int


def native_connector(proj: Projection) -> bool:
    """Whether sPyNNaker's own connector is used: one weight and one delay for every synapse.

    sPyNNaker's AllToAll/OneToOne connectors refuse per-synapse weight arrays, and random
    weights would be drawn by its own generator, so anything else is an explicit list.
    sPyNNaker's all-to-all leaves ``i -> i`` out only from a population onto itself, so
    an all-to-all without self-connections between two populations is a list too.
    """
    conn = proj.connector
    delay = proj.synapse.delay
    if isinstance(conn, AllToAllConnector) and not conn.allow_self_connections and proj.pre != proj.post:
        return False
    return (
        isinstance(conn, (AllToAllConnector, OneToOneConnector))
        and isinstance(proj.synapse.weight, float)
        and (delay is None or isinstance(delay, float))
    )


def rounded_delay_ms(delay_ms: float, step: float) -> float:
    """A delay rounded to whole steps of at least one (sPyNNaker's ``_round_delay``)."""
    return float(delay_steps(delay_ms, step)) * step


def signed_parts(network: Network, proj: Projection, weight: np.ndarray, spec: HwSpec) -> list[np.ndarray]:
    """Masks of the sPyNNaker projections one listed projection becomes.

    With unsigned synaptic weights, a projection onto the excitatory receptor of a
    current-based population whose weights have both signs is two projections: the
    non-negative weights, and the negative ones onto the inhibitory receptor.
    """
    every = np.ones(weight.size, dtype=bool)
    signed = spec.formats.weight_signed
    current = not network.populations[proj.post].cell_type.conductance_based
    if signed or proj.receptor_type != "excitatory" or not current or not weight.size:
        return [every]
    if weight.min() >= 0 or weight.max() < 0:
        return [every]
    return [weight >= 0, weight < 0]


def longest_delay(network: Network, proj: Projection, spec: HwSpec, seed: int) -> float:
    """The longest delay of ``proj`` in ms, in whole steps (``None`` delays are one step)."""
    from neurovpr.ir.connectors import FromListConnector

    step = spec.timing.time_step_ms
    delay = proj.synapse.delay
    listed = isinstance(proj.connector, FromListConnector) and proj.connector.conn_list.shape[1] == 4
    if not listed and (delay is None or isinstance(delay, float)):
        return step if delay is None else rounded_delay_ms(delay, step)
    conns = expand_on_chip(network, proj, spec, seed)
    return float(delay_steps(conns.delay, step).max()) * step if len(conns) else step


def row_lengths(network: Network, proj: Projection, spec: HwSpec, seed: int, n_post_atoms: int,
                 max_supported_ms: float, extended: bool) -> tuple[list[RowLengths], list[int]]:
    """Longest rows onto a post core of ``n_post_atoms`` (``get_max_row_info``) of each
    sPyNNaker projection ``proj`` becomes (two for a list of signed currents), and the
    longest row of each onto a core of the per-core maximum over all delays (the estimate
    ``n_synapse_cores_required`` uses; none for an empty list, which sPyNNaker never gets).

    Synapses with delays up to ``max_supported_ms`` go to the undelayed matrix. When the
    edge from ``proj.pre`` has a delay extension (``extended``), those from
    ``max_supported_ms`` on are counted for the delay-extension matrix: sPyNNaker starts
    that range at ``max_supported_ms`` plus the smallest double, which rounds back to
    ``max_supported_ms``, so a delay of exactly that many steps counts in both. Explicit
    lists are counted per (source, post core) as
    ``FromListConnector.get_n_connections_from_pre_vertex_maximum`` does.
    """
    step = spec.timing.time_step_ms
    per_core = spec.core.max_neurons
    if native_connector(proj):
        delay = rounded_delay_ms(proj.synapse.delay, step) if proj.synapse.delay is not None else step
        all_to_all = isinstance(proj.connector, AllToAllConnector)
        n = n_post_atoms if all_to_all else 1
        rows = RowLengths(undelayed=n if delay <= max_supported_ms else 0,
                     delayed=n if extended and delay >= max_supported_ms else 0)
        return [rows], [per_core if all_to_all else 1]
    conns = expand_on_chip(network, proj, spec, seed)
    delay = delay_steps(conns.delay, step) * step
    out, events = [], []
    for part in signed_parts(network, proj, conns.weight, spec):
        rows = []
        for mask in (part & (delay <= max_supported_ms), part & (delay >= max_supported_ms) & extended):
            rows.append(list_row_max(conns.pre[mask], conns.post[mask] // n_post_atoms) if mask.any() else 0)
        out.append(RowLengths(undelayed=rows[0], delayed=rows[1]))
        if part.any():
            events.append(list_row_max(conns.pre[part], conns.post[part] // per_core))
    return out, events


def numpy_group(values: np.ndarray, order_by: np.ndarray) -> list[np.ndarray]:
    """Index chunks as ``FromListConnector.__numpy_group`` makes them.

    sPyNNaker 7.4.1 computes the split points on the list sorted by the column but
    splits the list in its original order, so an unsorted list is cut into chunks of
    the group sizes rather than into groups. Reproduced as is: it decides the row length
    sPyNNaker reserves.
    """
    split_points = np.unique(np.sort(order_by), return_index=True)[1][1:]
    return np.array_split(values, split_points)


def list_row_max(pre: np.ndarray, core: np.ndarray) -> int:
    """Longest row of an explicit list per (source, post core), as sPyNNaker estimates it
    (``FromListConnector.get_n_connections_from_pre_vertex_maximum``)."""
    idx = np.arange(pre.size)
    best = 0
    for chunk in numpy_group(idx, pre):
        for sub in numpy_group(chunk, core[chunk]):
            best = max(best, sub.size)
    return best


def row_words(n_synapses: int, plastic: bool, rules: SpinnakerRules) -> int:
    """Words of a row of ``n_synapses`` (static: one word each; STDP: half-words and a header)."""
    if n_synapses == 0:
        return 0
    if not plastic:
        return n_synapses
    fixed = -(-n_synapses * rules.fixed_half_words_per_synapse // 2)
    plastic_bytes = rules.plastic_header_bytes + 2 * rules.plastic_half_words_per_synapse * n_synapses
    return fixed + -(-plastic_bytes // rules.bytes_per_word)
