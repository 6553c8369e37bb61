"""The DVS emulator: ON for brightening, OFF for darkening, the contrast threshold, options."""

from __future__ import annotations

import numpy as np
import pytest

from neurovpr.data.events import emulate_dvs
from neurovpr.errors import ValidationError


def _two_frames(before, after, shape=(3, 4)):
    return np.stack([np.full(shape, before, dtype=float), np.full(shape, after, dtype=float)])


def test_brightening_gives_on_events_counted_by_threshold():
    # log(200/100) = 0.693 -> floor(0.693 / 0.2) = 3 ON events per pixel
    stream = emulate_dvs(_two_frames(100.0, 200.0), np.array([0, 10_000]), threshold_on=0.2, log_eps=1e-9)
    assert stream.sensor_size == (4, 3)
    assert len(stream) == 3 * 12 and np.all(stream.p == 1)
    # crossing times interpolate the log intensity linearly between the two frames
    expected = np.rint(np.array([0.2, 0.4, 0.6]) / np.log(2.0) * 10_000)
    assert np.array_equal(np.unique(stream.t), expected)
    assert np.all(np.bincount(stream.y * 4 + stream.x) == 3)


def test_darkening_gives_off_events():
    # log(100/40) = 0.916 -> floor(0.916 / 0.3) = 3 OFF events per pixel
    stream = emulate_dvs(_two_frames(100.0, 40.0), np.array([0, 1000]), threshold_off=0.3, log_eps=1e-9)
    assert len(stream) == 3 * 12 and np.all(stream.p == 0)


def test_change_below_threshold_gives_no_events():
    with pytest.raises(ValidationError, match="no pixel's log intensity changed by a contrast threshold"):
        emulate_dvs(_two_frames(100.0, 115.0), np.array([0, 1000]), threshold_on=0.2, log_eps=1e-9)  # log 1.15 = 0.14


def test_reference_level_carries_over_between_frames():
    # +0.15 then +0.15 in log: nothing after the first step, one ON event at the second
    frames = np.stack([np.full((1, 1), v) for v in (1.0, np.exp(0.15), np.exp(0.30))])
    stream = emulate_dvs(frames, np.array([0, 100, 200]), threshold_on=0.2, log_eps=1e-12)
    assert len(stream) == 1 and stream.p[0] == 1 and 100 < stream.t[0] <= 200


def test_mixed_scene_and_refractory_period():
    frames = np.stack([np.array([[100.0, 100.0]]), np.array([[300.0, 20.0]])])  # left brightens, right darkens
    stream = emulate_dvs(frames, np.array([0, 1000]), log_eps=1e-9)
    assert set(zip(stream.x.tolist(), stream.p.tolist(), strict=True)) == {(0, 1), (1, 0)}
    on, off = np.sum(stream.p == 1), np.sum(stream.p == 0)
    assert on == int(np.log(3.0) / 0.2) and off == int(np.log(5.0) / 0.2)
    slow = emulate_dvs(frames, np.array([0, 1000]), log_eps=1e-9, refractory_us=400)
    assert len(slow) < len(stream)
    for x in (0, 1):
        assert np.all(np.diff(slow.t[slow.x == x]) >= 400)


def test_noise_and_mismatch_are_seeded():
    frames = np.stack([np.full((8, 8), 50.0), np.full((8, 8), 80.0)])
    times = np.array([0, 1_000_000])
    a = emulate_dvs(frames, times, noise_rate_hz=2.0, threshold_sigma=0.03, seed=7)
    b = emulate_dvs(frames, times, noise_rate_hz=2.0, threshold_sigma=0.03, seed=7)
    c = emulate_dvs(frames, times, noise_rate_hz=2.0, threshold_sigma=0.03, seed=8)
    assert a == b and a != c
    assert np.all(np.diff(a.t) >= 0)


def test_noise_rate_and_threshold_mismatch():
    # log(80/50) = 0.47: 2 events per pixel at threshold 0.2
    frames = np.stack([np.full((8, 8), 50.0), np.full((8, 8), 80.0)])
    times = np.array([0, 1_000_000])
    clean = emulate_dvs(frames, times, log_eps=1e-9)
    assert len(clean) == 2 * 64
    noisy = emulate_dvs(frames, times, log_eps=1e-9, noise_rate_hz=2.0, seed=1)
    extra = len(noisy) - len(clean)  # Poisson, mean 2 Hz x 64 px x 1 s = 128
    assert 90 < extra < 170
    mismatched = emulate_dvs(frames, times, log_eps=1e-9, threshold_sigma=0.05, seed=1)
    per_pixel = np.bincount(mismatched.y * 8 + mismatched.x, minlength=64)
    assert len(np.unique(per_pixel)) > 1  # some pixels now cross 1 or 3 thresholds


@pytest.mark.parametrize(
    ("frames", "times", "match"),
    [
        (np.zeros((2, 3)), np.array([0, 1]), "frames must be an"),
        (np.ones((1, 2, 2)), np.array([0]), "at least 2 frames"),
        (np.ones((2, 2, 2)), np.array([5, 5]), "strictly increasing"),
        (-np.ones((2, 2, 2)), np.array([0, 1]), "finite and >= 0"),
    ],
)
def test_bad_inputs(frames, times, match):
    with pytest.raises(ValidationError, match=match):
        emulate_dvs(frames, times)
