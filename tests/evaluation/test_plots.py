"""PNG plots: each function writes a real PNG of the expected size."""

from __future__ import annotations

import numpy as np
import pytest
from PIL import Image

from neurovpr.errors import ValidationError
from neurovpr.evaluation.metrics import auc_roc, precision_recall, recall_at_n, roc
from neurovpr.evaluation.plots import plot_distance_matrix, plot_pr_curves, plot_recall_at_n, plot_roc_curves


def _check_png(path, width, height):
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    with Image.open(path) as img:
        assert img.size == (width, height)
        arr = np.asarray(img.convert("L"))
    assert arr.std() > 5  # something was drawn


def test_all_plots(tmp_path):
    rng = np.random.default_rng(0)
    d = rng.random((30, 30))
    d[np.arange(30), np.arange(30)] -= 0.5
    _check_png(plot_distance_matrix(d, tmp_path / "dm.png"), 550, 450)
    curve = precision_recall(d)
    _check_png(plot_pr_curves({"random": curve}, tmp_path / "pr.png"), 500, 400)
    _check_png(plot_recall_at_n({"random": recall_at_n(d, None, (1, 5, 10))}, tmp_path / "rn.png"), 500, 400)
    labels = np.r_[np.ones(10), np.zeros(10)]
    scores = np.r_[rng.random(10) + 0.3, rng.random(10)]
    fpr, tpr, _ = roc(labels, scores)
    _check_png(plot_roc_curves({"fam": (fpr, tpr, auc_roc(labels, scores))}, tmp_path / "sub" / "roc.png"), 500, 400)


def test_plot_errors(tmp_path):
    with pytest.raises(ValidationError, match=r"must end in \.png"):
        plot_distance_matrix(np.eye(3), tmp_path / "dm.jpg")
    with pytest.raises(ValidationError, match="at least one"):
        plot_pr_curves({}, tmp_path / "pr.png")
