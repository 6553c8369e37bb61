"""The concentration of best matches (``neurovpr.evaluation.concentration``)."""

from __future__ import annotations

import numpy as np
import pytest

import neurovpr as nv
from neurovpr.evaluation import match_concentration


def test_spread_matches_give_the_top_fraction() -> None:
    d = 1.0 - np.eye(100)  # every query closest to its own place
    c = match_concentration(d)
    assert c == {"queries": 100, "distinct_best_matches": 100, "top_fraction": 0.02, "top_places": 2, "top_share": 0.02}


def test_matches_piled_on_few_places() -> None:
    rng = np.random.default_rng(0)
    d = rng.uniform(1.0, 2.0, size=(50, 40))
    d[3, :30] = 0.0  # 30 queries go to place 3
    d[7, 30:36] = 0.0  # 6 to place 7
    c = match_concentration(d)
    assert c["top_places"] == 1 and c["top_share"] == pytest.approx(30 / 40)
    assert c["distinct_best_matches"] <= 2 + 4
    wider = match_concentration(d, top_fraction=0.04)
    assert wider["top_places"] == 2 and wider["top_share"] == pytest.approx(36 / 40)


def test_ties_go_to_the_lowest_index_and_bad_fractions_are_refused() -> None:
    c = match_concentration(np.zeros((10, 5)))  # every query ties: all go to place 0
    assert c["distinct_best_matches"] == 1 and c["top_share"] == 1.0
    for bad in (0.0, 1.5, float("nan")):
        with pytest.raises(nv.ValidationError, match="top_fraction"):
            match_concentration(np.zeros((10, 5)), top_fraction=bad)
