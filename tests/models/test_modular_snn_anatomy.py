"""Modular SNN: the neurons behind each place's score and behind the most-chosen places (analytic cases)."""

from __future__ import annotations

import math

import numpy as np
import pytest

import neurovpr as nv
from neurovpr.models.modular_snn import hub_anatomy, place_anatomy

# module A: places 0 and 1; neuron 1 (50 images) and the unassigned neuron 3 are hyperactive at 40
# module B: place 2; neuron 2 (60 images) is hyperactive; place 3 has no neuron
MODULES = [
    (np.array([0, 0, 1, -1]), np.array([10, 50, 5, 99])),
    (np.array([2, 2, 2]), np.array([1, 2, 60])),
]


def test_place_anatomy_counts_assigned_and_kept_neurons_and_their_activity() -> None:
    a = place_anatomy(MODULES, 40, 4)
    np.testing.assert_array_equal(a["assigned"], [2, 1, 3, 0])
    np.testing.assert_array_equal(a["kept"], [1, 1, 2, 0])
    np.testing.assert_array_equal(a["kept_activity"][:3], [10.0, 5.0, 1.5])
    assert math.isnan(a["kept_activity"][3])
    # threshold 0 marks no neuron hyperactive, as the code does
    b = place_anatomy(MODULES, 0, 4)
    np.testing.assert_array_equal(b["kept"], b["assigned"])
    np.testing.assert_allclose(b["kept_activity"][:3], [30.0, 5.0, 21.0])


def test_place_anatomy_refuses_mismatched_inputs() -> None:
    with pytest.raises(nv.ValidationError, match="activity of shape"):
        place_anatomy([(np.array([0, 1]), np.array([1, 2, 3]))], 0, 2)
    with pytest.raises(nv.ValidationError, match="beyond 2 places"):
        place_anatomy([(np.array([0, 2]), np.array([1, 2]))], 0, 2)


def test_hub_anatomy_of_the_most_chosen_place() -> None:
    anatomy = place_anatomy(MODULES, 40, 4)
    # best matches of the five queries: places 2, 2, 2, 0, 1 (distances: 0 at the best match, 1 elsewhere)
    d = np.ones((4, 5))
    for q, p in enumerate([2, 2, 2, 0, 1]):
        d[p, q] = 0.0
    h = hub_anatomy(d, anatomy, top_fraction=0.25)
    assert h["top_places"] == 1 and h["top_share"] == pytest.approx(0.6)
    assert h["top"] == {"assigned": 3.0, "kept_share": pytest.approx(2 / 3), "kept_activity": 1.5}
    # means over the places with neurons (kept share) or with kept neurons (activity)
    assert h["all"]["assigned"] == 1.5
    assert h["all"]["kept_share"] == pytest.approx((0.5 + 1 + 2 / 3) / 3)
    assert h["all"]["kept_activity"] == pytest.approx((10 + 5 + 1.5) / 3)
    # wins 1, 1, 3 (place 3: no neurons, left out) against kept shares 0.5, 1, 2/3: ranks (1.5, 1.5, 3) and
    # (1, 3, 2), covariance 0; against kept activity 10, 5, 1.5: ranks (3, 2, 1), rho = -1.5 / sqrt(1.5 * 2)
    rho = h["spearman_wins_vs"]
    assert rho["kept_share"] == pytest.approx(0.0, abs=1e-12)
    assert rho["kept_activity"] == pytest.approx(-1.5 / math.sqrt(3))
    # mean similarity (minus mean distance): place 2 highest, places 0 and 1 tied, place 3 lowest, as the wins
    assert rho["mean_similarity"] == pytest.approx(1.0)


def test_hub_anatomy_refuses_mismatched_inputs() -> None:
    anatomy = place_anatomy(MODULES, 40, 4)
    with pytest.raises(nv.ValidationError, match="assigned has shape"):
        hub_anatomy(np.ones((3, 5)), anatomy)
    with pytest.raises(nv.ValidationError, match="top_fraction"):
        hub_anatomy(np.ones((4, 5)), anatomy, top_fraction=0)
