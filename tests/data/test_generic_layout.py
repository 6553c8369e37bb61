"""The generic folder layout: reading, writing, ground_truth.csv, and refusals."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from neurovpr.data.generic import open_traverse, read_generic, write_generic
from neurovpr.data.ground_truth import GroundTruth
from neurovpr.data.synthetic import synthetic_traverse
from neurovpr.data.traverse import ImageSet, Traverse
from neurovpr.errors import ValidationError


def _make(root: Path, n_ref: int, n_query: int) -> Path:
    rng = np.random.default_rng(0)
    for folder, n in (("reference", n_ref), ("query", n_query)):
        (root / folder).mkdir(parents=True)
        for i in range(n):
            Image.fromarray(rng.integers(0, 256, size=(16, 24, 3), dtype=np.uint8)).save(root / folder / f"f{i:03d}.png")
    return root


def test_aligned_without_csv(tmp_path):
    root = _make(tmp_path / "set", 4, 4)
    (root / "reference" / ".DS_Store").write_text("hidden files are skipped")
    tr = open_traverse(root)
    assert tr.n_reference == 4 and tr.n_query == 4
    assert tr.ground_truth.is_aligned()
    assert tr.reference.names == ("f000.png", "f001.png", "f002.png", "f003.png")
    assert tr.query.image(2).shape == (16, 24, 3)


def test_csv_ground_truth_with_several_matches(tmp_path):
    root = _make(tmp_path / "set", 3, 2)
    (root / "ground_truth.csv").write_text("query_index,reference_index\n0,0\n0,1\n1,2\n")
    tr = read_generic(root)
    assert tr.ground_truth.matches(0).tolist() == [0, 1]
    assert tr.ground_truth.matches(1).tolist() == [2]


@pytest.mark.parametrize(
    ("setup", "needle"),
    [
        (lambda r: _make(r, 3, 2), "3 reference and 2 query images and no ground_truth.csv"),
        (lambda r: (_make(r, 2, 2) / "query" / "notes.txt").write_text("x"), "notes.txt is not an image file"),
        (lambda r: (_make(r, 2, 2) / "query" / "sub").mkdir(), "is a folder inside"),
        (lambda r: (_make(r, 2, 2) / "ground_truth.csv").write_text("0,5\n"), "line 1 has reference_index 5"),
        (lambda r: (r / "reference").mkdir(parents=True) or (r / "query").mkdir(), "holds no images"),
        (lambda r: r.mkdir(), "neither the generic layout"),
    ],
)
def test_bad_folders_fail_before_training(tmp_path, setup, needle):
    root = tmp_path / "set"
    setup(root)
    with pytest.raises(ValidationError, match=needle):
        open_traverse(root)


def test_non_image_with_image_name_is_refused_at_open(tmp_path):
    root = _make(tmp_path / "set", 2, 2)
    (root / "query" / "f001.png").write_text("not a png")
    with pytest.raises(ValidationError, match=r"f001\.png is not a readable image"):
        open_traverse(root)  # every header is read at open, so train refuses it before any work


def test_write_and_read_back_synthetic(tmp_path):
    tr = synthetic_traverse(12, seed=3)
    out = write_generic(tr, tmp_path / "synth")
    back = open_traverse(out)
    assert back.n_reference == 12 and back.ground_truth.is_aligned()
    assert not (out / "ground_truth.csv").exists()
    for i in (0, 11):
        np.testing.assert_array_equal(back.reference.image(i), tr.reference.image(i))
        np.testing.assert_array_equal(back.query.image(i), tr.query.image(i))
    with pytest.raises(ValidationError, match="already exists"):
        write_generic(tr, out)
    write_generic(tr, out, overwrite=True)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["synth"]  # no temporary folder left


def test_write_keeps_a_non_aligned_ground_truth(tmp_path):
    rng = np.random.default_rng(1)
    tr = Traverse(
        name="t",
        references=(ImageSet(name="r", array=rng.integers(0, 256, size=(3, 8, 8), dtype=np.uint8)),),
        query=ImageSet(name="q", array=rng.integers(0, 256, size=(2, 8, 8), dtype=np.uint8)),
        ground_truth=GroundTruth.from_pairs([(0, 2), (1, 0), (1, 1)], 3, 2),
    )
    out = write_generic(tr, tmp_path / "gt")
    assert (out / "ground_truth.csv").read_text().splitlines() == ["query_index,reference_index", "0,2", "1,0", "1,1"]
    assert np.array_equal(open_traverse(out).ground_truth.matrix, tr.ground_truth.matrix)
