"""Download helpers: the registry's checksums are those of the real files; nothing is downloaded."""

from __future__ import annotations

import hashlib
from pathlib import Path

import pytest

from neurovpr.data import download, published
from neurovpr.errors import ValidationError


def test_registry_checksums_match_the_shared_copies(shared_data: Path):
    lists = shared_data / "vprsnn_lists"
    if not lists.is_dir():
        pytest.skip("vprsnn_lists not in the shared data folder")
    for rel, sha in download.VPRSNN_FILES.items():
        assert hashlib.sha256((lists / rel).read_bytes()).hexdigest() == sha, rel


def test_registry_covers_every_list_a_loader_reads():
    needed = {f"dataset_imagenames/{f}" for d in published.DATASETS.values() for f in (*d.reference_lists, d.query_list)}
    needed |= {f"dataset_gt_files/{d.gt_file}" for d in published.DATASETS.values() if d.gt_file}
    assert needed <= set(download.VPRSNN_FILES)


def test_fetch_refuses_a_download_without_checksum(tmp_path):
    with pytest.raises(ValidationError, match="needs a checksum"):
        download.fetch("https://example.org/data.zip", "", tmp_path)
