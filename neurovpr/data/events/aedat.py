"""AEDAT event files: AEDAT 4.0 through a maintained decoder, AEDAT 2.0 (jAER) parsed here.

AEDAT 4.0 (DV, iniVation's current format: LZ4/Zstd-compressed FlatBuffers packets) is
decoded by the ``aedat`` package (neuromorphic-systems, a small Rust decoder; the
``events`` extra installs it) or, when that is missing, by iniVation's
``dv-processing``. AEDAT 2.0 is jAER's format: an ASCII header of ``#`` lines, then
big-endian pairs of 32-bit address and 32-bit timestamp (us); the address layout read
here is jAER's DAVIS one (``y`` in bits 22-30, ``x`` in bits 12-21, polarity in bit 11,
bit 31 set for APS/IMU samples and bit 10 for external-input events, both skipped).
AEDAT 3.1 is not read.
"""

from __future__ import annotations

import importlib
import importlib.util
from pathlib import Path
from typing import Literal

import numpy as np

from neurovpr.errors import FileFormatError, NeurovprError

__all__ = ["read_aedat4", "read_aedat2", "aedat_version", "available_aedat4_readers"]

#: Decoders of AEDAT 4.0 files, in the order ``reader="auto"`` tries them.
_AEDAT4_READERS = ("aedat", "dv-processing")
_MODULES = {"aedat": "aedat", "dv-processing": "dv_processing"}

RawEvents = tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, int, int]


def available_aedat4_readers() -> tuple[str, ...]:
    """Names of the installed AEDAT 4.0 decoders (``"aedat"``, ``"dv-processing"``)."""
    return tuple(name for name in _AEDAT4_READERS if importlib.util.find_spec(_MODULES[name]) is not None)


def aedat_version(path: Path) -> str | None:
    """The version in an AEDAT file's first line (``"2.0"``, ``"3.1"``, ``"4.0"``), or ``None``."""
    with open(path, "rb") as fh:
        head = fh.read(16)
    if not head.startswith(b"#!AER-DAT"):
        return None
    return head[len(b"#!AER-DAT") :].split(b"\r")[0].split(b"\n")[0].decode("ascii", "replace").strip()


def read_aedat4(path: Path, reader: Literal["auto", "aedat", "dv-processing"] = "auto") -> RawEvents:
    """Decode the first polarity-event stream of an AEDAT 4.0 file.

    Parameters
    ----------
    path
        The ``.aedat4`` file.
    reader
        ``"aedat"``, ``"dv-processing"``, or ``"auto"`` (the first one installed).

    Returns
    -------
    tuple
        ``(x, y, t, p, width, height)``: arrays as stored in the file (``t`` in us) and
        the sensor size from the file's stream description.
    """
    installed = available_aedat4_readers()
    if reader == "auto":
        if not installed:
            raise NeurovprError(
                f"Reading the AEDAT 4.0 file {str(path)!r} needs the package 'aedat' "
                "(pip install 'neurovpr[events]') or 'dv-processing', and neither is installed."
            )
        reader = installed[0]  # type: ignore[assignment]
    if reader not in _AEDAT4_READERS:
        raise NeurovprError(f"AEDAT 4.0 reader {reader!r} is unknown; choose one of {_AEDAT4_READERS}.")
    if reader not in installed:
        raise NeurovprError(
            f"AEDAT 4.0 reader {reader!r} was asked for to read {str(path)!r}, but the package is not installed."
        )
    decode = _decode_with_aedat if reader == "aedat" else _decode_with_dv
    try:
        return decode(path)
    except NeurovprError:
        raise
    except Exception as exc:  # the decoders raise their own exception types on corrupt input
        message = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise FileFormatError(f"AEDAT 4.0 file {str(path)!r} could not be decoded by {reader}: {message}.") from exc


def _decode_with_aedat(path: Path) -> RawEvents:
    aedat = importlib.import_module("aedat")
    decoder = aedat.Decoder(str(path))
    streams = decoder.id_to_stream()
    event_ids = sorted(sid for sid, desc in streams.items() if desc.get("type") == "events")
    if not event_ids:
        raise FileFormatError(f"AEDAT 4.0 file {str(path)!r} has no polarity-event stream.")
    sid = event_ids[0]
    width, height = int(streams[sid]["width"]), int(streams[sid]["height"])
    chunks = [packet["events"] for packet in decoder if packet["stream_id"] == sid and "events" in packet]
    if not chunks:
        return _empty(width, height)
    ev = np.concatenate(chunks)
    return (ev["x"], ev["y"], ev["t"].astype(np.int64), ev["on"].astype(np.int8), width, height)


def _decode_with_dv(path: Path) -> RawEvents:
    dv = importlib.import_module("dv_processing")
    recording = dv.io.MonoCameraRecording(str(path))
    if not recording.isEventStreamAvailable():
        raise FileFormatError(f"AEDAT 4.0 file {str(path)!r} has no polarity-event stream.")
    width, height = (int(v) for v in recording.getEventResolution())
    chunks = []
    while recording.isRunning():
        batch = recording.getNextEventBatch()
        if batch is not None and batch.size() > 0:
            chunks.append(batch.numpy())
    if not chunks:
        return _empty(width, height)
    ev = np.concatenate(chunks)
    return (ev["x"], ev["y"], ev["timestamp"].astype(np.int64), ev["polarity"].astype(np.int8), width, height)


def _empty(width: int, height: int) -> RawEvents:
    zero = np.zeros(0, dtype=np.int64)
    return zero, zero, zero, zero, width, height


def read_aedat2(path: Path, sensor_size: tuple[int, int] | None, *, flip_y: bool = False) -> RawEvents:
    """Parse a jAER AEDAT 2.0 file with the DAVIS address layout.

    Parameters
    ----------
    path
        The ``.aedat`` file.
    sensor_size
        ``(width, height)``: AEDAT 2.0 headers do not state it reliably, so it is required.
    flip_y
        jAER counts rows from the bottom; ``True`` turns ``y`` into ``height - 1 - y`` so
        that row 0 is the top row, as in AEDAT 4.0 and image arrays.

    Returns
    -------
    tuple
        ``(x, y, t, p, width, height)``; ``t`` in us with 32-bit wrap-arounds undone.
    """
    if sensor_size is None:
        raise NeurovprError(
            f"AEDAT 2.0 file {str(path)!r} does not state its sensor size; pass sensor_size=(width, height)."
        )
    data = Path(path).read_bytes()
    start = 0
    while start < len(data) and data[start : start + 1] == b"#":
        end = data.find(b"\n", start)
        if end < 0:
            raise FileFormatError(f"AEDAT 2.0 file {str(path)!r} ends inside its ASCII header.")
        line = data[start:end]
        start = end + 1
        if line.rstrip(b"\r").lower() == b"#end of ascii header":
            break
    body = data[start:]
    if len(body) % 8:
        raise FileFormatError(
            f"AEDAT 2.0 file {str(path)!r} is truncated: {len(body)} data bytes is not a whole number "
            "of 8-byte (address, timestamp) records."
        )
    words = np.frombuffer(body, dtype=">u4").reshape(-1, 2).astype(np.int64)
    addr, ts = words[:, 0], words[:, 1]
    dvs = ((addr >> 31) & 1 == 0) & ((addr >> 10) & 1 == 0)
    addr, ts = addr[dvs], ts[dvs]
    wraps = np.concatenate([[0], np.cumsum(np.diff(ts) < -(1 << 31))]) if ts.size else ts
    t = ts + (wraps.astype(np.int64) << 32)
    width, height = (int(v) for v in sensor_size)
    x = (addr >> 12) & 0x3FF
    y = (addr >> 22) & 0x1FF
    if flip_y:
        y = height - 1 - y
    p = ((addr >> 11) & 1).astype(np.int8)
    return x, y, t, p, width, height
