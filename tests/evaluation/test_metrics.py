"""Metrics on hand-made matrices with hand-computed answers, and against scikit-learn."""

from __future__ import annotations

import numpy as np
import pytest
import sklearn.metrics as skm

from neurovpr.data.ground_truth import GroundTruth
from neurovpr.errors import ValidationError
from neurovpr.evaluation.metrics import (
    auc_roc,
    best_matches,
    correct_match_sparsity,
    correct_top1,
    distance_from_similarity,
    evaluate,
    precision_recall,
    recall_at_n,
    roc,
)

# [reference, query]: query 0 -> ref 0 (rank 0), query 1 -> ref 1 (rank 1),
# query 2 -> ref 2 (rank 2), query 3 -> ref 3 (rank 0, but ref 2 is one index away)
D = np.array(
    [
        [0.1, 0.4, 0.9, 0.8],
        [0.5, 0.3, 0.3, 0.9],
        [0.6, 0.1, 0.6, 0.5],
        [0.7, 0.9, 0.4, 0.2],
    ]
)


def test_recall_at_n_hand_matrix():
    assert recall_at_n(D, None, (1, 2, 3, 4)) == {1: 0.5, 2: 0.75, 3: 1.0, 4: 1.0}


def test_recall_with_tolerance():
    # with 1 frame tolerance query 1's best (ref 2) and query 2's best (ref 1) count as correct
    assert recall_at_n(D, None, (1,), tolerance=1) == {1: 1.0}


def test_recall_with_gt_matrix_several_matches_and_unmatched_queries():
    gt = np.zeros((4, 4), dtype=bool)
    gt[[0, 2], 0] = True  # query 0 matches refs 0 and 2
    gt[3, 1] = True  # query 1 matches ref 3 only: rank 3
    gt[2, 2] = True
    # query 3 has no match: left out of the denominator
    assert recall_at_n(D, gt, (1, 3, 4)) == {1: 1 / 3, 3: 2 / 3, 4: 1.0}
    assert recall_at_n(D, GroundTruth(matrix=gt), (1,)) == {1: 1 / 3}


def test_recall_with_index_ground_truth():
    assert recall_at_n(D, np.array([0, 2, 1, 3]), (1,)) == {1: 1.0}


def test_ties_index_vs_pessimistic():
    d = np.array([[1.0, 0.0], [1.0, 0.0]])  # every distance tied in each column
    assert recall_at_n(d, None, (1, 2)) == {1: 0.5, 2: 1.0}  # lower index wins: query 0 correct
    assert recall_at_n(d, None, (1, 2), ties="pessimistic") == {1: 0.0, 2: 1.0}


def test_best_matches_and_correct_top1():
    idx, dist = best_matches(D)
    assert idx.tolist() == [0, 2, 1, 3]
    assert dist.tolist() == [0.1, 0.1, 0.3, 0.2]
    assert correct_top1(D).tolist() == [True, False, False, True]


def test_precision_recall_hand_example():
    # best distances 0.1, 0.2, 0.3, 0.4 with correctness 1, 0, 1, 1; a rejected query is a false negative
    d = np.array([[0.1, 0.9, 0.9, 0.9], [0.9, 0.9, 0.9, 0.4], [0.9, 0.2, 0.3, 0.9], [0.9, 0.9, 0.9, 0.9]])
    gt = np.eye(4, dtype=bool)
    gt[3, 3], gt[1, 3] = False, True  # query 3 matches ref 1, its best
    curve = precision_recall(d, gt)
    np.testing.assert_allclose(curve.precision, [1.0, 1.0, 0.5, 2 / 3, 0.75])
    np.testing.assert_allclose(curve.recall, [0.0, 0.25, 1 / 3, 2 / 3, 1.0])
    np.testing.assert_allclose(curve.thresholds, [0.1, 0.2, 0.3, 0.4])
    assert curve.precision_at_100_recall == pytest.approx(0.75)  # = R@1
    assert curve.recall_at_100_precision == pytest.approx(0.25)
    assert curve.auc == pytest.approx(0.25 + 0.75 / 12 + (0.5 + 2 / 3) / 6 + (2 / 3 + 0.75) / 6)
    assert curve.auc == pytest.approx(skm.auc(curve.recall, curve.precision))


def test_precision_recall_ties_accept_together():
    # queries 0 and 1 share the best distance 0.2: one threshold accepts both
    d = np.array([[0.2, 0.5, 0.9], [0.5, 0.9, 0.9], [0.9, 0.2, 0.4]])
    curve = precision_recall(d)  # query 1's best is ref 2 (wrong); query 2's best is ref 2 (right)
    np.testing.assert_allclose(curve.precision, [1.0, 0.5, 2 / 3])
    np.testing.assert_allclose(curve.recall, [0.0, 0.5, 1.0])


def test_precision_recall_random_p100r_equals_r1():
    rng = np.random.default_rng(0)
    d = rng.random((50, 40))
    d[np.arange(40), np.arange(40)] -= rng.random(40) * 0.8  # make about half the queries correct
    curve = precision_recall(d, np.eye(50, 40, dtype=bool))
    idx, best = best_matches(d)
    y = idx == np.arange(40)
    assert 0 < y.sum() < 40
    assert curve.precision_at_100_recall == pytest.approx(y.mean())
    assert curve.precision_at_100_recall == pytest.approx(recall_at_n(d, np.eye(50, 40, dtype=bool), (1,))[1])
    assert np.all(np.diff(curve.recall) >= 0) and curve.recall[-1] == 1.0
    # brute force: every threshold from the definition
    for t, p, r in zip(curve.thresholds, curve.precision[1:], curve.recall[1:], strict=True):
        acc = best <= t
        tp, fp, fn = np.sum(acc & y), np.sum(acc & ~y), np.sum(~acc)
        assert p == pytest.approx(tp / (tp + fp)) and r == pytest.approx(tp / (tp + fn))


def test_no_correct_match_gives_zero_curve():
    d = np.array([[1.0, 0.0], [0.0, 1.0]])
    curve = precision_recall(d)
    assert curve.auc == 0.0 and curve.precision_at_100_recall == 0.0


def test_roc_and_auc_roc():
    labels = np.array([1, 1, 0, 0])
    scores = np.array([0.9, 0.4, 0.5, 0.1])
    assert auc_roc(labels, scores) == pytest.approx(0.75)
    fpr, tpr, _ = roc(labels, scores)
    assert skm.auc(fpr, tpr) == pytest.approx(0.75)
    with pytest.raises(ValidationError, match="both positive and negative"):
        auc_roc(np.ones(3), np.arange(3.0))


def test_distance_from_similarity():
    s = np.array([[3.0, 0.0], [1.0, 2.0]])
    assert distance_from_similarity(s).tolist() == [[0.0, 3.0], [2.0, 1.0]]


def test_correct_match_sparsity_values():
    # query 0: one reference holds all similarity (Hoyer 1); query 1: uniform (Hoyer 0)
    s = np.array([[4.0, 2.0], [0.0, 2.0], [0.0, 2.0], [0.0, 2.0]])
    d = distance_from_similarity(s)
    gt = np.zeros((4, 2), dtype=bool)
    gt[0, 0] = gt[1, 1] = True
    out = correct_match_sparsity(d, gt)
    np.testing.assert_allclose(out["per_query"], [1.0, 0.0])
    assert out["correct"].tolist() == [1.0, 0.0]  # query 1's tie goes to ref 0, which is wrong
    assert out["sparsity_correct"] == 1.0 and out["sparsity_incorrect"] == 0.0
    assert out["sparsity_all"] == 0.5
    # a half-concentrated column: s = (1, 1, 0, 0) -> (2 - 2/sqrt(2)) / (2 - 1)
    d2 = distance_from_similarity(np.array([[1.0], [1.0], [0.0], [0.0]]))
    assert correct_match_sparsity(d2, np.array([[True], [False], [False], [False]]))["per_query"][0] == (
        pytest.approx(2 - np.sqrt(2))
    )


def test_evaluate_keys():
    out = evaluate(D)
    assert set(out) == {"R@1", "R@5", "R@10", "P@100R", "R@100P", "AUC_PR"}
    assert out["R@1"] == 0.5


@pytest.mark.parametrize(
    ("call", "needle"),
    [
        (lambda: recall_at_n(np.array([1.0, 2.0])), "2-D"),
        (lambda: recall_at_n(np.array([[np.nan]])), "NaN"),
        (lambda: recall_at_n(np.zeros((3, 4))), "3 x 4"),
        (lambda: recall_at_n(np.zeros((3, 3)), np.eye(4, dtype=bool)), r"shape \(4, 4\)"),
        (lambda: recall_at_n(np.zeros((2, 2)), np.zeros((2, 2), dtype=bool)), "at least one query"),
        (lambda: recall_at_n(np.zeros((2, 2)), None, (0,)), "N values >= 1"),
        (lambda: recall_at_n(np.zeros((2, 2)), np.eye(2)), "must be boolean"),
        (lambda: recall_at_n(np.zeros((2, 2)), None, ties="random"), "ties must be"),
    ],
)
def test_bad_metric_input(call, needle):
    with pytest.raises(ValidationError, match=needle):
        call()
