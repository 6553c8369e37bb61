"""Run directories: the names of their standard files, and verification of finished parts on ``--resume``.

A part a run wrote (a network file, a ``.npz`` record, a JSON file) counts as
finished on ``--resume`` only when it reads back whole: a network file through its
own SHA-256 checksum (:func:`neurovpr.load`), an ``.npz`` archive through the CRC-32
of every member, JSON by parsing. :func:`damaged_part` says what is wrong with one,
so a resumed run redoes a damaged part and names it instead of trusting that the
file exists.
"""

from __future__ import annotations

import json
import os
import zipfile
import zlib
from pathlib import Path

from neurovpr.errors import NeurovprError

__all__ = ["NETWORK_FILE", "RUN_FILE", "damaged_part"]

#: The trained network of a run directory.
NETWORK_FILE = "network.h5"
#: The description of a run (``{"model": ..., "backend": ..., "seed": ...}``).
RUN_FILE = "run.json"


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
