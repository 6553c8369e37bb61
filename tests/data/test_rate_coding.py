"""Poisson rate coding: intensity/4 Hz, the 350/150 ms schedule, Bernoulli-per-step spikes."""

from __future__ import annotations

import numpy as np
import pytest

from neurovpr.data.encoding import RateCoding, poisson_spike_trains
from neurovpr.errors import ValidationError


def test_rates_are_intensity_over_four():
    coding = RateCoding()
    img = np.array([[0, 4], [128, 255]], dtype=np.uint8)
    assert coding.rates(img).tolist() == [0.0, 1.0, 32.0, 63.75]
    assert coding.max_rate_hz == 63.75


def test_schedule_has_initial_rest_then_350_plus_150_ms():
    assert RateCoding().schedule(3).tolist() == [500.0, 1000.0, 1500.0]


def test_poisson_counts_match_rate_times_duration():
    rates = np.full(2000, 63.75)
    times, idx = poisson_spike_trains(rates, 350.0, 0.5, np.random.default_rng(0), t_start_ms=500.0)
    counts = np.bincount(idx, minlength=2000)
    expected = 63.75 * 0.35  # 22.3 spikes per neuron
    assert abs(counts.mean() - expected) < 0.03 * expected
    assert times.min() >= 500.0 and times.max() < 850.0
    assert np.all(np.diff(times) >= 0)
    silent_t, silent_i = poisson_spike_trains(np.zeros(10), 350.0, 0.5, np.random.default_rng(0))
    assert silent_t.size == 0 and silent_i.size == 0


@pytest.mark.parametrize(
    "build",
    [
        lambda: RateCoding(intensity_divisor=0.0),
        lambda: RateCoding(presentation_ms=0.0),
        lambda: RateCoding(rest_ms=-1.0),
        lambda: RateCoding().rates(np.array([[300.0]])),
        lambda: RateCoding().rates(np.array([[np.nan]])),
        lambda: RateCoding().rates(np.zeros((0,))),
        lambda: poisson_spike_trains(np.array([5000.0]), 10.0, 1.0, np.random.default_rng(0)),
        lambda: poisson_spike_trains(np.array([-1.0]), 10.0, 1.0, np.random.default_rng(0)),
    ],
)
def test_bad_coding_input_is_refused(build):
    with pytest.raises(ValidationError):
        build()
