"""Run directories: one object that owns a run folder's layout, and verification of finished parts on ``--resume``.

A *run directory* is what ``neurovpr train`` writes: the trained network
(:data:`NETWORK_FILE`), the model's own parts, and :data:`RUN_FILE` (at least
``{"model": NAME, "backend": ..., "seed": ...}``), written last, so a folder with
it is a finished run. :class:`RunDir` is the one place that spells these names: it
opens and checks them through the project's readers (:func:`neurovpr.load`, with its
checksum; JSON parsed and checked for its model) and writes through the atomic
writer (:mod:`neurovpr.fileio`), so every model, command and benchmark reads and
writes a run the same way.

A part a run wrote (a network file, a ``.npz`` record, a JSON file) counts as
finished on ``--resume`` only when it reads back whole: a network file through its
own SHA-256 checksum (:func:`neurovpr.load`), an ``.npz`` archive through the CRC-32
of every member, JSON by parsing. :func:`damaged_part` says what is wrong with one,
so a resumed run redoes a damaged part and names it instead of trusting that the
file exists.
"""

from __future__ import annotations

import json
import math
import os
import zipfile
import zlib
from dataclasses import dataclass
from pathlib import Path, PurePosixPath
from typing import TYPE_CHECKING, Any

from neurovpr.errors import NeurovprError, ValidationError
from neurovpr.fileio import atomic_write_text

if TYPE_CHECKING:
    from neurovpr.ir.network import Network

__all__ = ["NETWORK_FILE", "RUN_FILE", "RUN_DT_KEY", "RunDir", "damaged_part"]

#: The trained network of a run directory.
NETWORK_FILE = "network.h5"
#: The description of a run (``{"model": ..., "backend": ..., "seed": ...}``), written last.
RUN_FILE = "run.json"
#: The key of ``run.json`` that records the time step (ms) a run's network runs at (every model writes it).
RUN_DT_KEY = "dt_ms"


@dataclass(frozen=True, slots=True)
class RunDir:
    """The layout of one run folder: its network file, its ``run.json`` and the model's own parts.

    Parameters
    ----------
    path
        The folder (it need not exist yet: a training run creates it).

    Examples
    --------
    >>> run = RunDir("runs/mb")
    >>> run.network_file.name, run.info_file.name
    ('network.h5', 'run.json')
    """

    path: Path

    def __post_init__(self) -> None:
        if not isinstance(self.path, (str, os.PathLike)):
            raise ValidationError(f"a run directory must be a path, got {self.path!r}.")
        object.__setattr__(self, "path", Path(self.path))

    def __str__(self) -> str:
        return str(self.path)

    @property
    def network_file(self) -> Path:
        """The trained network (:data:`NETWORK_FILE`)."""
        return self.path / NETWORK_FILE

    @property
    def info_file(self) -> Path:
        """The run's description (:data:`RUN_FILE`)."""
        return self.path / RUN_FILE

    def part(self, name: str) -> Path:
        """The model's own part ``name`` (a relative path inside the folder, e.g. ``"modules/m0.h5"``)."""
        pure = PurePosixPath(name)
        if not name or pure.is_absolute() or ".." in pure.parts or "\\" in name:
            raise ValidationError(f"run part {name!r} must be a relative path inside the run directory.")
        return self.path.joinpath(*pure.parts)

    @property
    def finished(self) -> bool:
        """True when ``run.json`` is there (it is written last)."""
        return self.info_file.is_file()

    @property
    def has_network(self) -> bool:
        """True when the folder holds a network file."""
        return self.network_file.is_file()

    def require(self) -> RunDir:
        """This run directory, after checking that the folder exists (one sentence otherwise)."""
        if not self.path.is_dir():
            raise ValidationError(f"Run directory {str(self.path)!r} does not exist.")
        return self

    def read_info(self) -> dict[str, Any]:
        """``run.json``, parsed and checked to name its model.

        Raises
        ------
        ValidationError
            When it is missing, is not readable JSON or names no model.
        """
        path = self.info_file
        if not path.is_file():
            raise ValidationError(f"Run directory {str(self.path)!r} has no {RUN_FILE} (was it written by neurovpr train?).")
        try:
            info = json.loads(path.read_text(encoding="utf-8"))
        except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
            raise ValidationError(f"{path} is not readable JSON ({exc}).") from None
        if not isinstance(info, dict) or not isinstance(info.get("model"), str):
            raise ValidationError(f"{path} does not name its model.")
        return info

    def time_step(self) -> tuple[float, str] | None:
        """The time step (ms) ``run.json`` records (:data:`RUN_DT_KEY`) and where it was read, or ``None``.

        ``None`` when there is no ``run.json`` or it records no time step.

        Raises
        ------
        ValidationError
            If ``run.json`` is unreadable or the recorded time step is not a positive number.
        """
        if not self.finished:
            return None
        value = self.read_info().get(RUN_DT_KEY)
        if value is None:
            return None
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) or value <= 0:
            raise ValidationError(f"{self.info_file}: time step {RUN_DT_KEY} must be a positive number of ms, got {value!r}.")
        return float(value), f"{self.info_file} {RUN_DT_KEY}"

    def load_network(self) -> Network:
        """The trained network, read through :func:`neurovpr.load` (its checksum checked)."""
        from neurovpr.ir.serialization import load

        self.require()
        if not self.has_network:
            raise ValidationError(f"Run directory {str(self.path)!r} has no {NETWORK_FILE}.")
        return load(self.network_file)

    def save_network(self, obj: Any) -> Path:
        """Write ``obj`` (a network or a simulation, with its learned weights) as the network file, atomically."""
        from neurovpr.ir.serialization import save

        self.path.mkdir(parents=True, exist_ok=True)
        save(obj, self.network_file)
        return self.network_file

    def write_info(self, info: dict[str, Any], *, indent: int = 2) -> Path:
        """Write ``run.json`` atomically; call it last, when every other part is written."""
        atomic_write_text(self.info_file, json.dumps(info, indent=indent))
        return self.info_file

    def mark_unfinished(self) -> None:
        """Remove ``run.json`` before parts are rewritten, so the folder reads as unfinished until it is back."""
        self.info_file.unlink(missing_ok=True)

    def damaged(self, name: str) -> str | None:
        """:func:`damaged_part` of the part ``name`` (``NETWORK_FILE`` and ``RUN_FILE`` included)."""
        return damaged_part(self.part(name))


def damaged_part(path: str | os.PathLike[str]) -> str | None:
    """``None`` when ``path`` reads back whole; else the reason, in words (``"missing"``, the checksum error...)."""
    target = Path(path)
    if not target.is_file():
        return "missing"
    suffix = target.suffix.lower()
    try:
        if suffix == ".h5":
            from neurovpr.ir.serialization import load

            load(target)
        elif suffix == ".npz":
            with zipfile.ZipFile(target) as archive:
                bad = archive.testzip()  # reads every member and checks its CRC-32
            if bad is not None:
                return f"member {bad!r} fails its CRC-32 check"
        elif suffix == ".json":
            json.loads(target.read_text(encoding="utf-8"))
    except NeurovprError as exc:
        return str(exc).rstrip(".")
    except (OSError, ValueError, EOFError, zipfile.BadZipFile, zlib.error, NotImplementedError, RuntimeError) as exc:
        return f"{type(exc).__name__}: {exc}"
    return None
