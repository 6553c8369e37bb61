"""Traverse and ImageSet: every unusable combination is one ValidationError before any training."""

from __future__ import annotations

import numpy as np
import pytest

from neurovpr.data.ground_truth import GroundTruth
from neurovpr.data.traverse import ImageSet, Traverse
from neurovpr.errors import ValidationError


def _set(n: int, name: str = "s") -> ImageSet:
    return ImageSet(name=name, array=np.random.default_rng(n).integers(0, 256, size=(n, 32, 32), dtype=np.uint8))


def test_valid_traverse_and_subset():
    tr = Traverse(
        name="t",
        references=(_set(5, "a"), _set(5, "b")),
        query=_set(4, "q"),
        ground_truth=GroundTruth.from_pairs([(0, 0), (1, 1), (2, 2), (3, 4)], 5, 4),
    )
    assert tr.n_reference == 5 and tr.n_query == 4
    sub = tr.subset([0, 4], [3])
    assert sub.ground_truth.matrix.tolist() == [[False], [True]]
    np.testing.assert_array_equal(sub.references[1].image(1), tr.references[1].image(4))
    first = tr.first(3)
    assert first.ground_truth.is_aligned()
    assert first.query.names == ("00000", "00001", "00002")


@pytest.mark.parametrize(
    ("build", "needle"),
    [
        (lambda: Traverse(name="t", references=(), query=_set(3), ground_truth=GroundTruth.aligned(3)), "no reference image set"),
        (
            lambda: Traverse(name="t", references=(_set(3), _set(4)), query=_set(3), ground_truth=GroundTruth.aligned(3)),
            "has 4 images but",
        ),
        (
            lambda: Traverse(name="t", references=(_set(3),), query=_set(4), ground_truth=GroundTruth.aligned(3)),
            r"ground truth has shape \(3, 3\)",
        ),
        (
            lambda: Traverse(
                name="t", references=(_set(3),), query=_set(3), ground_truth=GroundTruth(matrix=np.zeros((3, 3), dtype=bool))
            ),
            "gives no query a matching reference",
        ),
        (lambda: ImageSet(name="e", array=np.zeros((0, 8, 8))), "non-empty stack"),
        (lambda: ImageSet(name="e", paths=()), "is empty"),
        (lambda: ImageSet(name="e", paths=("does/not/exist.png",)), "1 missing file"),
        (lambda: ImageSet(name="e", array=np.full((2, 8, 8), np.nan)), "NaN or infinite"),
        (lambda: ImageSet(name="e", array=np.zeros((2, 8, 8, 7))), "7 channels"),
        (lambda: ImageSet(name="e"), "exactly one of paths or array"),
    ],
)
def test_unusable_sets_fail_with_one_sentence(build, needle):
    with pytest.raises(ValidationError, match=needle) as info:
        build()
    message = info.value.args[0]
    assert message.endswith(".") and message.count(". ") == 0


def test_first_refuses_too_many_places():
    tr = Traverse(name="t", references=(_set(3),), query=_set(3), ground_truth=GroundTruth.aligned(3))
    with pytest.raises(ValidationError, match="first 4 places"):
        tr.first(4)
