"""SAD and Perfect Memory baselines against direct computations."""

from __future__ import annotations

import numpy as np
import pytest

from neurovpr.data.ground_truth import GroundTruth
from neurovpr.data.preprocess import preprocess_images
from neurovpr.data.traverse import ImageSet, Traverse
from neurovpr.errors import ValidationError
from neurovpr.models.baselines import perfect_memory_distances, sad_distances


def _stacks():
    rng = np.random.default_rng(0)
    return rng.integers(0, 256, size=(6, 32, 48, 3), dtype=np.uint8), rng.integers(0, 256, size=(4, 32, 48, 3), dtype=np.uint8)


def test_sad_is_sum_of_absolute_differences_of_preprocessed_images():
    ref, qry = _stacks()
    d = sad_distances(ref, qry)
    pr = preprocess_images(ref).astype(float).reshape(6, -1)
    pq = preprocess_images(qry).astype(float).reshape(4, -1)
    assert d.shape == (6, 4)
    assert d[2, 3] == np.abs(pr[2] - pq[3]).sum()
    np.testing.assert_array_equal(d, np.abs(pr[:, None] - pq[None]).sum(-1))


def test_perfect_memory_is_sum_of_squared_differences():
    ref, qry = _stacks()
    d = perfect_memory_distances(ref, qry)
    pr = preprocess_images(ref).astype(float).reshape(6, -1)
    pq = preprocess_images(qry).astype(float).reshape(4, -1)
    np.testing.assert_array_equal(d, ((pr[:, None] - pq[None]) ** 2).sum(-1))  # exact in float64


def test_unpreprocessed_features_and_identical_images():
    feats = np.array([[0.0, 1.0], [2.0, 2.0]])
    assert sad_distances(feats, feats, preprocess=False).tolist() == [[0.0, 3.0], [3.0, 0.0]]
    assert perfect_memory_distances(feats, feats, preprocess=False).tolist() == [[0.0, 5.0], [5.0, 0.0]]


def test_traverse_with_two_references_keeps_the_closer():
    ref, qry = _stacks()
    other = ref[::-1].copy()
    tr = Traverse(
        name="t",
        references=(ImageSet(name="a", array=ref[:4]), ImageSet(name="b", array=other[:4])),
        query=ImageSet(name="q", array=qry),
        ground_truth=GroundTruth.aligned(4),
    )
    expected = np.minimum(sad_distances(ref[:4], qry), sad_distances(other[:4], qry))
    np.testing.assert_array_equal(sad_distances(tr), expected)
    expected_pm = np.minimum(perfect_memory_distances(ref[:4], qry), perfect_memory_distances(other[:4], qry))
    np.testing.assert_array_equal(perfect_memory_distances(tr), expected_pm)


def test_baseline_errors():
    with pytest.raises(ValidationError, match="same size"):
        sad_distances(np.zeros((2, 4)), np.zeros((2, 5)), preprocess=False)
    with pytest.raises(ValidationError, match="needs query images"):
        perfect_memory_distances(np.zeros((2, 4)), preprocess=False)
    with pytest.raises(ValidationError, match="non-empty stack"):
        sad_distances(np.zeros((0, 4)), np.zeros((2, 4)), preprocess=False)
