"""Dataset files: oversized, empty, tiny and odd-sized images and malformed ground truth are refused or warned about at open."""

from __future__ import annotations

import struct
import zlib
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from neurovpr.data.ground_truth import read_pairs_csv
from neurovpr.data.images import read_image
from neurovpr.data.traverse import ImageSet
from neurovpr.errors import ValidationError


def _png_header_only(path: Path, width: int, height: int) -> None:
    """A PNG whose header declares ``width x height`` (a decompression bomb's header; no pixel data)."""

    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))

    ihdr = struct.pack(">IIBBBBB", width, height, 8, 0, 0, 0, 0)
    path.write_bytes(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", zlib.compress(b"")) + chunk(b"IEND", b""))


def _images(folder: Path, sizes: list[tuple[int, int]]) -> list[Path]:
    folder.mkdir(parents=True, exist_ok=True)
    paths = []
    for i, (w, h) in enumerate(sizes):
        path = folder / f"{i:03d}.png"
        Image.fromarray(np.full((h, w), 100 + i, dtype=np.uint8)).save(path)
        paths.append(path)
    return paths


def test_bomb_empty_and_tiny_images_are_refused_at_open(tmp_path: Path) -> None:
    paths = _images(tmp_path / "q", [(64, 32)] * 3)
    _png_header_only(paths[1], 15000, 15000)
    with pytest.raises(ValidationError, match=r"001.png declares more than the limit of 89478485 pixels per image"):
        ImageSet(name="query", paths=tuple(paths))
    _png_header_only(paths[1], 10000, 10000)  # past the limit, below Pillow's own refusal
    with pytest.raises(ValidationError, match=r"001.png is 10000x10000 pixels \(100000000\), more than the limit of 89478485"):
        ImageSet(name="query", paths=tuple(paths))
    _png_header_only(paths[1], 15000, 15000)
    with pytest.raises(ValidationError, match=r"more than the limit"):
        read_image(paths[1])
    paths[1].write_bytes(b"")
    with pytest.raises(ValidationError, match=r"001.png is empty \(0 bytes\)"):
        ImageSet(name="query", paths=tuple(paths))
    Image.fromarray(np.zeros((1, 1), dtype=np.uint8)).save(paths[1])
    with pytest.raises(ValidationError, match=r"001.png is 1x1 pixels; an image needs at least 2x2 pixels"):
        ImageSet(name="query", paths=tuple(paths))


def test_odd_sized_image_is_warned_about(tmp_path: Path) -> None:
    paths = _images(tmp_path / "q", [(64, 32), (64, 32), (100, 50)])
    with pytest.warns(UserWarning, match=r"002.png is 100x50 pixels, .*000.png is 64x32"):
        ImageSet(name="query", paths=tuple(paths))


@pytest.mark.parametrize("row", ["--1,1", "1" * 5000 + ",1", "1,1e3", "0x1,2", " ,1", "1;2"])
def test_malformed_ground_truth_rows_are_refused(tmp_path: Path, row: str) -> None:
    path = tmp_path / "ground_truth.csv"
    path.write_text(f"query_index,reference_index\n0,0\n{row}\n")
    with pytest.raises(ValidationError, match=r"line 3 is .*expected 'query_index,reference_index' as two integers"):
        read_pairs_csv(path, 4, 4)
