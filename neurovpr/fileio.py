"""Writing results: one atomic writer and one output-path check, used by every command.

A result file is either complete or absent, never half-written. Every writer goes
through :func:`atomic_output`: the content is written to a temporary file in the
target's own folder (``.NAME.PID.TOKEN.tmp``), flushed and ``fsync``-ed, then renamed
over the target (``os.replace`` is atomic within one file system). A run killed
mid-write leaves only such a temporary file; it is removed by the next write of the
same file and by :func:`remove_stale_temps` (``neurovpr train`` calls it on its run
directory, so ``--resume`` and later runs clear what a killed run left). A temporary
file is stale when the process named in it no longer runs, so a writer that is still
working is never disturbed.

:func:`check_output` is the check every command applies to its output paths before
any work: the path must not be an existing entry of the wrong kind (a file where a
folder is written, or the reverse), its nearest existing ancestor must be a folder
this process can create files in, and it must not be one of the command's inputs.
"""

from __future__ import annotations

import io
import os
import re
import secrets
import tempfile
from collections.abc import Iterable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any, Literal

from neurovpr.errors import ValidationError

__all__ = [
    "OutputError",
    "atomic_output",
    "atomic_write_bytes",
    "atomic_write_text",
    "save_figure",
    "remove_stale_temps",
    "is_temp_name",
    "check_output",
]


class OutputError(ValidationError):
    """A result file cannot be written; ``reason`` says why (``"[Errno 28] No space left on device"``)."""

    def __init__(self, path: Path, reason: str) -> None:
        super().__init__(f"Cannot write {str(path)!r} ({reason}).")
        self.path, self.reason = path, reason


_TEMP = re.compile(r"^\.(?P<name>.+)\.(?P<pid>[0-9]+)\.[0-9a-f]{12}\.tmp$")


def _temp_path(target: Path) -> Path:
    return target.parent / f".{target.name}.{os.getpid()}.{secrets.token_hex(6)}.tmp"


def is_temp_name(name: str) -> bool:
    """True when ``name`` is the name of a temporary file of :func:`atomic_output`."""
    return _TEMP.match(name) is not None


def _process_alive(pid: int) -> bool:
    if pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OverflowError):
        return True
    return True


def remove_stale_temps(folder: str | os.PathLike[str], *, recursive: bool = True, target: str | None = None) -> list[Path]:
    """Remove the temporary files that killed writers left in ``folder``; returns what was removed.

    Only files named like :func:`atomic_output`'s temporaries whose writing process
    no longer runs are removed (``target``: only those of that file name).
    """
    root = Path(folder)
    if not root.is_dir():
        return []
    removed = []
    entries: Iterable[Path] = root.rglob(".*.tmp") if recursive else root.glob(".*.tmp")
    for entry in entries:
        match = _TEMP.match(entry.name)
        if match is None or (target is not None and match["name"] != target):
            continue
        if entry.is_file() and not entry.is_symlink() and not _process_alive(int(match["pid"])):
            try:
                entry.unlink()
                removed.append(entry)
            except OSError:
                pass
    return removed


@contextmanager
def atomic_output(path: str | os.PathLike[str], *, make_parents: bool = True) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; on success it is fsync-ed and renamed over ``path``.

    Anything raised inside the block (including ``KeyboardInterrupt``) removes the
    temporary file and leaves ``path`` as it was. Writers that need a file name
    (``h5py``, ``nir.write``) write to the yielded path.

    Raises
    ------
    OutputError
        When the file cannot be written (missing folder with ``make_parents=False``,
        no permission, a folder in the way, disk full), naming the path.
    """
    target = Path(path)
    try:
        if make_parents:
            target.parent.mkdir(parents=True, exist_ok=True)
        elif not target.parent.is_dir():
            raise OutputError(target, f"the folder {str(target.parent)!r} does not exist")
        if target.is_dir():
            raise OutputError(target, "a folder of that name exists")
        remove_stale_temps(target.parent, recursive=False, target=target.name)
        tmp = _temp_path(target)
        os.close(os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666))
    except OSError as exc:
        raise OutputError(target, _reason(exc)) from None
    try:
        yield tmp
        with open(tmp, "rb+") as fh:
            os.fsync(fh.fileno())
        os.replace(tmp, target)
    except OSError as exc:
        tmp.unlink(missing_ok=True)
        raise OutputError(target, _reason(exc)) from None
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


def atomic_write_bytes(path: str | os.PathLike[str], data: bytes) -> None:
    """Write ``data`` to ``path`` atomically (see :func:`atomic_output`)."""
    with atomic_output(path) as tmp, open(tmp, "wb") as fh:
        fh.write(data)


def atomic_write_text(path: str | os.PathLike[str], text: str) -> None:
    """Write ``text`` (UTF-8) atomically."""
    atomic_write_bytes(path, text.encode("utf-8"))


def save_figure(fig: Any, path: str | os.PathLike[str], **savefig: Any) -> Path:
    """Render a matplotlib figure as PNG and write it atomically; returns the path.

    The image is rendered in memory first, so a run killed while plotting never
    leaves an empty or partial PNG under the final name.
    """
    buf = io.BytesIO()
    fig.savefig(buf, format="png", **savefig)
    atomic_write_bytes(path, buf.getvalue())
    return Path(path)


def _reason(exc: OSError) -> str:
    text = exc.strerror or type(exc).__name__
    return f"[Errno {exc.errno}] {text}" if exc.errno else text


def _same_file(a: Path, b: Path) -> bool:
    try:
        if a.exists() and b.exists():
            return os.path.samefile(a, b)
    except OSError:
        return False
    return a.resolve() == b.resolve()


def check_output(
    path: str | os.PathLike[str],
    *,
    kind: Literal["file", "folder"] = "file",
    option: str = "output",
    inputs: Iterable[str | os.PathLike[str]] = (),
    suffix: str | None = None,
) -> Path:
    """Check that ``path`` can be written as a ``kind`` before any work; returns it as a ``Path``.

    Refused, with one sentence naming ``option`` and the path: an empty path; a
    ``suffix`` other than the required one; an existing entry of the other kind (a
    folder where a file is written, a file where a folder is written); an ancestor
    that is a file; a nearest existing ancestor in which this process cannot create
    files (no permission, read-only file system); the same file as one of ``inputs``
    (a command must never overwrite what it reads). Missing parent folders are
    created by the writers later, not here.
    """
    text = os.fspath(path)
    if not text:
        raise ValidationError(f"{option} is empty; give a path to write.")
    target = Path(text)
    if suffix is not None and target.suffix.lower() != suffix:
        raise ValidationError(f"{option} {text!r} must end in {suffix}.")
    if kind == "file" and target.is_dir():
        raise ValidationError(f"{option} {text!r} is a folder; give a file name.")
    if kind == "folder" and target.exists() and not target.is_dir():
        raise ValidationError(f"{option} {text!r} is an existing file; give a folder.")
    for candidate in inputs:
        if _same_file(target, Path(candidate)):
            raise ValidationError(
                f"{option} {text!r} is the same file as the input {os.fspath(candidate)!r}; it would be overwritten."
            )
    start = target if kind == "folder" else target.parent
    ancestor = start.absolute()
    while not ancestor.exists():
        if ancestor.parent == ancestor:
            break
        ancestor = ancestor.parent
    if not ancestor.is_dir():
        raise ValidationError(f"{option} {text!r} cannot be created: {str(ancestor)!r} is a file, not a folder.")
    try:
        fd, probe = tempfile.mkstemp(prefix=".neurovpr-write-check.", dir=ancestor)
        os.close(fd)
        os.unlink(probe)
    except OSError as exc:
        raise ValidationError(
            f"{option} {text!r} cannot be written: the folder {str(ancestor)!r} is not writable ({_reason(exc)})."
        ) from None
    return target
