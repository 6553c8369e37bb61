"""Events -> PN spikes: crops, mega-pixel counts, the 1 ms counter threshold, the published binnings."""

from __future__ import annotations

from collections import Counter

import numpy as np
import pytest

from neurovpr.data.events import (
    DAVIS346_BINNING_2020,
    DAVIS346_BINNING_2023,
    EventStream,
    MegaPixelBinning,
    available_aedat4_readers,
    events_to_pn_spikes,
    load_pn_spikes,
    read_events,
    read_pn_mat,
    write_events,
)
from neurovpr.errors import ValidationError


def test_2023_crop_of_davis346_gives_840_pns():
    b = DAVIS346_BINNING_2023
    assert (b.x_max - b.x_min, b.y_max - b.y_min) == (336, 160)
    assert (b.n_cols, b.n_rows) == (42, 20) and b.grid == (20, 42)
    assert b.n_pn == 840 == 42 * 20
    assert MegaPixelBinning.from_margins((346, 260), left=5, right=5, top=100, block=8) == b


def test_2020_binning_is_the_published_16x16_formula():
    b = DAVIS346_BINNING_2020
    assert b.n_pn == 210 and b.grid == (10, 21) and b.min_events == 1
    y, x = np.mgrid[100:260, 5:341]
    idx = b.pn_index(x.ravel(), y.ravel())
    # the mbsnn_routes README: idx = (x//16)*10 + (y//16), x and y counted from the crop's corner
    assert np.array_equal(idx, ((x.ravel() - 5) // 16) * 10 + (y.ravel() - 100) // 16)
    assert idx.min() == 0 and idx.max() == 209 and len(np.unique(idx)) == 210
    col, row = b.pn_position(idx)
    assert np.array_equal(col * 10 + row, idx)


def _events(rows, size=(16, 16)):
    """rows of (x, y, t_us, p) -> EventStream (sorted by t)."""
    arr = np.array(sorted(rows, key=lambda r: r[2]))
    return EventStream(width=size[0], height=size[1], x=arr[:, 0], y=arr[:, 1], t=arr[:, 2], p=arr[:, 3])


def test_three_event_threshold_and_one_ms_counters():
    binning = MegaPixelBinning(sensor_width=16, sensor_height=16, x_min=0, x_max=16, y_min=0, y_max=16,
                               block=8, min_events=4)
    assert binning.n_pn == 4  # 2 x 2 mega-pixels, idx = col * 2 + row
    rows = [
        (0, 0, 0, 1), (7, 7, 100, 0), (3, 4, 999, 1),  # PN 0, ms 0: 3 events -> no spike
        (1, 1, 1000, 1), (2, 2, 1200, 1), (6, 1, 1500, 0), (5, 5, 1999, 1),  # PN 0, ms 1: 4 -> spike at 1 ms
        (0, 8, 2500, 1), (1, 9, 2600, 1), (2, 10, 3000, 1), (3, 11, 3100, 1),  # PN 1: 2 + 2 across a ms edge
        (8, 0, 4000, 1), (9, 1, 4001, 1), (8, 8, 4002, 1), (9, 9, 4003, 1),  # PN 2 and 3: 2 each in one ms
        (15, 15, 5000, 1), (14, 14, 5001, 1), (13, 13, 5002, 0), (12, 12, 5003, 0), (11, 11, 5004, 1),  # PN 3: 5
    ]
    spikes = events_to_pn_spikes(_events(rows), binning)
    assert spikes.times_ms.tolist() == [1.0, 5.0] and spikes.idx.tolist() == [0, 3]
    assert spikes.n_pn == 4 and spikes.duration_ms == 6.0
    # "more than 3" versus "at least 3": one step down the threshold adds the 3-event window
    three = events_to_pn_spikes(_events(rows), binning.replace(min_events=3))
    assert three.times_ms.tolist() == [0.0, 1.0, 5.0] and three.idx.tolist() == [0, 0, 3]
    # the 2020 rule (>= 1 event per ms) gives one spike per busy (ms, PN) pair
    every = events_to_pn_spikes(_events(rows), binning.replace(min_events=1))
    assert every.times_ms.tolist() == [0, 1, 2, 3, 4, 4, 5] and every.idx.tolist() == [0, 0, 1, 1, 2, 3, 3]


def test_crop_polarity_and_time_origin():
    binning = MegaPixelBinning(sensor_width=16, sensor_height=16, x_min=4, x_max=12, y_min=8, y_max=16,
                               block=4, min_events=1)
    assert binning.grid == (2, 2)
    rows = [(3, 9, 10_000, 1), (4, 8, 10_500, 1), (11, 15, 11_000, 0), (12, 15, 11_000, 1), (5, 7, 12_000, 1)]
    spikes = events_to_pn_spikes(_events(rows), binning)
    # only (4, 8) -> PN 0 and (11, 15) -> PN 3 are inside; time 0 is the first event (10 ms)
    assert spikes.idx.tolist() == [0, 3] and spikes.times_ms.tolist() == [0.0, 1.0]
    on_only = events_to_pn_spikes(_events(rows), binning.replace(polarity="on"))
    assert on_only.idx.tolist() == [0]
    shifted = events_to_pn_spikes(_events(rows), binning, t0_us=0)
    assert shifted.times_ms.tolist() == [10.0, 11.0] and shifted.duration_ms == 13.0


def test_bad_binnings_are_refused():
    with pytest.raises(ValidationError, match="crop width 10 px is not a multiple of block=8 px"):
        MegaPixelBinning(sensor_width=16, sensor_height=16, x_min=0, x_max=10, y_min=0, y_max=16)
    with pytest.raises(ValidationError, match=r"columns \[0, 20\) must be non-empty and within the sensor's width 16"):
        MegaPixelBinning(sensor_width=16, sensor_height=16, x_min=0, x_max=20, y_min=0, y_max=16)
    with pytest.raises(ValidationError, match="polarity 'up'"):
        DAVIS346_BINNING_2023.replace(polarity="up")
    stream = _events([(0, 0, 5, 1)])
    with pytest.raises(ValidationError, match="sensor is 16x16 but the binning is for 346x260"):
        events_to_pn_spikes(stream, DAVIS346_BINNING_2023)
    b = MegaPixelBinning(sensor_width=16, sensor_height=16, x_min=0, x_max=16, y_min=0, y_max=16)
    with pytest.raises(ValidationError, match="t0_us=9 is after the stream's first event at 5 us"):
        events_to_pn_spikes(stream, b, t0_us=9)


def test_16x16_binning_reproduces_the_mbsnn_routes_files(shared_data):
    """Events made from NB0's spikes, binned with the 2020 rule, give back NB0's t/idx arrays exactly."""
    path = next((shared_data / "mbsnn_routes").glob("NB0_*.mat"))
    published = read_pn_mat(path, n_pn=DAVIS346_BINNING_2020.n_pn)
    rng = np.random.default_rng(0)
    b = DAVIS346_BINNING_2020
    col, row = b.pn_position(published.idx)
    repeats = rng.integers(1, 4, len(published))  # 1 to 3 events per (ms, PN): still one spike
    col, row, t_ms = (np.repeat(a, repeats) for a in (col, row, published.times_ms.astype(np.int64)))
    x = b.x_min + col * 16 + rng.integers(0, 16, col.size)
    y = b.y_min + row * 16 + rng.integers(0, 16, col.size)
    t = t_ms * 1000 + rng.integers(0, 1000, col.size)
    n_out = 50_000  # events outside the crop: left/right margins and the sky rows
    out_x = rng.choice(np.r_[0:5, 341:346], n_out)
    out_y = rng.integers(0, 260, n_out)
    sky_x, sky_y = rng.integers(0, 346, n_out), rng.integers(0, 100, n_out)
    out_t = rng.integers(0, int(published.duration_ms) * 1000, 2 * n_out)
    x, y, t = np.r_[x, out_x, sky_x], np.r_[y, out_y, sky_y], np.r_[t, out_t]
    order = np.argsort(t, kind="stable")
    stream = EventStream(width=346, height=260, x=x[order], y=y[order], t=t[order], p=rng.integers(0, 2, t.size))
    binned = events_to_pn_spikes(stream, b, t0_us=0)
    assert np.array_equal(binned.times_ms, published.times_ms)
    assert np.array_equal(binned.idx, published.idx)
    # the published files' structure: integer ms, sorted by time then PN, one spike per (ms, PN)
    key = binned.times_ms.astype(np.int64) * b.n_pn + binned.idx
    assert np.all(np.diff(key) > 0)


def test_real_aedat4_sample_matches_a_direct_count(shared_data):
    if not available_aedat4_readers():
        pytest.skip("no AEDAT 4.0 decoder installed (pip install 'neurovpr[events]')")
    stream = read_events(shared_data / "aedat4_sample" / "sample.aedat4")
    binning = MegaPixelBinning.from_margins(stream.sensor_size, top=40, block=8, min_events=4)
    assert binning.n_pn == 40 * 25
    spikes = events_to_pn_spikes(stream, binning)
    assert spikes.n_pn == 1000 and len(spikes) > 100
    counts = Counter()
    for x, y, t in zip(stream.x.tolist(), stream.y.tolist(), stream.t.tolist(), strict=True):
        if y >= 40:
            counts[((t - stream.t_start) // 1000, (x // 8) * 25 + (y - 40) // 8)] += 1
    expected = sorted(key for key, n in counts.items() if n >= 4)
    assert list(zip(spikes.times_ms.astype(np.int64).tolist(), spikes.idx.tolist(), strict=True)) == expected
    source = spikes.to_source()
    assert source.n_neurons == 1000 and source.times.size == len(spikes)


def test_load_pn_spikes_dispatches_on_the_file(shared_data, tmp_path):
    mat = next((shared_data / "mbsnn_routes").glob("NB3_*.mat"))
    assert load_pn_spikes(mat, n_pn=210) == read_pn_mat(mat, n_pn=210)
    rng = np.random.default_rng(4)
    n = 2000
    stream = EventStream(width=346, height=260, x=rng.integers(0, 346, n), y=rng.integers(0, 260, n),
                         t=np.sort(rng.integers(0, 20_000, n)), p=rng.integers(0, 2, n))
    path = write_events(stream, tmp_path / "davis.h5")
    assert load_pn_spikes(path) == events_to_pn_spikes(stream, DAVIS346_BINNING_2023)
    small = write_events(_events([(0, 0, 5, 1), (1, 1, 6, 0)]), tmp_path / "small.npz")
    with pytest.raises(ValidationError, match="comes from a 16x16 sensor; the default binning is for a 346x260"):
        load_pn_spikes(small)
