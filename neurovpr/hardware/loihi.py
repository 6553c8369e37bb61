"""NengoLoihi's rules for putting a network onto Loihi cores.

The network is translated the way an equivalent NengoLoihi model is built (one
``LoihiBlock`` per population, spike sources injected from the host):

* an ``AllToAllConnector`` becomes a dense weight matrix (``nengo.Dense``, zeros where a
  self-connection is left out);
* a ``ConvolutionConnector`` becomes a ``nengo.Convolution`` with channel-first maps and
  population (``pop32``) axons sharing weights (``nengo_loihi/conv.py``);
* every other connector becomes a ``nengo.transforms.Sparse`` matrix of its connections.

Blocks are then split exactly as ``nengo_loihi/builder/split_blocks.py`` does: the number
of pieces is the largest ratio of compartments, input axons, output axon slots and synapse
bits to their per-core limits, the compartments are cut into equal consecutive slices, and
synapses and axons are rebuilt per slice, sharing identical weight rows. The per-core
counts are then checked against the limits as ``builder/validate.py`` does, and blocks are
given one core each, filling chip after chip like ``hardware/allocators.Greedy``.

All limits and encoding constants come from the hwspec (``[core]``, ``[synapse_encoding]``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from tqdm import tqdm

from neurovpr.backendkit.timing import delay_steps
from neurovpr.ir.connectors import AllToAllConnector, ConvolutionConnector
from neurovpr.ir.network import Network, Projection

from .architectures import Architecture
from .cores import CoreSlice, Partition, Violation, expand_on_chip
from .hwspec import HwSpec, spec_field

__all__ = ["SynapseEncoding", "partition_loihi", "LOIHI"]


@dataclass(frozen=True, slots=True, kw_only=True)
class SynapseEncoding:
    """``[synapse_encoding]``: Loihi synapse memory layout (NengoLoihi's ``SynapseConfig``)."""

    weight_bits: int = spec_field("int", low=1)
    index_bits_map: tuple[int, ...] = spec_field("int_list")
    synapses_per_list: int = spec_field("int", low=1)
    list_header_bits: int = spec_field("int", low=0)
    word_bits: int = spec_field("int", low=1)
    delay_bits: int = spec_field("int", low=0)
    population_axon_slots: int = spec_field("int", low=1)
    max_compartment_base: int = spec_field("int", low=1)


def _ceil_div(a: int, b: int) -> int:
    return -(-a // b)


def bits_per_axon(n_weights: int, bits_per_weight: int, enc: SynapseEncoding) -> int:
    """Synapse memory bits for one axon's list of ``n_weights`` (``SynapseConfig.bits_per_axon``)."""
    per, word = enc.synapses_per_list, enc.word_bits
    full, rem = divmod(int(n_weights), per)
    chunk = _ceil_div(per * bits_per_weight + enc.list_header_bits, word) * word
    bits = full * chunk
    if rem:
        bits += _ceil_div(rem * bits_per_weight + enc.list_header_bits, word) * word
    return bits


def index_bits(max_index: int, enc: SynapseEncoding) -> int | None:
    """Index bits a synapse needs to address ``max_index`` (``None`` if none is large enough)."""
    need = math.ceil(math.log2(max_index + 1)) if max_index >= 0 else 0
    return next((v for v in enc.index_bits_map if v >= need), None)


@dataclass(slots=True)
class _Conv:
    n_pixels: int
    weights: list[np.ndarray]
    indices: list[np.ndarray]
    axon_weight: np.ndarray
    offsets: np.ndarray


@dataclass(slots=True, eq=False)
class _Synapse:
    """One incoming projection of a block, as NengoLoihi holds it before splitting."""

    proj: str
    pre: str
    kind: str
    n_axons: int
    delay_bits: int
    dense: np.ndarray | None = None
    # sparse: connections sorted by (pre, post), float32 weights, CSR row pointer over pre
    pre_idx: np.ndarray | None = None
    post_idx: np.ndarray | None = None
    weights: np.ndarray | None = None
    indptr: np.ndarray | None = None
    conv: _Conv | None = None


@dataclass(slots=True)
class _Block:
    name: str
    size: int
    synapses: list[_Synapse] = field(default_factory=list)
    outgoing: list[tuple[str, _Synapse]] = field(default_factory=list)
    slices: list[tuple[int, int]] = field(default_factory=list)
    # per slice: per incoming synapse: (axon ids or None for "all", n_axons, bits, max index)
    split_syn: list[list[tuple[np.ndarray | None, int, int, int]]] = field(default_factory=list)


def _conv_structure(conn: ConvolutionConnector, kernel: np.ndarray, enc: SynapseEncoding) -> _Conv:
    """Population weights of a convolution (``nengo_loihi/conv.py conv2d_loihi_weights``)."""
    c_in, rows, cols = conn.input_shape
    kh, kw = conn.kernel_shape
    sh, sw = conn.stride
    ph, pw = conn.padding
    n_out, out_rows, out_cols = conn.output_shape
    kern = np.asarray(kernel, dtype=np.float32).transpose(1, 2, 3, 0)[:, ::-1, ::-1, :]
    ri_max, rj_max = (out_rows - 1) * sh + 1, (out_cols - 1) * sw + 1
    offsets = np.zeros(rows * cols, dtype=np.int64)
    axon_weight = np.zeros(rows * cols, dtype=np.int64)
    weights: list[np.ndarray] = []
    indices: list[np.ndarray] = []
    seen: dict[tuple, int] = {}
    base = enc.max_compartment_base
    for i in range(rows):
        ri = i + ph + 1 - kh + np.arange(kh)
        mask_i = (ri >= 0) & (ri < ri_max) & (ri % sh == 0)
        for j in range(cols):
            ij = i * cols + j
            rj = j + pw + 1 - kw + np.arange(kw)
            mask_j = (rj >= 0) & (rj < rj_max) & (rj % sw == 0)
            if not mask_i.any() or not mask_j.any():
                offsets[ij] = -1
                continue
            offset = (ri[mask_i][0] // sh) * out_cols + rj[mask_j][0] // sw
            index_offset = offset - offset % base
            offsets[ij] = offset % base
            key = (tuple(mask_i), tuple(mask_j), index_offset)
            if key not in seen:
                w = kern[:, mask_i[:, None] * mask_j, :].transpose(0, 2, 1)
                mi, mj = int(mask_i.sum()), int(mask_j.sum())
                o, r, c = np.meshgrid(np.arange(n_out), np.arange(mi), np.arange(mj), indexing="ij")
                seen[key] = len(weights)
                weights.append(np.ascontiguousarray(w.reshape(c_in, -1)))
                indices.append((index_offset + o * out_rows * out_cols + r * out_cols + c).ravel())
            axon_weight[ij] = seen[key]
    return _Conv(n_pixels=rows * cols, weights=weights, indices=indices, axon_weight=axon_weight, offsets=offsets)


def _build_synapse(network: Network, proj: Projection, spec: HwSpec, seed: int) -> _Synapse:
    enc = spec.rules
    assert enc is not None
    pre = network.populations[proj.pre]
    post = network.populations[proj.post]
    conn = proj.connector
    if isinstance(conn, ConvolutionConnector):
        delay = proj.synapse.delay
        long = delay is not None and round(float(delay) / spec.timing.time_step_ms) > 1
        return _Synapse(
            proj=proj.name, pre=pre.name, kind="conv", n_axons=conn.input_shape[1] * conn.input_shape[2],
            delay_bits=enc.delay_bits if long else 0, conv=_conv_structure(conn, proj.synapse.weight, enc),
        )
    conns = expand_on_chip(network, proj, spec, seed)
    long = bool(len(conns)) and int(delay_steps(conns.delay, spec.timing.time_step_ms).max()) > 1
    dbits = enc.delay_bits if long else 0
    if isinstance(conn, AllToAllConnector):
        dense = np.zeros((pre.size, post.size), dtype=np.float32)
        dense[conns.pre, conns.post] = conns.weight
        return _Synapse(proj=proj.name, pre=pre.name, kind="dense", n_axons=pre.size, delay_bits=dbits, dense=dense)
    # Sparse: duplicate (pre, post) pairs are summed, as scipy does when building the matrix.
    key = conns.pre * post.size + conns.post
    uniq, inverse = np.unique(key, return_inverse=True)
    weight = np.zeros(uniq.size, dtype=np.float64)
    np.add.at(weight, inverse, conns.weight)
    if not proj.plastic:
        # NengoLoihi's sparse weights drop stored zeros (a static zero weight is no synapse);
        # plastic synapses keep their slot so that they can learn.
        keep = weight != 0.0
        uniq, weight = uniq[keep], weight[keep]
    pre_idx, post_idx = np.divmod(uniq, post.size)
    indptr = np.searchsorted(pre_idx, np.arange(pre.size + 1))
    return _Synapse(proj=proj.name, pre=pre.name, kind="sparse", n_axons=pre.size, delay_bits=dbits,
                    pre_idx=pre_idx, post_idx=post_idx, weights=weight.astype(np.float32), indptr=indptr)


def _bits_for_counts(counts: np.ndarray, bits_per_weight: int, enc: SynapseEncoding) -> int:
    """Total bits of one synapse list per entry of ``counts`` (vectorised over repeated counts)."""
    values, reps = np.unique(np.asarray(counts, dtype=np.int64), return_counts=True)
    return int(sum(int(r) * bits_per_axon(int(v), bits_per_weight, enc) for v, r in zip(values, reps, strict=True)))


def _unsplit_cost(syn: _Synapse, enc: SynapseEncoding) -> tuple[int, int]:
    """(synapse bits, largest compartment index) of a synapse on an unsplit block."""
    wbits = enc.weight_bits + syn.delay_bits
    if syn.kind == "dense":
        n_pre, n_post = syn.dense.shape  # type: ignore[union-attr]
        return n_pre * bits_per_axon(n_post, wbits, enc), n_post - 1
    if syn.kind == "sparse":
        bits = _bits_for_counts(np.diff(syn.indptr), wbits, enc)  # type: ignore[arg-type]
        return bits, int(syn.post_idx.max()) if syn.post_idx.size else -1  # type: ignore[union-attr]
    conv = syn.conv
    assert conv is not None
    top = max(int(ix.max()) for ix in conv.indices)
    ibits = index_bits(top, enc)
    per_weight = wbits + (ibits if ibits is not None else enc.index_bits_map[-1])
    return sum(bits_per_axon(w.size, per_weight, enc) for w in conv.weights), top


def _split_synapse(syn: _Synapse, lo: int, hi: int, enc: SynapseEncoding) -> tuple[np.ndarray | None, int, int, int]:
    """A synapse rebuilt for the compartments ``[lo, hi)`` of a split block.

    Returns (axon ids it keeps or None for all, n_axons, bits, largest index), following
    ``split_blocks.split_synapse`` and ``set_new_synapse_weights``: identical
    (weights, indices) rows are stored once.
    """
    wbits = enc.weight_bits + syn.delay_bits
    if syn.kind == "dense":
        sub = np.ascontiguousarray(syn.dense[:, lo:hi])  # type: ignore[index]
        n_unique = np.unique(sub.view(np.dtype((np.void, sub.dtype.itemsize * sub.shape[1]))).ravel()).size
        return None, sub.shape[0], n_unique * bits_per_axon(hi - lo, wbits, enc), hi - lo - 1
    if syn.kind == "sparse":
        sel = np.flatnonzero((syn.post_idx >= lo) & (syn.post_idx < hi))  # type: ignore[operator]
        pres = syn.pre_idx[sel]  # type: ignore[index]
        kept_rows, starts = np.unique(pres, return_index=True)
        ends = np.append(starts[1:], sel.size) if starts.size else starts
        seen: set[tuple[bytes, bytes]] = set()
        sizes = []
        top = -1
        for a, b in zip(starts, ends, strict=True):
            idx = sel[a:b]
            new_ii = syn.post_idx[idx] - lo  # type: ignore[index]
            key = (syn.weights[idx].tobytes(), new_ii.astype(np.int64).tobytes())  # type: ignore[index]
            if key not in seen:
                seen.add(key)
                sizes.append(b - a)
                top = max(top, int(new_ii.max()))
        return kept_rows.astype(np.int64), int(kept_rows.size), _bits_for_counts(np.asarray(sizes), wbits, enc), top
    conv = syn.conv
    assert conv is not None
    kept = []
    unique: dict[tuple[bytes, bytes], int] = {}
    top = -1
    for ij in range(conv.n_pixels):
        base = conv.offsets[ij]
        if base < 0:
            continue
        widx = conv.axon_weight[ij]
        ids = base + conv.indices[widx]
        sel = (ids >= lo) & (ids < hi)
        if not sel.any():
            continue
        kept.append(ij)
        ww = conv.weights[widx] if sel.all() else conv.weights[widx][:, sel]
        new_ids = ids[sel] - lo
        new_ii = new_ids - new_ids.min() % enc.max_compartment_base
        key = (np.ascontiguousarray(ww).tobytes(), new_ii.astype(np.int64).tobytes())
        if key not in unique:
            unique[key] = ww.size
            top = max(top, int(new_ii.max()))
    ibits = index_bits(top, enc)
    per_weight = wbits + (ibits if ibits is not None else enc.index_bits_map[-1])
    bits = sum(bits_per_axon(size, per_weight, enc) for size in unique.values())
    return np.asarray(kept, dtype=np.int64), len(kept), bits, top


def _pre_axons(syn: _Synapse, lo: int, hi: int) -> np.ndarray:
    """Axon ids of ``syn`` used by the compartments ``[lo, hi)`` of its presynaptic block."""
    if syn.kind == "conv":
        assert syn.conv is not None
        return np.unique(np.arange(lo, hi) % syn.conv.n_pixels)
    return np.arange(lo, hi)


def partition_loihi(network: Network, spec: HwSpec, *, seed: int = 0) -> Partition:
    """Split ``network`` onto Loihi cores with NengoLoihi's rules (see the module docstring)."""
    enc = spec.rules
    assert isinstance(enc, SynapseEncoding), "the loihi partitioner needs [synapse_encoding]"
    core = spec.core
    max_in, max_out, max_bits = core.max_input_axons, core.max_output_axons, core.synapse_memory_bits
    assert max_in is not None and max_out is not None and max_bits is not None
    blocks = {p.name: _Block(p.name, p.size) for p in network.populations.values() if not p.is_source}
    host = tuple(p.name for p in network.populations.values() if p.is_source)
    projections = list(network.projections.values())
    for proj in tqdm(projections, desc=f"synapses for {spec.name}", unit="projection", leave=False,
                     disable=len(projections) < 20):
        syn = _build_synapse(network, proj, spec, seed)
        blocks[proj.post].synapses.append(syn)
        if proj.pre in blocks:
            blocks[proj.pre].outgoing.append((proj.post, syn))
    slots = {"dense": 1, "sparse": 1, "conv": enc.population_axon_slots}

    for block in tqdm(list(blocks.values()), desc=f"splitting blocks for {spec.name}", unit="block", leave=False,
                      disable=len(blocks) < 20):
        costs = [_unsplit_cost(s, enc) for s in block.synapses]
        n_in = sum(s.n_axons for s in block.synapses)
        n_out = sum(slots[s.kind] * s.n_axons for _, s in block.outgoing)
        bits = sum(c[0] for c in costs) + block.size * core.neuron_state_bits
        n_split = max(
            _ceil_div(block.size, core.max_neurons),
            _ceil_div(n_in, max_in),
            _ceil_div(n_out, max_out),
            _ceil_div(bits, max_bits),
            1,
        )
        size = _ceil_div(block.size, n_split)
        block.slices = [(lo, min(lo + size, block.size)) for lo in range(0, block.size, size)]
        if len(block.slices) == 1:
            block.split_syn = [[(None, s.n_axons, c[0], c[1]) for s, c in zip(block.synapses, costs, strict=True)]]
        else:
            block.split_syn = [[_split_synapse(s, lo, hi, enc) for s in block.synapses] for lo, hi in block.slices]

    cores: list[CoreSlice] = []
    violations: list[Violation] = []
    per_chip = spec.chip.app_cores_per_chip
    limits = {"neurons": core.max_neurons, "input_axons": max_in, "output_axons": max_out, "synapse_bits": max_bits}
    for block in blocks.values():
        for k, (lo, hi) in enumerate(block.slices):
            n_out = 0
            for post_name, syn in block.outgoing:
                post = blocks[post_name]
                used = _pre_axons(syn, lo, hi)
                idx = next(i for i, other in enumerate(post.synapses) if other is syn)
                if len(post.slices) == 1:
                    n_out += slots[syn.kind] * used.size
                    continue
                for per_slice in post.split_syn:
                    kept = per_slice[idx][0]
                    n = used.size if kept is None else int(np.isin(used, kept, assume_unique=True).sum())
                    n_out += slots[syn.kind] * n
            parts = block.split_syn[k]
            usage = {
                "neurons": hi - lo,
                "input_axons": sum(p[1] for p in parts),
                "output_axons": n_out,
                "synapse_bits": sum(p[2] for p in parts) + (hi - lo) * core.neuron_state_bits,
            }
            label = block.name if len(block.slices) == 1 else f"{block.name}[{lo}:{hi}]"
            cores.append(
                CoreSlice(population=block.name, lo=lo, hi=hi, kind="neurons", chip=len(cores) // per_chip,
                          usage=usage, limits=dict(limits))
            )
            violations.extend(_validate(label, usage, limits, parts, block.synapses, enc))
    chips = max(1, _ceil_div(len(cores), per_chip)) if cores else 0
    if chips > spec.chip.n_chips:
        violations.append(
            Violation(
                limit="chips", where=network.name, value=chips, maximum=spec.chip.n_chips,
                message=(
                    f"Network {network.name!r} needs {chips} chips ({len(cores)} cores at {per_chip} per chip) "
                    f"but {spec.name} has {spec.chip.n_chips}."
                ),
            )
        )
    notes = (
        "Cores are NengoLoihi blocks: AllToAll -> dense, Convolution -> pop32 conv, other connectors -> sparse.",
        "Spike sources are injected from the host and use no core.",
    )
    return Partition(hardware=spec.name, cores=tuple(cores), chips=chips, violations=tuple(violations),
                     host=host, notes=notes)


_NAMES = {
    "neurons": ("compartments per core", "Number of compartments"),
    "input_axons": ("input axons per core", "Input axons"),
    "output_axons": ("output axons per core", "Output axons"),
    "synapse_bits": ("synapse memory bits per core", "Total synapse bits"),
}


def _validate(label: str, usage: dict[str, int], limits: dict[str, int], parts: list, synapses: list[_Synapse],
              enc: SynapseEncoding) -> list[Violation]:
    """The checks of ``nengo_loihi/builder/validate.py`` for one block."""
    out = []
    for key, (limit, what) in _NAMES.items():
        if usage[key] > limits[key]:
            out.append(
                Violation(limit=limit, where=label, value=usage[key], maximum=limits[key],
                          message=f"Block {label}: {what} ({usage[key]}) exceeded max ({limits[key]}).")
            )
    for (_, _, _, top), syn in zip(parts, synapses, strict=True):
        if index_bits(top, enc) is None:
            out.append(
                Violation(limit="synapse index bits", where=f"{label}:{syn.proj}", value=top + 1,
                          maximum=2 ** enc.index_bits_map[-1],
                          message=(f"Block {label}: projection {syn.proj!r} addresses compartment {top}, beyond "
                                   f"the {enc.index_bits_map[-1]}-bit synapse index."))
            )
    return out


#: NengoLoihi's rules, for hwspecs with ``partitioner = "loihi"`` (entry point ``neurovpr.architectures``).
LOIHI = Architecture(
    name="loihi",
    table="synapse_encoding",
    rules=SynapseEncoding,
    partition=partition_loihi,
    required_core=("max_input_axons", "max_output_axons", "synapse_memory_bits"),
)
