"""Event stream -> projection-neuron spikes: crop, pool into mega-pixels, count per time bin.

This is the input stage of the mushroom-body model (Zhu, Mangan, Webb, Science Robotics
2023): the sensor view is cropped (sky removed), pooled into ``block x block``-pixel
"mega-pixels", one projection neuron (PN) per mega-pixel; each mega-pixel has an event
counter that restarts every ``bin_ms`` (1 ms) and the PN spikes in that bin when the
counter reached ``min_events``.

PN numbering follows the published binned recordings: with the crop's column ``cx =
(x - x_min) // block`` and row ``cy = (y - y_min) // block``, ``idx = cx * n_rows + cy``
(``n_rows`` mega-pixel rows). For the 2020 binning (16 x 16 blocks) this is the
``idx = (x//16)*10 + (y//16)`` of the mbsnn_routes files, with x and y counted from
the crop's corner.

The number of PNs always follows from the crop and the block size. Both presets use the
crop of the published recordings, columns 5..340 and rows 100..259 of the DAVIS346's
346 x 260 pixels (336 x 160 pixels, the top 100 rows removed):

* :data:`DAVIS346_BINNING_2023`: 8 x 8 blocks -> 42 x 20 = 840 PNs, a spike when more
  than 3 events arrive in 1 ms (``min_events=4``), the paper's input layer;
* :data:`DAVIS346_BINNING_2020`: 16 x 16 blocks -> 21 x 10 = 210 PNs, a spike for at
  least 1 event in 1 ms, the binning of the mbsnn_routes files.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from neurovpr.data.events.pn_spikes import PNSpikes, read_pn_mat
from neurovpr.data.events.readers import read_events
from neurovpr.data.events.stream import EventStream
from neurovpr.errors import ValidationError
from neurovpr.ir.node import IRNode, param

__all__ = [
    "MegaPixelBinning",
    "events_to_pn_spikes",
    "load_pn_spikes",
    "DAVIS346_BINNING_2023",
    "DAVIS346_BINNING_2020",
]

_POLARITIES = ("both", "on", "off")


@dataclass(frozen=True, slots=True, kw_only=True, eq=False)
class MegaPixelBinning(IRNode):
    """How events become PN spikes: sensor, crop, mega-pixel size, counter window, threshold.

    The crop keeps columns ``x_min <= x < x_max`` and rows ``y_min <= y < y_max``; its width
    and height must be multiples of ``block``.
    """

    sensor_width: int = param(unit="px", low=1, integer=True)
    sensor_height: int = param(unit="px", low=1, integer=True)
    x_min: int = param(unit="px", low=0, integer=True)
    x_max: int = param(unit="px", low=1, integer=True)
    y_min: int = param(unit="px", low=0, integer=True)
    y_max: int = param(unit="px", low=1, integer=True)
    block: int = param(8, unit="px", low=1, integer=True, doc="mega-pixel side")
    bin_ms: float = param(1.0, unit="ms", low=0.0, low_open=True, doc="event-counter window")
    min_events: int = param(4, low=1, integer=True, doc="events in one window that make a PN spike")
    polarity: str = "both"

    def _validate(self) -> None:
        name = type(self).__name__
        if not (self.x_min < self.x_max <= self.sensor_width):
            raise ValidationError(
                f"{name}: the crop's columns [{self.x_min}, {self.x_max}) must be non-empty and within "
                f"the sensor's width {self.sensor_width}."
            )
        if not (self.y_min < self.y_max <= self.sensor_height):
            raise ValidationError(
                f"{name}: the crop's rows [{self.y_min}, {self.y_max}) must be non-empty and within "
                f"the sensor's height {self.sensor_height}."
            )
        for axis, size in (("width", self.x_max - self.x_min), ("height", self.y_max - self.y_min)):
            if size % self.block:
                raise ValidationError(f"{name}: crop {axis} {size} px is not a multiple of block={self.block} px.")
        bin_us = self.bin_ms * 1000.0
        if bin_us != round(bin_us):
            raise ValidationError(f"{name}.bin_ms={self.bin_ms} is not a whole number of microseconds.")
        if self.polarity not in _POLARITIES:
            raise ValidationError(f"{name}.polarity {self.polarity!r} is not one of {_POLARITIES}.")

    @classmethod
    def from_margins(
        cls,
        sensor_size: tuple[int, int],
        *,
        left: int = 0,
        right: int = 0,
        top: int = 0,
        bottom: int = 0,
        **options: object,
    ) -> MegaPixelBinning:
        """A binning that removes ``left``/``right`` columns and ``top``/``bottom`` rows of the sensor."""
        width, height = (int(v) for v in sensor_size)
        return cls(
            sensor_width=width, sensor_height=height,
            x_min=left, x_max=width - right, y_min=top, y_max=height - bottom,
            **options,  # type: ignore[arg-type]
        )

    @property
    def n_cols(self) -> int:
        """Mega-pixel columns across the crop."""
        return (self.x_max - self.x_min) // self.block

    @property
    def n_rows(self) -> int:
        """Mega-pixel rows down the crop."""
        return (self.y_max - self.y_min) // self.block

    @property
    def grid(self) -> tuple[int, int]:
        """``(n_rows, n_cols)``: the shape of a frame with one pixel per PN."""
        return self.n_rows, self.n_cols

    @property
    def n_pn(self) -> int:
        """Number of projection neurons: one per mega-pixel."""
        return self.n_cols * self.n_rows

    @property
    def bin_us(self) -> int:
        """The counter window in microseconds."""
        return round(self.bin_ms * 1000.0)

    def pn_index(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """PN index of sensor pixels inside the crop: ``((x - x_min)//block) * n_rows + (y - y_min)//block``."""
        cx = (np.asarray(x, dtype=np.int64) - self.x_min) // self.block
        cy = (np.asarray(y, dtype=np.int64) - self.y_min) // self.block
        return cx * self.n_rows + cy

    def pn_position(self, idx: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(column, row)`` of each PN in the mega-pixel grid (inverse of :meth:`pn_index`)."""
        col, row = np.divmod(np.asarray(idx, dtype=np.int64), self.n_rows)
        return col, row


def events_to_pn_spikes(
    stream: EventStream, binning: MegaPixelBinning, *, t0_us: int | None = None
) -> PNSpikes:
    """Turn an event stream into PN spikes with ``binning``.

    Parameters
    ----------
    stream
        Events of a sensor of the binning's size.
    binning
        Crop, mega-pixel size, counter window and threshold.
    t0_us
        Time (us) that becomes 0 ms; default the stream's first event. Counter windows
        are ``[t0 + k * bin, t0 + (k + 1) * bin)``.

    Returns
    -------
    PNSpikes
        One spike at ``k * bin_ms`` for PN ``i`` whenever window ``k`` of mega-pixel ``i``
        counted at least ``min_events`` events; sorted by time, then PN index. The
        duration runs to the end of the window of the stream's last event.
    """
    if stream.sensor_size != (binning.sensor_width, binning.sensor_height):
        raise ValidationError(
            f"events_to_pn_spikes: the stream's sensor is {stream.width}x{stream.height} but the binning "
            f"is for {binning.sensor_width}x{binning.sensor_height}."
        )
    t0 = stream.t_start if t0_us is None else int(t0_us)
    if t0 > stream.t_start:
        raise ValidationError(
            f"events_to_pn_spikes: t0_us={t0} is after the stream's first event at {stream.t_start} us."
        )
    x, y, t, p = stream.x, stream.y, stream.t, stream.p
    keep = (x >= binning.x_min) & (x < binning.x_max) & (y >= binning.y_min) & (y < binning.y_max)
    if binning.polarity != "both":
        keep &= p == (1 if binning.polarity == "on" else 0)
    bins = (t[keep] - t0) // binning.bin_us
    key = bins * binning.n_pn + binning.pn_index(x[keep], y[keep])
    cells, counts = np.unique(key, return_counts=True)
    cells = cells[counts >= binning.min_events]
    window, idx = np.divmod(cells, binning.n_pn)
    last_window = (int(t[-1]) - t0) // binning.bin_us
    return PNSpikes(
        times_ms=window * binning.bin_ms,
        idx=idx,
        n_pn=binning.n_pn,
        duration_ms=(last_window + 1) * binning.bin_ms,
    )


#: The 2023 paper's input layer for a DAVIS346: crop 336 x 160 px, 8 x 8 blocks (840 PNs),
#: a spike when more than 3 events arrive within 1 ms.
DAVIS346_BINNING_2023 = MegaPixelBinning(
    sensor_width=346, sensor_height=260, x_min=5, x_max=341, y_min=100, y_max=260, block=8, min_events=4
)

#: The binning of the published 2020 recordings (mbsnn_routes): same crop, 16 x 16 blocks
#: (210 PNs), a spike for at least 1 event within 1 ms.
DAVIS346_BINNING_2020 = MegaPixelBinning(
    sensor_width=346, sensor_height=260, x_min=5, x_max=341, y_min=100, y_max=260, block=16, min_events=1
)


def load_pn_spikes(
    path: str | os.PathLike[str],
    *,
    binning: MegaPixelBinning | None = None,
    n_pn: int | None = None,
    sensor_size: tuple[int, int] | None = None,
) -> PNSpikes:
    """PN spikes of one recording: binned spikes (``.mat``) as they are, an event file binned.

    Parameters
    ----------
    path
        A MATLAB file of ``t``/``idx`` PN spikes, or any event file :func:`read_events` reads.
    binning
        For event files; default :data:`DAVIS346_BINNING_2023` when the sensor is a
        DAVIS346 (346 x 260), required otherwise.
    n_pn
        For ``.mat`` files: the number of PNs of their binning (default: from the data).
    sensor_size
        For event files that do not state it.
    """
    path = Path(path)
    if path.suffix.lower() == ".mat":
        return read_pn_mat(path, n_pn=n_pn)
    stream = read_events(path, sensor_size=sensor_size)
    if binning is None:
        if stream.sensor_size != (DAVIS346_BINNING_2023.sensor_width, DAVIS346_BINNING_2023.sensor_height):
            raise ValidationError(
                f"events file {str(path)!r} comes from a {stream.width}x{stream.height} sensor; the default "
                "binning is for a 346x260 DAVIS346, so pass a MegaPixelBinning for this sensor."
            )
        binning = DAVIS346_BINNING_2023
    return events_to_pn_spikes(stream, binning)
