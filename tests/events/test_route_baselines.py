"""Route-familiarity baselines (Perfect Memory, SeqSLAM) and the frames they compare."""

from __future__ import annotations

import numpy as np
import pytest
from sklearn.metrics import roc_auc_score

from neurovpr.data.events import DAVIS346_BINNING_2020, EventStream, PNSpikes, event_frames, pn_frames, read_pn_mat
from neurovpr.errors import ValidationError
from neurovpr.models.route_baselines import (
    enhance_local_contrast,
    patch_normalise,
    perfect_memory_familiarity,
    second_min_familiarity,
    seqslam_familiarity,
)


def test_pn_frames_layout_and_bins():
    # 2 rows x 3 columns: PN i sits at (i % 2, i // 2)
    spikes = PNSpikes(times_ms=[0.0, 1.0, 4.0, 9.5], idx=[0, 5, 3, 5], n_pn=6, duration_ms=10.0)
    frames = pn_frames(spikes, (2, 3), bin_ms=5.0)
    assert frames.shape == (2, 2, 3)
    assert frames[0].tolist() == [[1, 0, 0], [0, 1, 1]] and frames[1].tolist() == [[0, 0, 0], [0, 0, 1]]
    assert pn_frames(spikes, (2, 3), n_frames=10).sum(axis=(1, 2)).tolist() == [1, 1, 0, 0, 1, 0, 0, 0, 0, 1]
    with pytest.raises(ValidationError, match="grid 4x4 has 16 pixels but there are 6 PNs"):
        pn_frames(spikes, (4, 4), bin_ms=1.0)
    with pytest.raises(ValidationError, match="exactly one of"):
        pn_frames(spikes, (2, 3))


def test_event_frames():
    stream = EventStream(width=3, height=2, x=[0, 2, 2, 1], y=[0, 1, 1, 0], t=[100, 150, 900, 1100], p=[1, 0, 1, 1])
    frames = event_frames(stream, window_us=500)
    assert frames.shape == (3, 2, 3)
    assert frames[0].tolist() == [[1, 0, 0], [0, 0, 1]] and frames[1][1, 2] == 1 and frames[2][0, 1] == 1
    assert event_frames(stream, n_frames=1, polarity="off").sum() == 1


def test_patch_normalise():
    rng = np.random.default_rng(0)
    frames = rng.random((3, 10, 21)) * 50 + 7
    frames[0, :5, :5] = 4.0  # a flat tile
    out = patch_normalise(frames, 5)
    for r in range(0, 10, 5):
        for c in range(0, 21, 5):
            tile = out[1:, r : r + 5, c : c + 5]
            assert np.allclose(tile.mean(axis=(1, 2)), 0) and np.allclose(tile.std(axis=(1, 2)), 1)
    assert np.all(out[0, :5, :5] == 0)
    assert np.allclose(patch_normalise(3 * frames + 2, 5), out)  # brightness and gain do not matter


def test_second_min_normalisation():
    d = np.array([[1.0, 9, 9, 9, 9, 2.0], [5.0, 5, 5, 4, 5, 5]])
    # row 0: best 1 (column 0), second best outside +-1 columns is 2 -> 1 - 1/2
    # row 1: best 4, second best outside +-1 is 5 -> 1 - 4/5
    assert np.allclose(second_min_familiarity(d, 1), [0.5, 0.2])
    with pytest.raises(ValidationError, match="6 learned frames leave none outside the exclusion window of"):
        second_min_familiarity(d, 3)


def test_local_contrast_enhancement_ignores_row_scale():
    rng = np.random.default_rng(1)
    d = rng.random((4, 30))
    e = enhance_local_contrast(d, 10)
    assert e.min() == 0.0 and e.shape == d.shape
    assert np.allclose(enhance_local_contrast(d * np.array([[1.0], [3.0], [0.5], [10.0]]) + 7.0, 10), e)


def _synthetic_route(rng, n_places=90, shape=(10, 21), noise=0.3):
    """Two traverses of a textured route: the second darker, with noise."""
    world = rng.random((shape[0], n_places + shape[1]))
    first = np.stack([world[:, i : i + shape[1]] for i in range(n_places)])
    second = 0.6 * first + 0.1 + noise * rng.random(first.shape)
    return first, second


@pytest.mark.parametrize("method", [perfect_memory_familiarity, seqslam_familiarity])
def test_baselines_on_a_synthetic_route(method):
    first, second = _synthetic_route(np.random.default_rng(2))
    learned = slice(30, 60)
    scores = method(first[learned], second, patch=5)
    labels = np.zeros(len(second), dtype=bool)
    labels[learned] = True
    assert scores.shape == (90,) and np.all((scores >= 0) & (scores <= 1))
    assert roc_auc_score(labels, scores) > 0.95
    raw = method(first[learned], second, patch=5, normalisation="none")
    assert roc_auc_score(labels, raw) > 0.9


def test_bad_frames_are_refused():
    frames = np.zeros((5, 4, 4))
    with pytest.raises(ValidationError, match="reference frames are 4x4 but test frames are 4x5"):
        perfect_memory_familiarity(frames, np.zeros((5, 4, 5)))
    bad = frames.copy()
    bad[1, 1, 1] = np.nan
    with pytest.raises(ValidationError, match="test frames contain NaN"):
        seqslam_familiarity(frames, bad)


N_FRAMES = 100
LEARNED = (0.4, 0.6)


def _route_frames(shared_data, run):
    path = next((shared_data / "mbsnn_routes").glob(f"{run}_*.mat"))
    spikes = read_pn_mat(path, n_pn=DAVIS346_BINNING_2020.n_pn).trim_inactive()
    return pn_frames(spikes, DAVIS346_BINNING_2020.grid, n_frames=N_FRAMES)


@pytest.mark.parametrize(("learn", "test"), [("NB3", "NB4"), ("NB4", "NB3")])
def test_baselines_find_the_learned_segment_in_a_real_repeat(shared_data, learn, test):
    """Learn 40-60 % of one run's active span, score every frame of another run by normalised time."""
    reference = _route_frames(shared_data, learn)
    query = _route_frames(shared_data, test)
    lo, hi = (round(f * N_FRAMES) for f in LEARNED)
    centres = (np.arange(N_FRAMES) + 0.5) / N_FRAMES
    labels = (centres >= LEARNED[0]) & (centres < LEARNED[1])
    pm = perfect_memory_familiarity(reference[lo:hi], query, patch=5)
    seq = seqslam_familiarity(reference[lo:hi], query, patch=5)
    auc_pm, auc_seq = roc_auc_score(labels, pm), roc_auc_score(labels, seq)
    assert auc_pm > 0.85, f"Perfect Memory AUC-ROC {auc_pm:.3f}"
    assert auc_seq > 0.85, f"SeqSLAM AUC-ROC {auc_seq:.3f}"
    assert pm[labels].mean() > pm[~labels].mean() and seq[labels].mean() > seq[~labels].mean()
