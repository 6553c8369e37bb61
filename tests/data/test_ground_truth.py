"""Ground truth: every way of building it, widening by a tolerance, and the CSV file."""

from __future__ import annotations

import numpy as np
import pytest

from neurovpr.data.ground_truth import GroundTruth, read_pairs_csv
from neurovpr.errors import ValidationError


def test_aligned_is_identity():
    gt = GroundTruth.aligned(4)
    assert gt.shape == (4, 4)
    assert gt.is_aligned()
    assert gt.matches(2).tolist() == [2]
    assert not gt.matrix.flags.writeable


def test_from_matrix_match_value_zero_like_st_lucia():
    raw = np.array([[0, 1, 1], [1, 0, 0]])
    gt = GroundTruth.from_matrix(raw, match_value=0)
    assert gt.matrix.tolist() == [[True, False, False], [False, True, True]]
    assert gt.matches(2).tolist() == [1]


def test_from_pairs_several_per_query_and_pairs_roundtrip():
    gt = GroundTruth.from_pairs([(0, 1), (0, 2), (2, 0)], n_reference=3, n_query=3)
    assert gt.matches(0).tolist() == [1, 2]
    assert gt.matches(1).tolist() == []
    assert gt.has_match().tolist() == [True, False, True]
    assert gt.pairs().tolist() == [[0, 1], [0, 2], [2, 0]]


def test_from_positions_with_tolerance():
    ref = np.array([[0.0, 0.0], [10.0, 0.0], [20.0, 0.0]])
    qry = np.array([[1.0, 0.0], [15.0, 0.0], [40.0, 0.0]])
    gt = GroundTruth.from_positions(ref, qry, tolerance=5.0)
    # query 0 is 1 m from ref 0; query 1 is exactly 5 m from refs 1 and 2; query 2 is far from all
    assert gt.matrix.T.tolist() == [[True, False, False], [False, True, True], [False, False, False]]


def test_with_tolerance_widens_along_references():
    gt = GroundTruth.aligned(5).with_tolerance(1)
    assert gt.matches(0).tolist() == [0, 1]
    assert gt.matches(2).tolist() == [1, 2, 3]
    assert gt.matches(4).tolist() == [3, 4]
    assert GroundTruth.aligned(3).with_tolerance(0).is_aligned()


@pytest.mark.parametrize(
    "build",
    [
        lambda: GroundTruth(matrix=np.zeros((0, 3), dtype=bool)),
        lambda: GroundTruth(matrix=np.zeros(3, dtype=bool)),
        lambda: GroundTruth(matrix=np.zeros((2, 2))),
        lambda: GroundTruth.from_pairs([(3, 0)], 2, 3),
        lambda: GroundTruth.from_pairs([(0, -1)], 2, 3),
        lambda: GroundTruth.from_positions(np.zeros((2, 2)), np.zeros((2, 3)), 1.0),
        lambda: GroundTruth.from_positions(np.zeros((2, 2)), np.zeros((2, 2)), -1.0),
        lambda: GroundTruth.aligned(3).with_tolerance(-1),
    ],
)
def test_bad_ground_truth_is_one_clear_error(build):
    with pytest.raises(ValidationError) as info:
        build()
    assert info.value.args[0].count(". ") == 0  # one sentence


def test_read_pairs_csv_header_comments_and_values(tmp_path):
    path = tmp_path / "ground_truth.csv"
    path.write_text("query_index,reference_index\n# a comment\n0,1\n\n0,2\n2, 0\n")
    gt = read_pairs_csv(path, n_reference=3, n_query=3)
    assert gt.pairs().tolist() == [[0, 1], [0, 2], [2, 0]]


@pytest.mark.parametrize(
    ("text", "needle"),
    [
        ("0,1\n5,0\n", "line 2 has query_index 5"),
        ("0,7\n", "line 1 has reference_index 7"),
        ("0;1\n", "line 1 is '0;1'"),
        ("a,b\n", "line 1 is 'a,b'"),
        ("# only a comment\n", "lists no query_index,reference_index pairs"),
    ],
)
def test_read_pairs_csv_errors_name_the_line(tmp_path, text, needle):
    path = tmp_path / "ground_truth.csv"
    path.write_text(text)
    with pytest.raises(ValidationError, match=needle):
        read_pairs_csv(path, n_reference=3, n_query=3)
