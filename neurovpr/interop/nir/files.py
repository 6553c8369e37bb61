"""Reading and writing NIR files, and the exact restoration from neurovpr's metadata.

An exported file carries the IR network in its graph metadata (the bytes of an
``nv.save`` file). Importing restores that network only when re-exporting it with
the options recorded beside it gives back the file's graph bit for bit; a graph a
peer has changed is imported from its NIR nodes alone.
"""

from __future__ import annotations

import io
import math
import os
import tempfile
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from neurovpr.errors import FileFormatError, NeurovprError, ValidationError
from neurovpr.fileio import atomic_output
from neurovpr.hdf5 import HDF5Rules, open_hdf5
from neurovpr.ir.network import Network

from .export import METADATA_PREFIX, build_graph
from .importer import NIRImport, flatten_graph, graph_to_network
from .mapping import DEFAULT_DT_MS, check_options

__all__ = ["require_nir", "read_graph", "write_graph", "network_to_nir", "nir_to_network", "export_nir", "import_nir", "load_nir"]

_BLOB = f"{METADATA_PREFIX}network"


def require_nir() -> Any:
    """The ``nir`` module, or one clear error when it is not installed."""
    try:
        import nir
    except ImportError:
        raise NeurovprError("NIR support needs the 'nir' package: pip install 'neurovpr[nir]'.") from None
    return nir


def _reason(exc: BaseException) -> str:
    return " ".join(str(exc).split())[:300].rstrip(".") or type(exc).__name__


#: What a NIR file may hold: numbers and strings, gzip as ``nir.write`` compresses, nothing outside the file.
NIR_RULES = HDF5Rules(what="NIR file", filters=("gzip",), strings=True)


def read_graph(path: str | os.PathLike[str]) -> Any:
    """Read a NIR file into a ``nir.NIRGraph`` (one :class:`FileFormatError` sentence on any problem).

    The file is checked whole by the safe HDF5 reader (:mod:`neurovpr.hdf5`: no links,
    external storage or virtual datasets, only gzip compression, declared sizes within
    the file and the memory limit) before ``nir.read`` reads any data.
    """
    nir = require_nir()
    import h5py

    target = os.fspath(path)
    with open_hdf5(target, NIR_RULES) as f:
        if not isinstance(f.get("node"), h5py.Group):
            raise FileFormatError(f"NIR file {target!r} has no /node group, so it is not a NIR graph.")
        _check_node_types(f["node"], target, nir)
    try:
        graph = nir.read(target, type_check=False)
    except Exception as exc:  # nir.read parses untrusted data; any failure of it means a damaged graph
        raise FileFormatError(f"NIR file {target!r} is damaged or not a NIR graph ({_describe(exc)}).") from None
    if type(graph).__name__ != "NIRGraph":
        raise FileFormatError(f"NIR file {target!r} holds a single {type(graph).__name__} node, not a graph.")
    return graph


def _text_dataset(group: Any, key: str) -> str | None:
    import h5py

    item = group.get(key)
    if not isinstance(item, h5py.Dataset) or item.shape not in ((), (1,)):
        return None
    value = item[()]
    value = value.reshape(-1)[0] if isinstance(value, np.ndarray) else value
    return value.decode("utf-8", "replace") if isinstance(value, bytes) else str(value)


_WINDOW_NODES = ("Conv1d", "Conv2d", "SumPool2d", "AvgPool2d")


def _check_node_types(group: Any, path: str, nir: Any, where: str = "graph", depth: int = 0) -> None:
    """Refuse a node whose ``type`` NIR does not define, naming the node and the type, before ``nir.read``."""
    import h5py

    known = {name for name, cls in vars(nir).items() if isinstance(cls, type) and issubclass(cls, nir.NIRNode)}
    kind = _text_dataset(group, "type")
    if kind is not None and kind not in known:
        raise FileFormatError(
            f"NIR file {path!r}: {where} has the type {kind[:80]!r}, which NIR does not define "
            f"(known: {', '.join(sorted(known - {'NIRNode'}))})."
        )
    for field in ("stride", "dilation", "kernel_size"):
        item = group.get(field)
        if kind in _WINDOW_NODES and isinstance(item, h5py.Dataset) and item.dtype.kind in "biuf" and item.size <= 8:
            values = np.asarray(item[()]).reshape(-1)
            if values.size and (not np.all(np.isfinite(values)) or np.any(values < 1)):
                raise FileFormatError(
                    f"NIR file {path!r}: {where} ({kind}) has {field} {values.tolist()}; every {field} must be >= 1."
                )
    nodes = group.get("nodes")
    if kind == "NIRGraph" and isinstance(nodes, h5py.Group) and depth < 64:
        for name in nodes:
            if isinstance(nodes[name], h5py.Group):
                _check_node_types(nodes[name], path, nir, f"node {name[:80]!r}", depth + 1)


def _describe(exc: BaseException) -> str:
    """What went wrong inside ``nir.read``, in words (an unknown node type has no message of its own)."""
    if isinstance(exc, (AssertionError, KeyError)) and not str(exc).strip("'\""):
        return "a node of a type NIR does not know, or a node without its fields"
    return f"{type(exc).__name__}: {_reason(exc)}"


def write_graph(graph: Any, path: str | os.PathLike[str]) -> None:
    """Write ``graph`` atomically: ``path`` ends up holding the whole file or its old content."""
    nir = require_nir()
    target = Path(path)
    if not target.parent.is_dir():
        raise ValidationError(f"Cannot write {str(target)!r}: the folder {str(target.parent)!r} does not exist.")
    with atomic_output(target, make_parents=False) as tmp:
        nir.write(tmp, graph)


def _canonical(graph: Any) -> dict[str, Any]:
    """The graph as it reads back from a file, without its top-level metadata."""
    nir = require_nir()
    buf = io.BytesIO()
    nir.write(buf, graph)
    buf.seek(0)
    data = nir.read(buf, type_check=False).to_dict()
    data.pop("metadata", None)
    return data


def _same(a: Any, b: Any) -> bool:
    if isinstance(a, dict) or isinstance(b, dict):
        return isinstance(a, dict) and isinstance(b, dict) and a.keys() == b.keys() and all(_same(a[k], b[k]) for k in a)
    if isinstance(a, (list, tuple)) and isinstance(b, (list, tuple)) and not a and not b:
        return True
    if isinstance(a, bytes):
        a = a.decode("utf-8", "replace")
    if isinstance(b, bytes):
        b = b.decode("utf-8", "replace")
    if isinstance(a, str) or isinstance(b, str):
        return a == b
    try:
        x, y = np.asarray(a), np.asarray(b)
    except (TypeError, ValueError):
        return a == b
    if x.dtype.kind in "SUO" or y.dtype.kind in "SUO":
        return x.shape == y.shape and [_text(v) for v in x.reshape(-1)] == [_text(v) for v in y.reshape(-1)]
    return x.shape == y.shape and np.array_equal(x, y, equal_nan=True)


def _text(v: Any) -> str:
    return v.decode("utf-8", "replace") if isinstance(v, bytes) else str(v)


def _is_number(v: Any) -> bool:
    return isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, (bool, np.bool_))


#: The metadata neurovpr's export writes, with what each value must be (checked on import).
_META_RULES: dict[str, tuple[str, Any]] = {
    "dt_ms": ("a positive number of ms", lambda v: _is_number(v) and math.isfinite(v) and v > 0),
    "integration": ("'exact' or 'euler'", lambda v: v in ("exact", "euler")),
    "seed": ("an integer >= 0", lambda v: _is_number(v) and float(v).is_integer() and 0 <= v < 2**63),
    "allow_refractory": ("0 or 1", lambda v: _is_number(v) and v in (0, 1)),
    "outputs": ("text (population names separated by commas)", lambda v: isinstance(v, str)),
    "network_name": ("text", lambda v: isinstance(v, str)),
}


def _meta(graph: Any) -> dict[str, Any]:
    """The graph's metadata, neurovpr's own entries checked (one sentence naming a wrong one)."""
    meta = getattr(graph, "metadata", None)
    if not isinstance(meta, dict):
        return {}
    out = {}
    for k, v in meta.items():
        if isinstance(v, np.ndarray) and v.shape == () and v.dtype.kind != "u":
            v = v.item()
        out[str(k)] = v.decode("utf-8", "replace") if isinstance(v, bytes) else v
    for key, (expected, ok) in _META_RULES.items():
        name = f"{METADATA_PREFIX}{key}"
        if name in out and not ok(out[name]):
            shown = f"an array of shape {out[name].shape}" if isinstance(out[name], np.ndarray) else repr(out[name])[:80]
            raise ValidationError(f"NIR graph metadata {name!r} is {shown}, expected {expected}.")
    return out


def network_to_nir(
    network: Network,
    *,
    dt: float = DEFAULT_DT_MS,
    integration: str = "exact",
    seed: int = 0,
    allow_refractory: bool = False,
    outputs: Sequence[str] | None = None,
    embed_network: bool = True,
) -> Any:
    """Convert a network to a ``nir.NIRGraph`` (see :mod:`neurovpr.interop.nir.mapping`).

    Parameters
    ----------
    network
        The network; populations must be spike sources or ``IF_curr_exp``.
    dt
        The NIR step ``h`` in ms: the area of one spike impulse and, with
        ``integration="euler"``, the peer's time step (default 0.1 ms, snnTorch's).
    integration
        ``"exact"`` (NIR's continuous-time equations) or ``"euler"`` (forward-Euler
        coefficients at step ``dt``, as snnTorch simulates).
    seed
        Seed for random connectors and weight distributions without their own.
    allow_refractory
        Keep ``tau_refrac > 0`` in neurovpr metadata only instead of refusing it.
    outputs
        Populations to mark with NIR ``Output`` nodes (default: those with no
        outgoing projection).
    embed_network
        Carry the IR network in the graph metadata for an exact restoration.
    """
    graph, _ = _export(network, dt, integration, seed, allow_refractory, outputs, embed_network)
    return graph


def _export(
    network: Network, dt: float, integration: str, seed: int, allow_refractory: bool,
    outputs: Sequence[str] | None, embed: bool,
) -> tuple[Any, tuple[str, ...]]:  # fmt: skip
    """The graph (with the embedded network when ``embed``) and the export notes."""
    require_nir()
    graph, notes = build_graph(network, dt=dt, integration=integration, seed=seed,
                               allow_refractory=allow_refractory, outputs=outputs)  # fmt: skip
    if embed:
        from neurovpr.ir.serialization import save

        with tempfile.TemporaryDirectory(prefix="neurovpr-nir-") as tmp:
            path = Path(tmp) / "embedded.h5"
            save(network, path)
            graph.metadata[_BLOB] = np.frombuffer(path.read_bytes(), dtype=np.uint8).copy()
    return graph, notes


def export_nir(
    network: Network,
    path: str | os.PathLike[str],
    *,
    dt: float = DEFAULT_DT_MS,
    integration: str = "exact",
    seed: int = 0,
    allow_refractory: bool = False,
    outputs: Sequence[str] | None = None,
    embed_network: bool = True,
) -> tuple[str, ...]:
    """Write ``network`` as a NIR file; returns notes on what peers will not see.

    Parameters are those of :func:`network_to_nir`.
    """
    graph, notes = _export(network, dt, integration, seed, allow_refractory, outputs, embed_network)
    write_graph(graph, path)
    return notes


def _restore(graph: Any, meta: dict[str, Any], dt: float, integration: str, notes: list[str]) -> Network | None:
    """The embedded network when the graph still is exactly its export, else ``None``."""
    from neurovpr.ir.serialization import load

    blob = meta.get(_BLOB)
    if not isinstance(blob, np.ndarray) or blob.dtype != np.uint8 or blob.ndim != 1:
        notes.append("The graph's neurovpr metadata is not a network file; it was imported from its NIR nodes.")
        return None
    with tempfile.TemporaryDirectory(prefix="neurovpr-nir-") as tmp:
        path = Path(tmp) / "embedded.h5"
        path.write_bytes(blob.tobytes())
        try:
            network = load(path)
        except FileFormatError:
            notes.append("The graph's embedded neurovpr network is damaged; it was imported from its NIR nodes.")
            return None
    outputs = meta.get(f"{METADATA_PREFIX}outputs")
    try:
        again, _ = build_graph(
            network, dt=dt, integration=integration, seed=int(meta.get(f"{METADATA_PREFIX}seed", 0)),
            allow_refractory=bool(int(meta.get(f"{METADATA_PREFIX}allow_refractory", 0))),
            outputs=[o for o in str(outputs).split(",") if o] if outputs is not None else None,
        )  # fmt: skip
    except NeurovprError:
        again = None
    if again is None or not _same(_canonical(again), _canonical(graph)):
        notes.append(
            "The graph differs from the network embedded at export (a peer changed it); it was imported from its NIR nodes."
        )
        return None
    return network


def nir_to_network(
    graph: Any,
    *,
    dt: float | None = None,
    integration: str | None = None,
    name: str | None = None,
    use_metadata: bool = True,
) -> NIRImport:
    """Convert a ``nir.NIRGraph`` to a network.

    Parameters
    ----------
    graph
        The NIR graph.
    dt, integration
        How to read the graph (see :func:`network_to_nir`); by default what
        neurovpr recorded at export, else 0.1 ms and ``"exact"``.
    name
        Name of the network (default: the exported network's name, else ``"nir"``).
    use_metadata
        Restore the network embedded by neurovpr's export when the graph still
        matches it exactly.
    """
    require_nir()
    if type(graph).__name__ != "NIRGraph":
        raise ValidationError(f"NIR import needs a nir.NIRGraph, got {type(graph).__name__}.")
    meta = _meta(graph)
    stored_dt = meta.get(f"{METADATA_PREFIX}dt_ms")
    stored_int = meta.get(f"{METADATA_PREFIX}integration")
    use_dt = float(dt if dt is not None else stored_dt if isinstance(stored_dt, (int, float)) else DEFAULT_DT_MS)
    use_int = str(integration if integration is not None else stored_int if stored_int in ("exact", "euler") else "exact")
    use_dt, use_int = check_options(use_dt, use_int)
    notes: list[str] = []
    if use_metadata and _BLOB in meta:
        if (stored_dt, stored_int) != (use_dt, use_int):
            notes.append(
                f"The graph was exported for dt={stored_dt} ms, {stored_int}; "
                f"read as dt={use_dt} ms, {use_int} from its NIR nodes."
            )
        elif (network := _restore(graph, meta, use_dt, use_int, notes)) is not None:
            if name is not None and name != network.name:
                network = network.copy(name)
            _, roles, edges = flatten_graph(graph)
            ins = {k: k for k, r in roles.items() if r == "input"}
            outs = {b: a for a, b in edges if roles.get(b) == "output"}
            done = ("Restored exactly from neurovpr's metadata.",)
            return NIRImport(network=network, inputs=ins, outputs=outs, notes=done, restored=True)
    net_name = name if name is not None else str(meta.get(f"{METADATA_PREFIX}network_name", "nir"))
    try:
        Network(net_name)
    except ValidationError:
        net_name = "nir"
    result = graph_to_network(graph, name=net_name, dt=use_dt, integration=use_int)
    return NIRImport(
        network=result.network, inputs=result.inputs, outputs=result.outputs, notes=tuple(notes) + result.notes, restored=False
    )


def import_nir(
    source: str | os.PathLike[str] | Any,
    *,
    dt: float | None = None,
    integration: str | None = None,
    name: str | None = None,
    use_metadata: bool = True,
) -> NIRImport:
    """Read a NIR file (or take a ``nir.NIRGraph``) and convert it; see :func:`nir_to_network`."""
    graph = read_graph(source) if isinstance(source, (str, os.PathLike)) else source
    try:
        return nir_to_network(graph, dt=dt, integration=integration, name=name, use_metadata=use_metadata)
    except ValidationError as exc:
        where = f"NIR file {os.fspath(source)!r}: " if isinstance(source, (str, os.PathLike)) else ""
        raise ValidationError(f"{where}{exc}") from None


def load_nir(path: str | os.PathLike[str]) -> Network:
    """The network of a NIR file, read with the defaults (for ``neurovpr check`` and ``energy``)."""
    return import_nir(path).network
