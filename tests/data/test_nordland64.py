"""Real data: the shared nordland64 set (summer reference, winter query) with the baselines."""

from __future__ import annotations

from pathlib import Path

import pytest

from neurovpr.data.generic import open_traverse
from neurovpr.data.traverse import Traverse
from neurovpr.evaluation.metrics import recall_at_n
from neurovpr.models.baselines import perfect_memory_distances, sad_distances


@pytest.fixture(scope="module")
def nordland64(shared_data: Path) -> Traverse:
    path = shared_data / "nordland64"
    if not path.is_dir():
        pytest.skip("nordland64 not in the shared data folder")
    return open_traverse(path)


def test_loads_2400_aligned_pairs(nordland64):
    assert nordland64.n_reference == 2400 and nordland64.n_query == 2400
    assert nordland64.ground_truth.is_aligned()
    assert nordland64.reference.names[0] == "images-00010.png"
    assert nordland64.query.names[-1] == "images-24000.png"
    assert nordland64.reference.image(0).shape == (32, 64, 3)


def test_sad_on_first_100_places(nordland64):
    first = nordland64.first(100)
    r = recall_at_n(sad_distances(first), first.ground_truth, (1, 5))
    # measured: R@1 = 0.10, R@5 = 0.14 (summer -> winter, zero tolerance; chance is 0.01)
    assert r[1] == pytest.approx(0.10, abs=0.02)
    assert r[5] == pytest.approx(0.14, abs=0.02)


@pytest.mark.slow
def test_baselines_on_all_2400_places(nordland64):
    ref = nordland64.reference.preprocessed(progress=True)
    qry = nordland64.query.preprocessed(progress=True)
    sad = recall_at_n(sad_distances(ref, qry, preprocess=False), None, (1, 5))
    pm = recall_at_n(perfect_memory_distances(ref, qry, preprocess=False), None, (1, 5))
    # measured: SAD R@1 0.188 R@5 0.239; Perfect Memory R@1 0.021 R@5 0.024 (SSD is dominated by
    # low-texture "hub" references such as the blank station frames, which SAD tolerates)
    assert sad[1] == pytest.approx(0.188, abs=0.01) and sad[5] == pytest.approx(0.239, abs=0.01)
    assert pm[1] == pytest.approx(0.022, abs=0.01) and pm[5] == pytest.approx(0.024, abs=0.01)
