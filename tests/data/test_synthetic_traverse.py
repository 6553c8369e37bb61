"""Synthetic traverses: deterministic, and hard enough that appearance change matters."""

from __future__ import annotations

import numpy as np
import pytest

from neurovpr.data.synthetic import AppearanceChange, synthetic_traverse
from neurovpr.errors import ValidationError
from neurovpr.evaluation.metrics import recall_at_n
from neurovpr.models.baselines.sad import sad_distances


def test_deterministic_and_seed_dependent():
    a = synthetic_traverse(20, seed=5)
    b = synthetic_traverse(20, seed=5)
    c = synthetic_traverse(20, seed=6)
    np.testing.assert_array_equal(a.query.array, b.query.array)
    assert not np.array_equal(a.reference.array, c.reference.array)
    assert a.reference.array.shape == (20, 32, 64, 3) and a.reference.array.dtype == np.uint8
    assert a.ground_truth.is_aligned()


def test_illumination_and_contrast_act_as_stated():
    base = synthetic_traverse(30, seed=0, query=AppearanceChange(noise_std=0.0, jitter=0.0))
    dark = synthetic_traverse(30, seed=0, query=AppearanceChange(illumination=0.5, noise_std=0.0, jitter=0.0))
    flat = synthetic_traverse(30, seed=0, query=AppearanceChange(contrast=0.5, noise_std=0.0, jitter=0.0))
    q0 = base.query.array.astype(float)
    assert dark.query.array.astype(float).mean() == pytest.approx(0.5 * q0.mean(), rel=0.01)
    assert flat.query.array.astype(float).std() == pytest.approx(0.5 * q0.std(), rel=0.02)
    winter = synthetic_traverse(30, seed=0, query=AppearanceChange(season=1.0, noise_std=0.0))
    ground = (slice(None), slice(26, 32))  # bottom rows: ground, snow-covered in winter
    assert winter.query.array[ground].mean() > base.query.array[ground].mean() + 60


def test_sad_is_well_above_chance_but_not_perfect():
    tr = synthetic_traverse(100, seed=0)
    r = recall_at_n(sad_distances(tr), tr.ground_truth, (1, 5))
    assert 0.2 < r[1] < 0.9  # chance is 0.01
    assert r[5] >= r[1]
    same = synthetic_traverse(100, seed=0, query=AppearanceChange(noise_std=0.01))
    assert recall_at_n(sad_distances(same), same.ground_truth, (1,))[1] > 0.95


@pytest.mark.parametrize(
    "kwargs",
    [{"season": 1.5}, {"illumination": 0.0}, {"blur_sigma": -1.0}, {"shift_px": 100}, {"noise_std": float("nan")}],
)
def test_bad_appearance_change(kwargs):
    with pytest.raises(ValidationError, match="AppearanceChange"):
        AppearanceChange(**kwargs)


def test_bad_route_size():
    with pytest.raises(ValidationError, match="n_places"):
        synthetic_traverse(0)
    with pytest.raises(ValidationError, match="height and width"):
        synthetic_traverse(5, height=4)
