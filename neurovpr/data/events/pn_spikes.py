"""Projection-neuron (PN) spike trains: the input of the mushroom-body network.

A :class:`PNSpikes` holds one recording's PN spikes as parallel arrays of times (ms)
and PN indices, the number of PNs and the recording's duration. It is built by
:func:`neurovpr.data.events.events_to_pn_spikes` from an event stream, or read from
MATLAB files of already binned spikes (:func:`read_pn_mat`, arrays ``t`` and ``idx``).
"""

from __future__ import annotations

import io
import os
import zlib
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import scipy.io

from neurovpr.errors import FileFormatError, NeurovprError, ValidationError
from neurovpr.hdf5 import HDF5Rules, open_hdf5, read_dataset
from neurovpr.ir.cells import SpikeSourceArray
from neurovpr.ir.node import IRNode, freeze_array, param
from neurovpr.resources import require_memory

__all__ = ["PNSpikes", "read_pn_mat", "stretch_time"]


def _first_bad_spike(times: np.ndarray, idx: np.ndarray, n_pn: int) -> str | None:
    """Describe the first bad spike record (0-based), or ``None`` when all are valid."""
    if times.shape != idx.shape:
        return f"times ({times.size}) and indices ({idx.size}) have different lengths"
    if times.size == 0:
        return None
    bad_t = ~np.isfinite(times) | (times < 0)
    bad_order = np.zeros(times.size, dtype=bool)
    bad_order[1:] = times[1:] < times[:-1]
    bad_i = ~np.isfinite(idx) | (idx != np.floor(idx)) | (idx < 0) | (idx >= n_pn)
    bad = bad_t | bad_order | bad_i
    if not bad.any():
        return None
    i = int(np.flatnonzero(bad)[0])
    if bad_t[i]:
        what = f"time {times[i]!r} ms, but times must be finite and >= 0"
    elif bad_order[i]:
        what = f"time {times[i]!r} ms before the previous spike's {times[i - 1]!r} ms (times must be sorted)"
    else:
        what = f"PN index {idx[i]!r} outside 0..{n_pn - 1}"
    return f"spike {i} (0-based) has {what}"


@dataclass(frozen=True, slots=True, kw_only=True, eq=False)
class PNSpikes(IRNode):
    """Spikes of ``n_pn`` projection neurons over one recording.

    Parameters
    ----------
    times_ms
        Spike times in ms from the start of the recording, sorted.
    idx
        PN index of each spike, ``0 <= idx < n_pn``.
    n_pn
        Number of PNs (from the binning that produced the spikes).
    duration_ms
        Length of the recording; every spike time is below it.
    """

    times_ms: np.ndarray
    idx: np.ndarray
    n_pn: int = param(low=1, integer=True, doc="number of projection neurons")
    duration_ms: float = param(unit="ms", low=0.0, low_open=True, doc="length of the recording")

    def _validate(self) -> None:
        times = np.asarray(self.times_ms, dtype=np.float64)
        idx = np.asarray(self.idx)
        if times.ndim != 1 or idx.ndim != 1:
            raise ValidationError(f"PNSpikes.times_ms and idx must be 1-D arrays, got {times.shape} and {idx.shape}.")
        problem = _first_bad_spike(times, idx.astype(np.float64), int(self.n_pn))
        if problem is not None:
            raise ValidationError(f"PNSpikes: {problem}.")
        if times.size and times[-1] >= self.duration_ms:
            raise ValidationError(
                f"PNSpikes: the last spike at {times[-1]!r} ms is not before duration_ms={self.duration_ms!r} ms."
            )
        object.__setattr__(self, "times_ms", freeze_array(times))
        object.__setattr__(self, "idx", freeze_array(idx, dtype=np.int64))

    def __len__(self) -> int:
        return int(self.times_ms.size)

    def counts(self) -> np.ndarray:
        """Number of spikes of each PN."""
        return np.bincount(self.idx, minlength=self.n_pn)

    def to_source(self) -> SpikeSourceArray:
        """The spikes as a :class:`~neurovpr.SpikeSourceArray` of ``n_pn`` neurons."""
        return SpikeSourceArray.from_events(self.times_ms, self.idx, self.n_pn)

    def window(self, start_ms: float, end_ms: float, *, shift: bool = True) -> PNSpikes:
        """The spikes with ``start_ms <= t < end_ms``.

        With ``shift`` (default) times restart at 0 and the duration is the window's;
        otherwise times and duration are kept.
        """
        if not (np.isfinite(start_ms) and np.isfinite(end_ms) and 0.0 <= start_ms < end_ms <= self.duration_ms):
            raise ValidationError(
                f"PNSpikes.window: need 0 <= start_ms < end_ms <= {self.duration_ms} ms, "
                f"got start_ms={start_ms}, end_ms={end_ms}."
            )
        lo, hi = np.searchsorted(self.times_ms, [start_ms, end_ms], side="left")
        return PNSpikes(
            times_ms=self.times_ms[lo:hi] - (start_ms if shift else 0.0),
            idx=self.idx[lo:hi],
            n_pn=self.n_pn,
            duration_ms=(end_ms - start_ms) if shift else self.duration_ms,
        )

    def segment(self, start: float, end: float, *, shift: bool = True) -> PNSpikes:
        """The spikes in ``[start, end)`` of the recording, given as fractions of its duration.

        This is how two recordings of a route are aligned by normalised time: the same
        fractions of each. With ``shift`` (default) times restart at 0.
        """
        if not 0.0 <= start < end <= 1.0:
            raise ValidationError(f"PNSpikes.segment: need 0 <= start < end <= 1, got start={start}, end={end}.")
        return self.window(start * self.duration_ms, end * self.duration_ms, shift=shift)

    def active_interval(self, *, window_ms: float = 100.0, fraction: float = 0.25) -> tuple[float, float]:
        """``(start_ms, end_ms)`` of the part of the recording where the sensor was moving.

        Recordings often begin and end with the robot standing still, when the event
        camera sees almost nothing. The recording is cut into ``window_ms`` windows; the
        active interval runs from the first to the end of the last window whose spike
        count reaches ``fraction`` of the 75th percentile of the window counts.
        """
        if not (window_ms > 0 and 0 < fraction <= 1):
            raise ValidationError(
                f"PNSpikes.active_interval: need window_ms > 0 and 0 < fraction <= 1, "
                f"got window_ms={window_ms}, fraction={fraction}."
            )
        n_windows = max(int(np.ceil(self.duration_ms / window_ms)), 1)
        which = np.minimum((self.times_ms // window_ms).astype(np.int64), n_windows - 1)
        # counts of the windows that hold spikes only: memory grows with the spikes, not the duration
        windows, counts = np.unique(which, return_counts=True)
        level = fraction * _percentile_with_zeros(counts, n_windows, 75.0)
        active = windows[counts >= max(level, 1)]
        if active.size == 0:
            raise ValidationError("PNSpikes.active_interval: the recording has no spikes.")
        return float(active[0] * window_ms), float(min((active[-1] + 1) * window_ms, self.duration_ms))

    def trim_inactive(self, *, window_ms: float = 100.0, fraction: float = 0.25) -> PNSpikes:
        """The :meth:`active_interval` of the recording, times restarting at 0."""
        start, end = self.active_interval(window_ms=window_ms, fraction=fraction)
        return self.window(start, end)


def _percentile_with_zeros(counts: np.ndarray, n: int, q: float) -> float:
    """``np.percentile(full, q)`` of ``n`` values: ``counts`` and ``n - counts.size`` zeros (never built)."""
    values = np.sort(counts)
    zeros = n - values.size
    pos = q / 100.0 * (n - 1)
    lo, hi = int(np.floor(pos)), int(np.ceil(pos))

    def at(i: int) -> float:
        return 0.0 if i < zeros else float(values[i - zeros])

    return at(lo) + (at(hi) - at(lo)) * (pos - lo)


def stretch_time(spikes: PNSpikes, factor: float) -> PNSpikes:
    """Stretch the time axis by ``factor``: the same route driven at ``1 / factor`` times the speed.

    ``factor = 2`` doubles every spike time and the duration (half speed); ``0.5`` halves
    them (double speed). Spike counts and their order are unchanged.
    """
    factor = float(factor)
    if not (np.isfinite(factor) and factor > 0):
        raise ValidationError(f"stretch_time: factor must be a finite number > 0, got {factor!r}.")
    return PNSpikes(
        times_ms=spikes.times_ms * factor,
        idx=spikes.idx,
        n_pn=spikes.n_pn,
        duration_ms=spikes.duration_ms * factor,
    )


#: What a MATLAB v7.3 (HDF5) file may hold: numbers and text, MATLAB's compression, nothing outside the file.
_MAT73_RULES = HDF5Rules(what="PN spike file", filters=("gzip", "shuffle", "fletcher32"), strings=True)


# What scipy.io raises on a damaged MATLAB file.
_MAT_ERRORS = (
    scipy.io.matlab.MatReadError, ValueError, TypeError, OSError, IndexError, KeyError, OverflowError, EOFError,
    AttributeError, zlib.error,
)  # fmt: skip


def _loadmat_child(path: Path) -> dict[str, np.ndarray]:
    _check_mat5_sizes(path)
    return scipy.io.loadmat(io.BytesIO(path.read_bytes()), variable_names=["t", "idx"])


def _loadmat_isolated(path: Path) -> dict[str, np.ndarray]:
    """``scipy.io.loadmat`` of ``t`` and ``idx`` in a child process.

    scipy's MATLAB v5 reader can crash the interpreter (SIGSEGV/SIGBUS) on some damaged
    files, which no ``except`` catches; a crash of the child becomes one sentence here.
    """
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor
    from concurrent.futures.process import BrokenProcessPool

    method = "fork" if "fork" in multiprocessing.get_all_start_methods() else "spawn"
    with ProcessPoolExecutor(max_workers=1, mp_context=multiprocessing.get_context(method)) as pool:
        try:
            return pool.submit(_loadmat_child, path).result()
        except BrokenProcessPool:
            raise FileFormatError(f"PN spike file {str(path)!r} is damaged: the MATLAB reader crashed on it.") from None
        except (NeurovprError, NotImplementedError):  # NotImplementedError: a v7.3 (HDF5) file, read by the caller
            raise
        except Exception as exc:  # scipy's parser fails on damaged files with any exception type
            raise FileFormatError(
                f"PN spike file {str(path)!r} is not a readable MATLAB file ({type(exc).__name__}: {exc})."
            ) from None


def _check_mat5_sizes(path: Path) -> None:
    """Refuse a MATLAB v5 file whose ``t``/``idx`` declare more values than the file or the memory limit holds."""
    variables = {name: shape for name, shape, _ in scipy.io.whosmat(path)}
    total = 0.0
    for name in ("t", "idx"):
        if name in variables:
            values = float(np.prod(variables[name], dtype=np.float64))
            total += values * 8
            if values > path.stat().st_size * 1100:  # more than even compressed bytes can hold
                raise FileFormatError(
                    f"PN spike file {str(path)!r} is forged: array {name!r} declares {values:.3g} values "
                    f"in a file of {path.stat().st_size} bytes."
                )
    require_memory(2 * total, f"reading PN spike file {str(path)!r} ({total / 8:.3g} values)")


def _load_mat_arrays(path: Path) -> tuple[np.ndarray, np.ndarray]:
    try:
        try:
            data = _loadmat_isolated(path)
        except NotImplementedError:  # MATLAB v7.3 files are HDF5
            with open_hdf5(path, _MAT73_RULES) as fh:
                data = {name: read_dataset(fh[name], str(path), _MAT73_RULES) for name in ("t", "idx") if name in fh}
    except (ValidationError, FileFormatError):
        raise
    except _MAT_ERRORS as exc:
        raise FileFormatError(f"PN spike file {str(path)!r} is not a readable MATLAB file: {exc}.") from exc
    missing = [name for name in ("t", "idx") if name not in data]
    if missing:
        raise FileFormatError(
            f"PN spike file {str(path)!r} lacks the array(s) {', '.join(missing)} (expected 't' and 'idx')."
        )
    t, idx = (np.ravel(np.asarray(data[name])) for name in ("t", "idx"))
    for name, arr in (("t", t), ("idx", idx)):
        if not np.issubdtype(arr.dtype, np.number):
            raise FileFormatError(f"PN spike file {str(path)!r}: array {name!r} is not numeric (dtype {arr.dtype}).")
    return t.astype(np.float64), idx.astype(np.float64)


def read_pn_mat(
    path: str | os.PathLike[str],
    *,
    n_pn: int | None = None,
    bin_ms: float = 1.0,
) -> PNSpikes:
    """Read binned PN spikes from a MATLAB file with arrays ``t`` (ms, sorted) and ``idx``.

    Parameters
    ----------
    path
        A MATLAB v5 (or v7.3/HDF5) file.
    n_pn
        Number of PNs of the binning that produced the file (e.g. ``binning.n_pn`` of
        :data:`~neurovpr.data.events.DAVIS346_BINNING_2020`, 210); by default the highest
        index in the file plus one.
    bin_ms
        Width of the time bins; the duration is the last spike time plus one bin.
    """
    path = Path(path)
    if not path.is_file():
        raise ValidationError(f"PN spike file {str(path)!r} does not exist.")
    t, idx = _load_mat_arrays(path)
    if t.size == 0:
        raise ValidationError(f"PN spike file {str(path)!r} holds no spikes; an empty recording cannot be used.")
    if n_pn is not None:
        limit = int(n_pn)
    else:
        finite = idx[np.isfinite(idx)]
        limit = max(int(finite.max()) + 1, 1) if finite.size else 1
    require_memory(
        64.0 * limit, f"PN spike file {str(path)!r}: {limit} PNs (n_pn or the highest idx + 1)", " to count spikes per PN"
    )
    problem = _first_bad_spike(t, idx, limit)
    if problem is not None:
        raise ValidationError(f"PN spike file {str(path)!r}: {problem}.")
    if not bin_ms > 0:
        raise ValidationError(f"read_pn_mat: bin_ms must be > 0, got {bin_ms!r}.")
    return PNSpikes(times_ms=t, idx=idx.astype(np.int64), n_pn=limit, duration_ms=float(t[-1]) + bin_ms)
