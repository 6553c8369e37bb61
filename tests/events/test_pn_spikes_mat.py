"""PN spike trains: the binned mbsnn_routes MATLAB files, validation, time stretching, segments."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.io

from neurovpr.data.events import DAVIS346_BINNING_2020, PNSpikes, read_pn_mat, stretch_time
from neurovpr.errors import FileFormatError, ValidationError

# spikes, duration (last spike + 1 ms) and active (moving) span of each published recording
ROUTES = {
    "NB0": (257_828, 34_277.0, (10_600.0, 30_300.0)),
    "NB3": (260_956, 25_186.0, (3_600.0, 21_900.0)),
    "NB4": (257_561, 27_079.0, (5_200.0, 23_900.0)),
    "NB5": (246_528, 24_886.0, (4_500.0, 23_900.0)),
    "NB6": (227_866, 26_954.0, (4_700.0, 24_900.0)),
}


@pytest.mark.parametrize("run", sorted(ROUTES))
def test_read_mbsnn_routes_file(shared_data, run):
    path = next((shared_data / "mbsnn_routes").glob(f"{run}_*.mat"))
    spikes = read_pn_mat(path, n_pn=DAVIS346_BINNING_2020.n_pn)
    n_spikes, duration, active = ROUTES[run]
    assert len(spikes) == n_spikes and spikes.duration_ms == duration
    assert spikes.n_pn == 210 and np.all(spikes.counts() > 0)
    assert read_pn_mat(path).n_pn == 210  # derived from the data: every PN fires
    assert spikes.times_ms[0] == 0.0 and np.all(np.diff(spikes.times_ms) >= 0)
    start, end = spikes.active_interval()
    assert abs(start - active[0]) <= 200 and abs(end - active[1]) <= 200
    trimmed = spikes.trim_inactive()
    assert trimmed.duration_ms == end - start and trimmed.times_ms[0] >= 0.0
    assert 0.9 < len(trimmed) / len(spikes) <= 1.0


def test_bad_mat_files(tmp_path):
    scipy.io.savemat(tmp_path / "noidx.mat", {"t": np.arange(3.0)})
    with pytest.raises(FileFormatError, match=r"noidx\.mat.*lacks the array\(s\) idx"):
        read_pn_mat(tmp_path / "noidx.mat")
    scipy.io.savemat(tmp_path / "unsorted.mat", {"t": [[0.0, 4.0, 2.0]], "idx": [[1.0, 2.0, 3.0]]})
    with pytest.raises(ValidationError, match=r"unsorted\.mat.*spike 2 \(0-based\) has time 2\.0 ms before"):
        read_pn_mat(tmp_path / "unsorted.mat")
    scipy.io.savemat(tmp_path / "range.mat", {"t": [[0.0, 1.0]], "idx": [[1.0, 300.0]]})
    with pytest.raises(ValidationError, match=r"range\.mat.*spike 1 \(0-based\) has PN index 300\.0 outside 0\.\.209"):
        read_pn_mat(tmp_path / "range.mat", n_pn=210)
    scipy.io.savemat(tmp_path / "empty.mat", {"t": np.zeros((1, 0)), "idx": np.zeros((1, 0))})
    with pytest.raises(ValidationError, match=r"empty\.mat.*holds no spikes"):
        read_pn_mat(tmp_path / "empty.mat")
    (tmp_path / "text.mat").write_text("not matlab")
    with pytest.raises(FileFormatError, match=r"text\.mat.*not a readable MATLAB file"):
        read_pn_mat(tmp_path / "text.mat")


def test_pn_spikes_validation():
    with pytest.raises(ValidationError, match=r"last spike at 5\.0 ms is not before duration_ms=5\.0"):
        PNSpikes(times_ms=[1.0, 5.0], idx=[0, 1], n_pn=2, duration_ms=5.0)
    with pytest.raises(ValidationError, match=r"spike 1 \(0-based\) has PN index 2\.0 outside 0\.\.1"):
        PNSpikes(times_ms=[1.0, 2.0], idx=[0, 2], n_pn=2, duration_ms=5.0)
    with pytest.raises(ValidationError, match=r"PNSpikes\.duration_ms must be > 0\.0"):
        PNSpikes(times_ms=[], idx=[], n_pn=2, duration_ms=0.0)


def test_stretch_time_changes_speed_only():
    spikes = PNSpikes(times_ms=[0.0, 1.0, 1.0, 7.0], idx=[3, 0, 2, 3], n_pn=4, duration_ms=8.0)
    slow = stretch_time(spikes, 2.0)  # half speed
    assert slow.times_ms.tolist() == [0.0, 2.0, 2.0, 14.0] and slow.duration_ms == 16.0
    assert np.array_equal(slow.idx, spikes.idx) and np.array_equal(slow.counts(), spikes.counts())
    fast = stretch_time(spikes, 0.5)
    assert fast.times_ms.tolist() == [0.0, 0.5, 0.5, 3.5] and fast.duration_ms == 4.0
    assert stretch_time(fast, 2.0) == spikes
    with pytest.raises(ValidationError, match=r"factor must be a finite number > 0, got 0\.0"):
        stretch_time(spikes, 0.0)


def test_segments_and_windows_align_by_normalised_time():
    spikes = PNSpikes(times_ms=np.arange(10.0) * 10, idx=np.arange(10) % 3, n_pn=3, duration_ms=100.0)
    seg = spikes.segment(0.2, 0.5)
    assert seg.times_ms.tolist() == [0.0, 10.0, 20.0] and seg.duration_ms == 30.0
    kept = spikes.segment(0.2, 0.5, shift=False)
    assert kept.times_ms.tolist() == [20.0, 30.0, 40.0] and kept.duration_ms == 100.0
    assert stretch_time(spikes, 3.0).segment(0.2, 0.5).idx.tolist() == seg.idx.tolist()
    with pytest.raises(ValidationError, match="need 0 <= start < end <= 1"):
        spikes.segment(0.5, 0.5)
    source = spikes.to_source()
    assert source.n_neurons == 3 and source.times.size == 10
