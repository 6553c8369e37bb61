"""Read and write event files: AEDAT 4.0/2.0, npy, npz, HDF5 and CSV arrays of x, y, t, p.

The format follows the file's suffix (``.aedat4``, ``.aedat``, ``.npy``, ``.npz``,
``.h5``/``.hdf5``/``.hdf``, ``.csv``). Every record is checked; a bad file is refused
with one sentence naming the file and its first bad record (0-based).

Array layouts read:

* ``.npy``: a structured array with fields ``x``, ``y``, ``t``, ``p`` (``ts``/``timestamp``
  and ``polarity``/``pol``/``on`` are accepted), or an ``(N, 4)`` array with those columns.
  It cannot hold the sensor size, so ``sensor_size`` must be passed.
* ``.npz``: arrays ``x``, ``y``, ``t``, ``p`` and optionally ``width``, ``height``.
* HDF5: datasets ``x``, ``y``, ``t``, ``p`` at the root or in a group ``events``; the
  sensor size in attributes ``width`` and ``height`` of that group, when present.
* ``.csv``: a header row naming the columns (or none: then ``x,y,t,p``), ``#`` comment
  lines, and optionally the comment ``# sensor_size: WIDTHxHEIGHT``.

Files never reach ``eval`` or unpickling: numpy files are loaded with
``allow_pickle=False``.
"""

from __future__ import annotations

import os
import re
import zipfile
import zlib
from collections.abc import Mapping
from pathlib import Path
from typing import Any, Literal

import h5py
import numpy as np

from neurovpr.data.events.aedat import aedat_version, read_aedat2, read_aedat4
from neurovpr.data.events.stream import EventStream, first_bad_record, normalise_polarity
from neurovpr.errors import FileFormatError, ValidationError
from neurovpr.fileio import atomic_output
from neurovpr.hdf5 import HDF5Rules, open_hdf5, read_dataset
from neurovpr.resources import require_memory

__all__ = ["read_events", "write_events", "EVENT_FORMATS"]

#: File suffix -> format name.
EVENT_FORMATS: dict[str, str] = {
    ".aedat4": "aedat4",
    ".aedat": "aedat",
    ".npy": "npy",
    ".npz": "npz",
    ".h5": "hdf5",
    ".hdf5": "hdf5",
    ".hdf": "hdf5",
    ".csv": "csv",
}
_WRITABLE = ("npy", "npz", "hdf5", "csv")
_ALIASES = {"x": ("x",), "y": ("y",), "t": ("t", "ts", "timestamp"), "p": ("p", "polarity", "pol", "on")}
_TIME_UNITS = {"ns": 1e-3, "us": 1.0, "ms": 1e3, "s": 1e6}
#: What an event HDF5 file may hold: numbers, gzip/shuffle compression, nothing outside the file.
_HDF5_RULES = HDF5Rules(what="events file", filters=("gzip", "shuffle"), strings=True)
# What zipfile, zlib and numpy raise on a damaged archive.
_ZIP_ERRORS = (zipfile.BadZipFile, OSError, EOFError, NotImplementedError, RuntimeError, ValueError, zlib.error)
_SENSOR_RE = re.compile(r"#\s*sensor_size\s*[:=]\s*(\d+)\s*[x, ]\s*(\d+)", re.IGNORECASE)


def read_events(
    path: str | os.PathLike[str],
    *,
    sensor_size: tuple[int, int] | None = None,
    time_unit: Literal["ns", "us", "ms", "s"] = "us",
    reader: Literal["auto", "aedat", "dv-processing"] = "auto",
    flip_y: bool = False,
) -> EventStream:
    """Read an event file into an :class:`EventStream`.

    Parameters
    ----------
    path
        The file; its suffix selects the format (see the module documentation).
    sensor_size
        ``(width, height)`` for formats that do not carry it (npy, AEDAT 2.0, CSV without
        the comment); when the file carries it too, both must agree.
    time_unit
        Unit of the timestamps in array files (AEDAT files are always us); times are
        rounded to integer microseconds.
    reader
        AEDAT 4.0 decoder: ``"aedat"``, ``"dv-processing"`` or ``"auto"``.
    flip_y
        AEDAT 2.0 only: count rows from the top (jAER counts them from the bottom).

    Raises
    ------
    FileFormatError
        Unknown suffix, unsupported AEDAT version, missing columns, unparsable content.
    ValidationError
        A record with out-of-range coordinates, an unsorted, negative or fractional
        timestamp or a polarity other than 0/1 (the first such record is named), or
        a file with no events.
    """
    path = Path(path)
    if not path.is_file():
        raise ValidationError(f"events file {str(path)!r} does not exist.")
    fmt = EVENT_FORMATS.get(path.suffix.lower())
    if fmt is None:
        raise FileFormatError(
            f"events file {str(path)!r} has an unknown format (suffix {path.suffix or 'none'!r}); "
            f"known suffixes: {', '.join(EVENT_FORMATS)}."
        )
    if time_unit not in _TIME_UNITS:
        raise ValidationError(f"read_events: time_unit {time_unit!r} is not one of {tuple(_TIME_UNITS)}.")
    if fmt in ("aedat", "aedat4"):
        version = aedat_version(path)
        if version is None and fmt == "aedat":
            raise FileFormatError(f"events file {str(path)!r} does not start with an '#!AER-DAT' header.")
        if version is not None and version.startswith("2"):
            x, y, t, p, width, height = read_aedat2(path, sensor_size, flip_y=flip_y)
            sensor_size = None
        elif version is None or version.startswith("4"):
            x, y, t, p, width, height = read_aedat4(path, reader)
        else:
            raise FileFormatError(
                f"events file {str(path)!r} is AEDAT {version}, which is not read (AEDAT 2.0 and 4.0 are)."
            )
        return _build(path, x, y, t, p, (width, height), sensor_size)
    loader = {"npy": _load_npy, "npz": _load_npz, "hdf5": _load_hdf5, "csv": _load_csv}[fmt]
    columns, file_size = loader(path)
    size = _sensor_size(path, file_size, sensor_size)
    t = columns["t"]
    if time_unit != "us":
        t = np.rint(np.asarray(t, dtype=np.float64) * _TIME_UNITS[time_unit])
    return _build(path, columns["x"], columns["y"], t, columns["p"], size, None)


def _sensor_size(
    path: Path, from_file: tuple[int, int] | None, given: tuple[int, int] | None
) -> tuple[int, int]:
    if from_file is None and given is None:
        raise ValidationError(
            f"events file {str(path)!r} does not state its sensor size; pass sensor_size=(width, height)."
        )
    if from_file is not None and given is not None and tuple(int(v) for v in given) != from_file:
        raise ValidationError(
            f"events file {str(path)!r} states sensor size {from_file[0]}x{from_file[1]}, "
            f"but sensor_size={tuple(given)} was given."
        )
    return from_file if from_file is not None else (int(given[0]), int(given[1]))  # type: ignore[index]


def _build(
    path: Path,
    x: Any,
    y: Any,
    t: Any,
    p: Any,
    size: tuple[int, int],
    given: tuple[int, int] | None,
) -> EventStream:
    width, height = _sensor_size(path, size, given)
    x, y, t, p = (np.ravel(np.asarray(a)) for a in (x, y, t, p))
    if t.size == 0:
        raise ValidationError(f"events file {str(path)!r} holds no events; an empty stream cannot be used.")
    for name, arr in (("x", x), ("y", y), ("t", t), ("p", p)):
        if not (np.issubdtype(arr.dtype, np.number) or arr.dtype == np.bool_) or np.iscomplexobj(arr):
            raise FileFormatError(f"events file {str(path)!r}: column {name!r} is not numeric (dtype {arr.dtype}).")
    p = normalise_polarity(p)
    problem = first_bad_record(x, y, t, p, width, height)
    if problem is not None:
        raise ValidationError(f"events file {str(path)!r}: {problem}.")
    return EventStream(width=width, height=height, x=x, y=y, t=t, p=p)


def _pick(path: Path, available: Mapping[str, Any] | tuple[str, ...], where: str) -> dict[str, str]:
    names = {name.lower(): name for name in available}
    picked = {}
    for column, aliases in _ALIASES.items():
        match = next((names[a] for a in aliases if a in names), None)
        if match is None:
            raise FileFormatError(
                f"events file {str(path)!r} has no {column!r} column in {where} "
                f"(accepted names: {', '.join(aliases)}; found: {', '.join(sorted(names)) or 'none'})."
            )
        picked[column] = match
    return picked


def _npy_bytes(path: Path, fh: Any, available: int, where: str) -> float:
    """Declared size of the ``.npy`` array at ``fh``, refused when past ``available`` bytes or the memory limit."""
    try:
        version = np.lib.format.read_magic(fh)
        read_header = np.lib.format.read_array_header_1_0 if version == (1, 0) else np.lib.format.read_array_header_2_0
        shape, _, dtype = read_header(fh)
    except (ValueError, TypeError, OSError, SyntaxError) as exc:
        raise FileFormatError(f"events file {str(path)!r}: {where} is not a plain numpy array ({exc}).") from None
    declared = float(np.prod(shape, dtype=np.float64)) * dtype.itemsize
    if declared > available:
        raise FileFormatError(
            f"events file {str(path)!r} is truncated or forged: {where} declares shape {shape} "
            f"({declared:.3g} bytes) in {available} bytes."
        )
    return declared


def _check_npy_sizes(path: Path) -> None:
    """Check the declared shapes of a ``.npy``/``.npz`` file against its bytes and the memory limit, reading no data."""
    if path.suffix.lower() == ".npy":
        with open(path, "rb") as fh:
            total = _npy_bytes(path, fh, path.stat().st_size, "the array")
    else:
        try:
            with zipfile.ZipFile(path) as archive:
                total = 0.0
                for info in archive.infolist():
                    if info.filename.endswith(".npy"):
                        with archive.open(info) as fh:
                            total += _npy_bytes(path, fh, info.file_size, f"member {info.filename!r}")
        except FileFormatError:
            raise
        except _ZIP_ERRORS as exc:
            raise FileFormatError(f"events file {str(path)!r} is not a readable npz archive ({exc}).") from None
    require_memory(total, f"reading events file {str(path)!r}")


def _load_npy(path: Path) -> tuple[dict[str, np.ndarray], None]:
    _check_npy_sizes(path)
    try:
        arr = np.load(path, allow_pickle=False)
    except ValueError as exc:
        raise FileFormatError(f"events file {str(path)!r} is not a plain numpy array: {exc}.") from exc
    if arr.dtype.names:
        picked = _pick(path, arr.dtype.names, "its structured array")
        return {col: arr[name] for col, name in picked.items()}, None
    if arr.ndim == 2 and arr.shape[1] == 4:
        return {col: arr[:, i] for i, col in enumerate(("x", "y", "t", "p"))}, None
    raise FileFormatError(
        f"events file {str(path)!r} holds an array of shape {arr.shape}; expected a structured array "
        "with fields x, y, t, p or an (N, 4) array with those columns."
    )


def _scalar_size(path: Path, source: Mapping[str, Any]) -> tuple[int, int] | None:
    keys = {k.lower(): k for k in source}
    if "width" in keys and "height" in keys:
        w, h = (np.asarray(source[keys[k]][()]) for k in ("width", "height"))
        if w.size != 1 or h.size != 1:
            raise FileFormatError(f"events file {str(path)!r}: 'width' and 'height' must be single numbers.")
        return int(w.item()), int(h.item())
    return None


def _load_npz(path: Path) -> tuple[dict[str, np.ndarray], tuple[int, int] | None]:
    _check_npy_sizes(path)
    try:
        with np.load(path, allow_pickle=False) as archive:
            data = {name: archive[name] for name in archive.files}
    except _ZIP_ERRORS as exc:
        raise FileFormatError(f"events file {str(path)!r} is not a plain npz archive: {exc}.") from exc
    picked = _pick(path, tuple(data), "the archive")
    return {col: data[name] for col, name in picked.items()}, _scalar_size(path, data)


def _load_hdf5(path: Path) -> tuple[dict[str, np.ndarray], tuple[int, int] | None]:
    with open_hdf5(path, _HDF5_RULES) as fh:
        group: h5py.Group = fh
        if "x" not in fh and isinstance(fh.get("events"), h5py.Group):
            group = fh["events"]
        datasets = tuple(k for k in group if isinstance(group[k], h5py.Dataset))
        picked = _pick(path, datasets, f"HDF5 group {group.name!r}")
        columns = {col: read_dataset(group[name], str(path), _HDF5_RULES) for col, name in picked.items()}
        size = _scalar_size(path, dict(group.attrs))
    return columns, size


def _load_csv(path: Path) -> tuple[dict[str, np.ndarray], tuple[int, int] | None]:
    try:
        text = path.read_text(encoding="utf-8")
    except UnicodeDecodeError as exc:
        raise FileFormatError(f"events file {str(path)!r} is not a UTF-8 text CSV file.") from exc
    size = None
    rows = []
    for line in text.splitlines():
        stripped = line.strip()
        if stripped.startswith("#"):
            match = _SENSOR_RE.match(stripped)
            if match:
                size = (int(match.group(1)), int(match.group(2)))
        elif stripped:
            rows.append(stripped)
    header = ["x", "y", "t", "p"]
    if rows and not _is_numeric_row(rows[0]):
        header = [name.strip().strip('"').lower() for name in rows[0].split(",")]
        rows = rows[1:]
    picked = _pick(path, tuple(header), "its header row")
    if not rows:
        return {col: np.zeros(0) for col in picked}, size
    try:
        table = np.loadtxt(rows, delimiter=",", dtype=np.float64, ndmin=2)
    except ValueError as exc:
        raise FileFormatError(f"events file {str(path)!r} is not a numeric CSV table: {exc}") from exc
    if table.shape[1] != len(header):
        raise FileFormatError(
            f"events file {str(path)!r} has {table.shape[1]} columns per row but its header names {len(header)}."
        )
    return {col: table[:, header.index(name)] for col, name in picked.items()}, size


def _is_numeric_row(row: str) -> bool:
    try:
        [float(tok) for tok in row.split(",")]
    except ValueError:
        return False
    return True


def write_events(stream: EventStream, path: str | os.PathLike[str]) -> Path:
    """Write ``stream`` to ``path`` (npy, npz, HDF5 or CSV, by suffix), atomically.

    npz, HDF5 and CSV keep the sensor size; npy cannot (pass ``sensor_size`` when
    reading it back). Returns the path written.
    """
    path = Path(path)
    fmt = EVENT_FORMATS.get(path.suffix.lower())
    if fmt not in _WRITABLE:
        raise FileFormatError(
            f"events file {str(path)!r}: writing suffix {path.suffix or 'none'!r} is not supported "
            f"(write .npy, .npz, .h5/.hdf5 or .csv)."
        )
    with atomic_output(path) as tmp:
        if fmt == "npy":
            table = np.empty(len(stream), dtype=[("x", "<i4"), ("y", "<i4"), ("t", "<i8"), ("p", "i1")])
            for name in ("x", "y", "t", "p"):
                table[name] = getattr(stream, name)
            with open(tmp, "wb") as fh:
                np.save(fh, table, allow_pickle=False)
        elif fmt == "npz":
            with open(tmp, "wb") as fh:
                np.savez_compressed(
                    fh, x=stream.x, y=stream.y, t=stream.t, p=stream.p,
                    width=np.int64(stream.width), height=np.int64(stream.height),
                )
        elif fmt == "hdf5":
            with h5py.File(tmp, "w") as fh:
                group = fh.create_group("events")
                group.attrs["width"], group.attrs["height"] = stream.sensor_size
                group.attrs["time_unit"] = "us"
                for name in ("x", "y", "t", "p"):
                    group.create_dataset(name, data=getattr(stream, name), compression="gzip")
        else:
            table = np.column_stack([stream.x, stream.y, stream.t, stream.p]).astype(np.int64)
            with open(tmp, "w", encoding="utf-8") as fh:
                fh.write(f"# sensor_size: {stream.width}x{stream.height}\nx,y,t,p\n")
                np.savetxt(fh, table, fmt="%d", delimiter=",")
    return path

