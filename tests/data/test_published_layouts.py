"""Published layouts, checked against the VPRSNN image-name lists in the shared data folder."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from neurovpr.data import published
from neurovpr.data.generic import open_traverse
from neurovpr.errors import ValidationError


@pytest.fixture(scope="module")
def lists(shared_data: Path) -> Path:
    path = shared_data / "vprsnn_lists"
    if not (path / "dataset_imagenames").is_dir():
        pytest.skip("vprsnn_lists not in the shared data folder")
    return path


EXPECTED = {
    # name: (reference traverses, n_ref, n_query, first reference path, last query path)
    "nordland-sfs": (2, 3300, 3300, "./nordland/spring/images-00202.png", None),
    "nordland-sfw": (2, 3300, 3300, "./nordland/spring/images-00202.png", None),
    "orc": (2, 450, 450, "./ORC/Sun/000000.png", None),
    "sfu-mountain": (
        1,
        375,
        375,
        "./SFU-Mountain/part_a/stereo_right/dry/frames/a001.jpg",
        "./SFU-Mountain/part_b/stereo_right/dusk/frames/b136.jpg",
    ),
    "synthia": (1, 250, 250, "./Synthia-NightToFall/ref/0000.jpg", "./Synthia-NightToFall/query/0812.jpg"),
    "st-lucia": (1, 500, 1037, "St-Lucia/190809_0845/0000037.png", "St-Lucia/180809_1545/0021327.png"),
}


@pytest.mark.parametrize("name", sorted(EXPECTED))
def test_selected_frames_follow_vprsnn(lists, name):
    n_refs, n_ref, n_query, first_ref, last_query = EXPECTED[name]
    refs, query = published.published_paths(name, lists)
    assert len(refs) == n_refs
    assert all(len(r) == n_ref for r in refs)
    assert len(query) == n_query
    assert refs[0][0] == first_ref
    if last_query is not None:
        assert query[-1] == last_query
    spec = published.DATASETS[name]
    raw = (lists / "dataset_imagenames" / spec.query_list).read_text().splitlines()
    assert query == [line.strip() for line in raw[:: spec.skip][:n_query]]


def test_nordland_every_eighth_frame(lists):
    refs, query = published.published_paths("nordland-sfw", lists)
    # the filtered list starts at images-00202; line 8 of it is the second kept frame
    raw = (lists / "dataset_imagenames" / "nordland_imageNames_winter.txt").read_text().splitlines()
    assert query[:2] == [raw[0], raw[8]]
    assert query[0] == "./nordland/winter/images-00202.png"
    assert [Path(a).name for a in refs[0]] == [Path(b).name for b in refs[1]] == [Path(q).name for q in query]


def test_st_lucia_ground_truth_matrix(lists):
    gt = published._ground_truth(published.DATASETS["st-lucia"], lists, 500, 1037)
    assert gt.shape == (500, 1037)
    assert (gt.matrix.sum(axis=0) == 1).all()  # one match per query, marked 0 in the file
    raw = np.load(lists / "dataset_gt_files" / "St_Lucia_gt_boolean_matrix.npy")
    assert np.array_equal(gt.matrix, raw == 0)


def test_orc_original_names(lists):
    mapping = published.orc_original_names(lists, "Dusk")
    assert len(mapping) == 3876
    assert mapping["000000.png"] == "1416586027583964.png"


def _fake_root(tmp_path: Path, lists: Path, name: str, n: int) -> Path:
    root = tmp_path / "data"
    refs, query = published.published_paths(name, lists, n_places=n)
    rng = np.random.default_rng(0)
    for entry in [*(e for r in refs for e in r), *query]:
        path = root / (entry[2:] if entry.startswith("./") else entry)
        path.parent.mkdir(parents=True, exist_ok=True)
        Image.fromarray(rng.integers(0, 256, size=(30, 40, 3), dtype=np.uint8)).save(path, format="PNG")
    return root


def test_load_synthia_from_a_layout_on_disk(tmp_path, lists):
    root = _fake_root(tmp_path, lists, "synthia", 6)
    assert published.detect(root) == ["synthia"]
    tr = open_traverse(root, lists=lists, n_places=6)
    assert tr.name == "synthia" and tr.n_reference == 6 and tr.n_query == 6
    assert tr.ground_truth.is_aligned()
    assert tr.query.names[:4] == ("0000.jpg", "0006.jpg", "0009.jpg", "0011.jpg")
    assert tr.reference.paths[0] == root / "Synthia-NightToFall" / "ref" / "0000.jpg"
    assert tr.query.preprocessed().shape == (6, 28, 28)


def test_load_st_lucia_subset_keeps_gt_matrix(tmp_path, lists):
    root = _fake_root(tmp_path, lists, "st-lucia", 40)
    tr = published.load_published("st-lucia", root, lists=lists, n_places=40)
    full = published._ground_truth(published.DATASETS["st-lucia"], lists, 500, 1037)
    assert np.array_equal(tr.ground_truth.matrix, full.matrix[:40, :40])


def test_missing_images_and_lists_are_clear_errors(tmp_path, lists):
    root = tmp_path / "data"
    (root / "ORC").mkdir(parents=True)
    with pytest.raises(ValidationError, match="missing file"):
        open_traverse(root, lists=lists)
    with pytest.raises(ValidationError, match="no dataset_imagenames/ folder"):
        published.load_published("orc", root, lists=tmp_path / "nowhere")
    with pytest.raises(ValidationError, match="unknown published dataset"):
        published.load_published("kitti", root, lists=lists)


def test_ambiguous_nordland_root_needs_a_choice(tmp_path):
    for season in ("summer", "winter"):
        (tmp_path / "nordland" / season).mkdir(parents=True)
    assert published.detect(tmp_path) == ["nordland-sfs", "nordland-sfw"]
    with pytest.raises(ValidationError, match="several published datasets"):
        open_traverse(tmp_path)
