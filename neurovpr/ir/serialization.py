"""Save and load networks as one versioned HDF5 file.

File layout (format ``"neurovpr-network"``, version :data:`FORMAT_VERSION`)::

    /                   attributes: format, format_version, name, graph, content_sha256
    /arrays/0, 1, ...   one plain numeric dataset per array in the graph

``graph`` is a JSON string ``{"populations": [...], "projections": [...]}``. Every IR
node is written as ``{"type": <class name>, "fields": {<field>: <value>}}``, derived
from its dataclass fields, so a new IR type needs no change here: adding it to one
of the type tables (:data:`~neurovpr.ir.cells.CELL_TYPES`,
:data:`~neurovpr.ir.synapses.SYNAPSE_TYPES`, :data:`~neurovpr.ir.connectors.CONNECTORS`,
:data:`~neurovpr.ir.distributions.DISTRIBUTIONS`) makes it saveable and loadable.
Values are JSON numbers, strings, booleans, ``null`` and lists (tuples), plus two
tagged objects: ``{"$array": "/arrays/<n>"}`` for a numpy array stored as a dataset
with its exact dtype and shape, and ``{"$float": "inf" | "-inf" | "nan"}`` for the
floats JSON cannot spell. ``content_sha256`` covers the name, the graph and every
array, so a damaged file is detected rather than loaded with altered values.

Loading never unpickles and never runs code from the file: only the registered IR
classes can be built, through their normal constructors (so every validation runs
again). The file is opened by the safe HDF5 reader (:mod:`neurovpr.hdf5`): nothing
outside the file is read (no external storage, links or virtual datasets), datasets
must be plain numeric arrays without filters whose declared sizes fit the file and
the memory limit, and any problem becomes one
:class:`~neurovpr.errors.FileFormatError` sentence naming the file.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
import os
import re
from collections.abc import Mapping
from types import MappingProxyType
from typing import Any

import h5py
import numpy as np

from neurovpr.errors import FileFormatError, NeurovprError, ValidationError
from neurovpr.fileio import OutputError, atomic_output
from neurovpr.hdf5 import HDF5Rules, open_hdf5, read_dataset
from neurovpr.ir.cells import CELL_TYPES
from neurovpr.ir.connectors import CONNECTORS
from neurovpr.ir.distributions import DISTRIBUTIONS
from neurovpr.ir.network import Network, Population, Projection
from neurovpr.ir.node import IRNode
from neurovpr.ir.synapses import SYNAPSE_TYPES
from neurovpr.resources import require_nodes
from neurovpr.runtime.simulation import Simulation

__all__ = ["save", "load", "FORMAT_NAME", "FORMAT_VERSION", "NODE_TYPES"]

#: Value of the root ``format`` attribute.
FORMAT_NAME = "neurovpr-network"
#: The format version this code writes and reads.
FORMAT_VERSION = 1

_LIBVER = ("v110", "latest")  # checksummed metadata and large attributes
_ARRAY_KINDS = frozenset("biuf")
_ARRAY_REF = re.compile(r"^/arrays/(0|[1-9][0-9]*)$")
_NONFINITE = {"inf": math.inf, "-inf": -math.inf, "nan": math.nan}
_MAX_DEPTH = 64
# What a network file may hold: plain numeric datasets, text attributes, no filters, nothing outside the file.
_RULES = HDF5Rules(what="Network file", filters=(), strings=True)
# Exceptions an IR constructor may raise on values read from a file.
_CONSTRUCT_ERRORS = (NeurovprError, TypeError, ValueError, AttributeError, IndexError, KeyError, OverflowError)
# Exceptions h5py and the OS raise on unreadable or damaged files.
_READ_ERRORS = (OSError, RuntimeError, KeyError, ValueError, TypeError, OverflowError, MemoryError)


def _node_types() -> Mapping[str, type[IRNode]]:
    table: dict[str, type[IRNode]] = {}
    for group in (CELL_TYPES, SYNAPSE_TYPES, CONNECTORS, DISTRIBUTIONS, {"Population": Population, "Projection": Projection}):
        for name, cls in group.items():
            if table.setdefault(name, cls) is not cls:
                raise RuntimeError(f"Two IR types share the name {name!r}; a saved file could not tell them apart.")
    return MappingProxyType(table)


#: Every IR class a file may name, by its ``type`` string (read-only).
NODE_TYPES: Mapping[str, type[IRNode]] = _node_types()


# -- paths and errors ----------------------------------------------------------------
def _as_path(path: Any, func: str) -> str:
    if not isinstance(path, (str, os.PathLike)):
        raise ValidationError(f"nv.{func}: path must be a str or os.PathLike, got {type(path).__name__}.")
    target = os.fspath(path)
    if not isinstance(target, str):
        target = os.fsdecode(target)
    if not target:
        raise ValidationError(f"nv.{func}: path must not be empty.")
    return target


def _error(path: str, what: str) -> FileFormatError:
    return FileFormatError(f"Network file {path!r} {what}.")


def _reason(exc: BaseException) -> str:
    raw = exc.args[0] if len(exc.args) == 1 and isinstance(exc.args[0], str) else str(exc)
    text = " ".join(raw.split()) or type(exc).__name__
    return text[:300].rstrip(".")


# -- encoding -------------------------------------------------------------------------
def _encode(value: Any, where: str, arrays: list[np.ndarray]) -> Any:
    """Turn one field value into JSON data, moving arrays into ``arrays``."""
    if isinstance(value, IRNode):
        name = type(value).__name__
        if NODE_TYPES.get(name) is not type(value):
            raise ValidationError(
                f"nv.save: {where} is a {name}, which is not a registered IR type "
                "(add it to CELL_TYPES, SYNAPSE_TYPES, CONNECTORS or DISTRIBUTIONS)."
            )
        fields = {
            f.name: _encode(getattr(value, f.name), f"{where}.{f.name}", arrays)
            for f in dataclasses.fields(value)  # type: ignore[arg-type]
            if f.init
        }
        return {"type": name, "fields": fields}
    if isinstance(value, np.ndarray):
        dt = value.dtype
        if dt.kind not in _ARRAY_KINDS or dt.itemsize > 8 or dt.metadata:
            raise ValidationError(f"nv.save: {where} is an array of dtype {dt}, which a network file cannot store.")
        arrays.append(value)
        return {"$array": f"/arrays/{len(arrays) - 1}"}
    if value is None or isinstance(value, (bool, str)):
        return value
    if isinstance(value, np.bool_):
        return bool(value)
    if isinstance(value, (int, np.integer)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        number = float(value)
        if math.isfinite(number):
            return number
        return {"$float": "nan" if math.isnan(number) else ("inf" if number > 0 else "-inf")}
    if isinstance(value, (tuple, list)):
        return [_encode(item, f"{where}[{i}]", arrays) for i, item in enumerate(value)]
    raise ValidationError(f"nv.save: {where} holds a {type(value).__name__}, which a network file cannot store.")


def _encode_network(network: Network) -> tuple[str, list[np.ndarray]]:
    arrays: list[np.ndarray] = []
    graph = {
        "populations": [_encode(p, f"population {n!r}", arrays) for n, p in network.populations.items()],
        "projections": [_encode(p, f"projection {n!r}", arrays) for n, p in network.projections.items()],
    }
    text = json.dumps(graph, allow_nan=False, separators=(",", ":"))
    return text, arrays


def _digest(name: str, graph: str, arrays: list[np.ndarray]) -> str:
    """SHA-256 of everything a file holds, each part length-prefixed."""
    h = hashlib.sha256()

    def put(part: bytes | str) -> None:
        data = part.encode("utf-8") if isinstance(part, str) else part
        h.update(len(data).to_bytes(8, "little"))
        h.update(data)

    put(FORMAT_NAME)
    put(str(FORMAT_VERSION))
    put(name)
    put(graph)
    for i, arr in enumerate(arrays):
        put(str(i))
        put(arr.dtype.str)
        put(repr(tuple(arr.shape)))
        put(np.ascontiguousarray(arr).tobytes())
    return h.hexdigest()


def _write_file(path: str, name: str, graph: str, arrays: list[np.ndarray]) -> None:
    """Write one network file at ``path`` (no atomicity: :func:`save` provides it)."""
    with h5py.File(path, "w", libver=_LIBVER) as f:
        f.attrs["format"] = FORMAT_NAME
        f.attrs["format_version"] = np.int64(FORMAT_VERSION)
        f.attrs["name"] = name
        f.attrs["graph"] = graph
        f.attrs["content_sha256"] = _digest(name, graph, arrays)
        group = f.create_group("arrays")
        for i, arr in enumerate(arrays):
            group.create_dataset(str(i), data=np.ascontiguousarray(arr), track_times=False)


def save(obj: Network | Simulation, path: str | os.PathLike) -> None:
    """Save a network, or a simulation's current network, to one HDF5 file.

    The file is written next to ``path`` under a temporary name and then renamed
    over ``path``, so ``path`` holds either its previous content or the complete
    new file, never a partial one.

    Parameters
    ----------
    obj
        A :class:`~neurovpr.ir.network.Network`, or a
        :class:`~neurovpr.runtime.simulation.Simulation` whose
        :meth:`~neurovpr.runtime.simulation.Simulation.to_network` (learned weights and
        thresholds included) is saved.
    path
        Destination file (conventionally ``*.h5``).

    Raises
    ------
    ValidationError
        ``obj`` is neither, or holds a value the format cannot store.
    FileFormatError
        The file cannot be written (missing folder, no permission, disk full).
    """
    target = _as_path(path, "save")
    network = obj.to_network() if isinstance(obj, Simulation) else obj
    if not isinstance(network, Network):
        raise ValidationError(f"nv.save: expected a Network or a Simulation, got {type(obj).__name__}.")
    graph, arrays = _encode_network(network)
    folder = os.path.dirname(os.path.abspath(target))
    if not os.path.isdir(folder):
        raise _error(target, f"cannot be written: the folder {folder!r} does not exist")
    try:
        with atomic_output(target, make_parents=False) as tmp:
            _write_file(os.fspath(tmp), network.name, graph, arrays)
    except OutputError as exc:
        raise _error(target, f"cannot be written ({exc.reason})") from None


# -- reading --------------------------------------------------------------------------
def _attr_text(path: str, attrs: Any, key: str) -> str:
    if key not in attrs:
        raise _error(path, f"lacks the {key!r} attribute of a neurovpr network file")
    value = attrs[key]
    if isinstance(value, (bytes, np.bytes_)):
        value = bytes(value).decode("utf-8")
    if not isinstance(value, str):
        raise _error(path, f"has a {key!r} attribute that is not text")
    return value


def _read_dataset(path: str, group: h5py.Group, key: str) -> np.ndarray:
    ds = group[key]
    if not isinstance(ds, h5py.Dataset) or ds.dtype.kind not in _ARRAY_KINDS:
        raise _error(path, f"has an entry /arrays/{key} that is not a plain numeric dataset")
    return read_dataset(ds, path, _RULES)


def _read_contents(path: str, f: h5py.File) -> tuple[str, str, list[np.ndarray]]:
    attrs = f.attrs
    if "format" not in attrs:
        raise _error(path, "is an HDF5 file but not a neurovpr network file (it has no 'format' attribute)")
    fmt = _attr_text(path, attrs, "format")
    if fmt != FORMAT_NAME:
        raise _error(path, f"is not a neurovpr network file (its format is {fmt[:80]!r}, expected {FORMAT_NAME!r})")
    version = attrs.get("format_version")
    if isinstance(version, (bool, np.bool_)) or not isinstance(version, (int, np.integer)):
        raise _error(path, "has no integer 'format_version' attribute")
    if int(version) != FORMAT_VERSION:
        raise _error(path, f"was written by format version {int(version)}; this neurovpr reads version {FORMAT_VERSION}")
    name = _attr_text(path, attrs, "name")
    graph = _attr_text(path, attrs, "graph")
    digest = _attr_text(path, attrs, "content_sha256")
    group = f.get("arrays")
    if not isinstance(group, h5py.Group):
        raise _error(path, "lacks its /arrays group")
    keys = list(group.keys())
    if sorted(keys) != sorted(str(i) for i in range(len(keys))):
        raise _error(path, "has /arrays entries that are not numbered 0, 1, 2, ...")
    arrays = [_read_dataset(path, group, str(i)) for i in range(len(keys))]
    if _digest(name, graph, arrays) != digest:
        raise _error(path, "is corrupted: its content does not match the checksum stored in it")
    return name, graph, arrays


def _read_file(path: str) -> tuple[str, str, list[np.ndarray]]:
    """Read a file's name, graph text and arrays, or raise one FileFormatError."""
    with open_hdf5(path, _RULES) as f:
        try:
            return _read_contents(path, f)
        except FileFormatError:
            raise
        except _READ_ERRORS as exc:
            reason = _reason(exc)
            kind = "is truncated" if "truncated" in reason.lower() else "is corrupted or unreadable"
            raise _error(path, f"{kind} ({reason})") from None


# -- decoding -------------------------------------------------------------------------
class _Decoder:
    """Builds IR nodes from the graph JSON of one file."""

    def __init__(self, path: str, arrays: list[np.ndarray]) -> None:
        self.path = path
        self.arrays = arrays

    def fail(self, where: str, what: str) -> FileFormatError:
        return FileFormatError(f"Network file {self.path!r}: {where} {what}.")

    def value(self, data: Any, where: str, depth: int = 0) -> Any:
        if depth > _MAX_DEPTH:
            raise self.fail(where, f"is nested more than {_MAX_DEPTH} levels deep")
        if data is None or isinstance(data, (bool, int, float, str)):
            return data
        if isinstance(data, list):
            return tuple(self.value(item, f"{where}[{i}]", depth + 1) for i, item in enumerate(data))
        if not isinstance(data, dict):
            raise self.fail(where, f"has a value of unsupported kind {type(data).__name__}")
        keys = set(data)
        if keys == {"$array"}:
            ref = data["$array"]
            match = _ARRAY_REF.match(ref) if isinstance(ref, str) else None
            if match is None or int(match.group(1)) >= len(self.arrays):
                raise self.fail(where, f"refers to a missing array {ref!r}")
            return self.arrays[int(match.group(1))]
        if keys == {"$float"}:
            if data["$float"] not in _NONFINITE:
                raise self.fail(where, f"has an invalid $float value {data['$float']!r} (inf, -inf or nan)")
            return _NONFINITE[data["$float"]]
        if keys == {"type", "fields"}:
            return self.node(data, where, depth)
        raise self.fail(where, f"is an object with unexpected keys {sorted(keys)}")

    def node(self, data: dict[str, Any], where: str, depth: int = 0) -> IRNode:
        type_name, fields = data.get("type"), data.get("fields")
        if not isinstance(type_name, str) or not isinstance(fields, dict):
            raise self.fail(where, "needs a 'type' string and a 'fields' object")
        cls = NODE_TYPES.get(type_name)
        if cls is None:
            raise self.fail(where, f"has unknown type {type_name[:80]!r}")
        declared = {f.name: f for f in dataclasses.fields(cls) if f.init}  # type: ignore[arg-type]
        unknown = sorted(set(fields) - set(declared))
        if unknown:
            raise self.fail(where, f"({type_name}) has unknown field(s) {', '.join(map(repr, unknown))}")
        missing = [
            n
            for n, f in declared.items()
            if n not in fields and f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING
        ]
        if missing:
            raise self.fail(where, f"({type_name}) lacks the field(s) {', '.join(map(repr, missing))}")
        kwargs = {k: self.value(v, f"{where}.{k}", depth + 1) for k, v in fields.items()}
        try:
            return cls(**kwargs)
        except _CONSTRUCT_ERRORS as exc:
            raise self.fail(where, f"({type_name}) is invalid: {_reason(exc)}") from None

    def network(self, name: str, graph: Any) -> Network:
        if not isinstance(graph, dict) or set(graph) != {"populations", "projections"}:
            raise FileFormatError(
                f"Network file {self.path!r} has a graph that is not an object with 'populations' and 'projections'."
            )
        try:
            net = Network(name)
        except ValidationError as exc:
            raise FileFormatError(f"Network file {self.path!r} has an invalid network name: {_reason(exc)}.") from None
        for key, cls in (("populations", Population), ("projections", Projection)):
            items = graph[key]
            if not isinstance(items, list):
                raise self.fail(f"graph[{key!r}]", "is not a list")
            for i, data in enumerate(items):
                label = data["fields"].get("name") if isinstance(data, dict) and isinstance(data.get("fields"), dict) else None
                where = f"{key}[{i}]" + (f" ({label[:128]!r})" if isinstance(label, str) else "")
                if not isinstance(data, dict) or data.get("type") != cls.__name__:
                    raise self.fail(where, f"is not a {cls.__name__}")
                item = self.node(data, where)
                try:
                    net.add(item)  # type: ignore[arg-type]
                except ValidationError as exc:
                    raise self.fail(where, f"cannot be added: {_reason(exc)}") from None
        return net


def load(path: str | os.PathLike) -> Network:
    """Load a network saved by :func:`save`.

    Parameters
    ----------
    path
        The file to read.

    Returns
    -------
    Network
        A network equal (``==``) to the one saved, arrays bit for bit.

    Raises
    ------
    FileFormatError
        The file is missing, not HDF5, truncated, corrupted, of another format or
        version, or describes an invalid graph; the message names the file and
        what is wrong.
    """
    target = _as_path(path, "load")
    name, graph_text, arrays = _read_file(target)

    def reject_constant(token: str) -> Any:
        raise ValueError(f"non-standard JSON constant {token}")

    try:
        graph = json.loads(graph_text, parse_constant=reject_constant)
    except (ValueError, RecursionError) as exc:
        raise _error(target, f"has a graph that is not valid JSON ({_reason(exc)})") from None
    if isinstance(graph, dict) and all(isinstance(graph.get(k), list) for k in ("populations", "projections")):
        require_nodes(len(graph["populations"]), len(graph["projections"]), f"Network file {target!r}")
    return _Decoder(target, arrays).network(name, graph)
