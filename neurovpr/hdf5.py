"""The one safe HDF5 reader: every HDF5 file neurovpr reads is opened and checked here.

An HDF5 file can point outside itself: a dataset may keep its bytes in another file
(*external storage*), in other datasets (*virtual datasets*), or be reached through
an *external* or *soft link*; a dataset may declare a shape far larger than the file
(a forged or truncated file) or be compressed so that a few kilobytes expand to
gigabytes. :func:`open_hdf5` walks the whole file before anything is read and refuses,
with one :class:`~neurovpr.errors.FileFormatError` sentence naming the file and the
object:

- any link that is not a hard link, and any object reachable by more than one link;
- external storage and virtual datasets;
- filters (compression) other than those the writer of that kind of file uses;
- dtypes other than plain numbers (and, where the format has them, strings);
- a dataset whose declared size exceeds the file (unfiltered data must be in the
  file), whose declared size exceeds what its compressed bytes can hold (deflate
  expands at most about 1032:1), or whose declared size, alone or summed over the
  file, exceeds the memory limit (:mod:`neurovpr.resources`);
- attributes of other dtypes or past the memory limit, and more than
  :data:`MAX_OBJECTS` objects.

Every loader of the project (network files, NIR graphs, run files, event files,
MATLAB v7.3 files) opens its files through this module.
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass

import h5py
import numpy as np

from neurovpr.errors import FileFormatError, NeurovprError
from neurovpr.resources import ResourceLimitError, format_bytes, memory_limit

__all__ = ["FILTERS", "MAX_OBJECTS", "HDF5Rules", "open_hdf5", "read_dataset", "check_hdf5"]

#: Filter ids by name (the HDF5 library's numbers).
FILTERS = {"gzip": 1, "shuffle": 2, "fletcher32": 3, "szip": 4, "lzf": 32000}
#: Most objects (groups, datasets, attributes) one file may hold.
MAX_OBJECTS = 1_000_000
#: Largest expansion a deflate stream can produce (with room for chunk overheads).
_MAX_RATIO = 1100


@dataclass(frozen=True, slots=True)
class HDF5Rules:
    """What one kind of file may contain.

    Attributes
    ----------
    what
        How errors name the file, e.g. ``"Network file"``.
    filters
        Names of the allowed filters (keys of :data:`FILTERS`); none by default.
    strings
        Whether string datasets and attributes are allowed.
    """

    what: str = "HDF5 file"
    filters: tuple[str, ...] = ()
    strings: bool = True


def _fail(path: str, rules: HDF5Rules, message: str) -> FileFormatError:
    return FileFormatError(f"{rules.what} {path!r} {message}.")


def _dtype_ok(dt: np.dtype, rules: HDF5Rules) -> bool:
    if dt.kind in "biuf" and dt.itemsize <= 8 and dt.fields is None and dt.subdtype is None:
        return True
    if rules.strings:
        if h5py.check_string_dtype(dt) is not None:
            return True
        if dt.kind == "S" and dt.fields is None:
            return True
    return False


class _Walker:
    def __init__(self, path: str, rules: HDF5Rules, file_size: int) -> None:
        self.path, self.rules, self.file_size = path, rules, file_size
        self.allowed = {FILTERS[name] for name in rules.filters}
        self.objects = 0
        self.total = 0.0
        self.limit, self.source = memory_limit()

    def fail(self, message: str) -> FileFormatError:
        return _fail(self.path, self.rules, message)

    def count(self) -> None:
        self.objects += 1
        if self.objects > MAX_OBJECTS:
            raise self.fail(f"holds more than {MAX_OBJECTS} objects")

    def need(self, nbytes: float, where: str) -> None:
        self.total += nbytes
        for amount, label in ((nbytes, where), (self.total, "its data in total")):
            if not amount <= self.limit:
                raise ResourceLimitError(
                    f"{self.rules.what} {self.path!r}: {label} would need about {format_bytes(amount)} of memory; "
                    f"the limit is {format_bytes(self.limit)} ({self.source})."
                )

    def attrs(self, obj: h5py.HLObject, where: str) -> None:
        for name in obj.attrs:
            self.count()
            aid = obj.attrs.get_id(name)
            dt = aid.dtype
            if not _dtype_ok(dt, self.rules):
                raise self.fail(f"has an attribute {name!r} of {where} of dtype {dt}, which this format never writes")
            shape = aid.shape or ()
            self.need(float(np.prod(shape, dtype=np.float64)) * max(dt.itemsize, 8), f"attribute {name!r} of {where}")

    def dataset(self, ds: h5py.Dataset, where: str) -> None:
        dcpl = ds.id.get_create_plist()
        if dcpl.get_layout() == h5py.h5d.VIRTUAL:
            raise self.fail(f"has a virtual dataset {where}, which reads other datasets or files; refused")
        if dcpl.get_external_count():
            raise self.fail(f"has a dataset {where} with external storage (its bytes lie in another file); refused")
        filters = [dcpl.get_filter(i)[0] for i in range(dcpl.get_nfilters())]
        unknown = [f for f in filters if f not in self.allowed]
        if unknown:
            names = {v: k for k, v in FILTERS.items()}
            shown = ", ".join(names.get(f, f"#{f}") for f in unknown)
            allowed = ", ".join(self.rules.filters) or "none"
            raise self.fail(f"has a dataset {where} with the filter(s) {shown}; this kind of file uses {allowed}")
        dt = ds.dtype
        if not _dtype_ok(dt, self.rules):
            raise self.fail(f"has a dataset {where} of dtype {dt}, which this format never writes")
        shape = ds.shape if ds.shape is not None else ()
        items = float(np.prod(shape, dtype=np.float64))
        declared = items * dt.itemsize
        if dt.kind == "O":
            declared = items * 16  # a variable-length string's handle; its bytes are bounded by the file
        if not filters:
            if dt.kind != "O" and declared > self.file_size:
                raise self.fail(
                    f"is truncated or forged: dataset {where} declares {format_bytes(declared)}, more than the whole "
                    f"file ({format_bytes(self.file_size)})"
                )
        else:
            stored = ds.id.get_storage_size()
            if declared > max(stored, 1) * _MAX_RATIO:
                raise self.fail(
                    f"is forged: compressed dataset {where} declares {format_bytes(declared)} from "
                    f"{format_bytes(stored)} of stored data, more than compression can expand to"
                )
        self.need(declared, f"dataset {where} ({'x'.join(map(str, shape)) or 'scalar'} of {dt})")

    def group(self, group: h5py.Group, where: str) -> None:
        self.attrs(group, where)
        for name in group:
            self.count()
            child = f"{where.rstrip('/')}/{name}"
            link = group.get(name, getlink=True)
            if isinstance(link, h5py.ExternalLink):
                raise self.fail(f"has an external link {child} to {link.filename!r}; refused")
            if not isinstance(link, h5py.HardLink):
                raise self.fail(f"has a {type(link).__name__} at {child}; only plain (hard-linked) objects are allowed")
            obj = group[name]
            if h5py.h5o.get_info(obj.id).rc != 1:
                raise self.fail(f"reaches the object {child} by more than one link; refused")
            if isinstance(obj, h5py.Dataset):
                self.attrs(obj, child)
                self.dataset(obj, child)
            elif isinstance(obj, h5py.Group):
                self.group(obj, child)
            else:
                raise self.fail(f"has a {type(obj).__name__} at {child}, which this format never writes")


def check_hdf5(f: h5py.File, path: str, rules: HDF5Rules, file_size: int) -> None:
    """Walk an open file and refuse anything :mod:`this module <neurovpr.hdf5>` forbids."""
    _Walker(path, rules, file_size).group(f, "/")


_READ_ERRORS = (OSError, RuntimeError, KeyError, ValueError, TypeError, OverflowError, MemoryError)


@contextmanager
def open_hdf5(path: str | os.PathLike[str], rules: HDF5Rules) -> Iterator[h5py.File]:
    """Open an HDF5 file for reading after checking all of it (see the module docstring).

    Raises
    ------
    FileFormatError
        When the file is missing, empty, not HDF5, damaged, or holds anything the
        rules forbid; the sentence names the file and the object. h5py and OS errors
        raised inside the ``with`` block (a dataset that cannot be decoded) become
        such a sentence too.
    """
    target = os.fspath(path)
    if not os.path.exists(target):
        raise _fail(target, rules, "does not exist")
    if os.path.isdir(target):
        raise _fail(target, rules, "is a folder, not a file")
    try:
        size = os.path.getsize(target)
        if size == 0:
            raise _fail(target, rules, "is empty")
        if not h5py.is_hdf5(target):
            raise _fail(target, rules, "is not an HDF5 file")
        f = h5py.File(target, "r", locking=False)
    except FileFormatError:
        raise
    except _READ_ERRORS as exc:
        raise _fail(target, rules, f"is truncated or unreadable ({_reason(exc)})") from None
    with f:
        try:
            check_hdf5(f, target, rules, size)
        except (FileFormatError, ResourceLimitError):
            raise
        except _READ_ERRORS as exc:
            raise _fail(target, rules, f"is corrupted or unreadable ({_reason(exc)})") from None
        try:
            yield f
        except NeurovprError:
            raise
        except _READ_ERRORS as exc:  # a dataset that passed the checks but cannot be decoded
            raise _fail(target, rules, f"is corrupted or unreadable ({_reason(exc)})") from None


def read_dataset(ds: h5py.Dataset, path: str, rules: HDF5Rules) -> np.ndarray:
    """Read a checked dataset into a read-only array (one sentence naming the file on a damaged dataset)."""
    try:
        arr = np.array(ds[()], copy=True)
    except _READ_ERRORS as exc:
        raise _fail(path, rules, f"has a damaged dataset {ds.name} ({_reason(exc)})") from None
    arr.setflags(write=False)
    return arr


def _reason(exc: BaseException) -> str:
    raw = exc.args[0] if len(exc.args) == 1 and isinstance(exc.args[0], str) else str(exc)
    return (" ".join(raw.split()) or type(exc).__name__)[:300].rstrip(".")
