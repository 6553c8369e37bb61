"""Event streams: readers and writers, a DVS emulator, and the projection-neuron input stage.

* :class:`EventStream` - one sensor's events ``(x, y, t [us], p)``, validated.
* :func:`read_events` / :func:`write_events` - AEDAT 4.0 (through the ``aedat`` or
  ``dv-processing`` package), AEDAT 2.0, npy, npz, HDF5 and CSV.
* :func:`emulate_dvs` - events from an aligned frame sequence.
* :class:`MegaPixelBinning`, :func:`events_to_pn_spikes` - crop, 8 x 8 mega-pixels,
  1 ms counters with a threshold: the mushroom-body model's PN spikes;
  :func:`load_pn_spikes` - PN spikes of a recording, binned (``.mat``) or from events.
* :class:`PNSpikes`, :func:`read_pn_mat`, :func:`stretch_time` - PN spike trains, read
  from binned MATLAB recordings, and speed changes.
* :func:`pn_frames`, :func:`event_frames` - frames for frame-based methods.
"""

from neurovpr.data.events.aedat import available_aedat4_readers
from neurovpr.data.events.binning import (
    DAVIS346_BINNING_2020,
    DAVIS346_BINNING_2023,
    MegaPixelBinning,
    events_to_pn_spikes,
    load_pn_spikes,
)
from neurovpr.data.events.dvs import emulate_dvs
from neurovpr.data.events.frames import event_frames, pn_frames
from neurovpr.data.events.pn_spikes import PNSpikes, read_pn_mat, stretch_time
from neurovpr.data.events.readers import EVENT_FORMATS, read_events, write_events
from neurovpr.data.events.stream import EventStream

__all__ = [
    "DAVIS346_BINNING_2020",
    "DAVIS346_BINNING_2023",
    "EVENT_FORMATS",
    "EventStream",
    "MegaPixelBinning",
    "PNSpikes",
    "available_aedat4_readers",
    "emulate_dvs",
    "event_frames",
    "events_to_pn_spikes",
    "load_pn_spikes",
    "pn_frames",
    "read_events",
    "read_pn_mat",
    "stretch_time",
    "write_events",
]
