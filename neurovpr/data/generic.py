"""The generic traverse layout: read it, write it, and pick the right reader for a folder.

Layout::

    PATH/reference/*        one image per place; sorted file names give the order
    PATH/query/*            the query traverse, sorted the same way
    PATH/ground_truth.csv   optional: "query_index,reference_index" per line, 0-based,
                            several lines per query allowed

Without ``ground_truth.csv``, query ``i`` matches reference ``i`` exactly, so both
folders must hold the same number of images. Hidden files (names starting with a dot)
are skipped; any other file that is not an image is refused, so a stray file can never
silently shift the alignment.
"""

from __future__ import annotations

import os
import shutil
import tempfile
import warnings
from pathlib import Path

import numpy as np

from neurovpr.data.ground_truth import GroundTruth, read_pairs_csv
from neurovpr.data.images import IMAGE_SUFFIXES, is_image_file
from neurovpr.data.traverse import ImageSet, Traverse
from neurovpr.errors import ValidationError

__all__ = ["read_generic", "write_generic", "is_generic", "open_traverse"]

GT_FILE = "ground_truth.csv"


def is_generic(path: str | Path) -> bool:
    """True when ``path`` has ``reference/`` and ``query/`` folders."""
    path = Path(path)
    return (path / "reference").is_dir() and (path / "query").is_dir()


def _list_images(folder: Path) -> tuple[Path, ...]:
    files = []
    for entry in sorted(folder.iterdir(), key=lambda p: p.name):
        if entry.name.startswith("."):
            continue
        if entry.is_dir():
            raise ValidationError(f"{entry} is a folder inside {folder}; the generic layout expects only image files there.")
        if not is_image_file(entry):
            raise ValidationError(f"{entry} is not an image file (allowed endings: {', '.join(IMAGE_SUFFIXES)}).")
        files.append(entry)
    if not files:
        raise ValidationError(f"{folder} holds no images, expected at least one.")
    return tuple(files)


def read_generic(path: str | Path, name: str | None = None) -> Traverse:
    """Read a folder in the generic layout (see the module docstring)."""
    path = Path(path)
    if not is_generic(path):
        raise ValidationError(f"{path} lacks a reference/ or query/ folder, so it is not in the generic layout.")
    ref = _list_images(path / "reference")
    qry = _list_images(path / "query")
    gt_path = path / GT_FILE
    if gt_path.is_file():
        gt = read_pairs_csv(gt_path, len(ref), len(qry))
    else:
        if len(ref) != len(qry):
            raise ValidationError(
                f"{path} has {len(ref)} reference and {len(qry)} query images and no {GT_FILE}; "
                "without it query i must match reference i, so the counts must be equal."
            )
        gt = GroundTruth.aligned(len(ref))
    return Traverse(
        name=name or path.resolve().name,
        references=(ImageSet(name="reference", paths=ref),),
        query=ImageSet(name="query", paths=qry),
        ground_truth=gt,
    )


def _as_uint8(image: np.ndarray, label: str) -> np.ndarray:
    arr = np.asarray(image)
    if arr.dtype == np.uint8:
        return arr
    if np.issubdtype(arr.dtype, np.integer) or np.issubdtype(arr.dtype, np.floating):
        lo, hi = float(arr.min()), float(arr.max())
        if lo >= 0 and hi <= 255:
            return np.rint(arr).astype(np.uint8)
        raise ValidationError(f"{label} has values in [{lo}, {hi}], which a PNG file cannot hold (0..255).")
    raise ValidationError(f"{label} has dtype {arr.dtype}, which a PNG file cannot hold.")


def write_generic(traverse: Traverse, out: str | Path, *, overwrite: bool = False) -> Path:
    """Write ``traverse`` in the generic layout as PNG files; returns the folder.

    Files are written to a temporary sibling folder first and moved into place at
    the end, so a failure leaves nothing half-written. ``ground_truth.csv`` is
    written unless the ground truth is the aligned identity. Only the first
    reference traverse is written (the layout has one reference folder); a warning
    says so when there are more.
    """
    from PIL import Image

    out = Path(out)
    if out.exists():
        if not overwrite:
            raise ValidationError(f"output folder {out} already exists; pass overwrite=True to replace it.")
        if not out.is_dir():
            raise ValidationError(f"output path {out} exists and is not a folder.")
    if len(traverse.references) > 1:
        warnings.warn(
            f"traverse {traverse.name!r} has {len(traverse.references)} reference traverses; the generic layout "
            "holds one, so only the first is written.",
            UserWarning,
            stacklevel=2,
        )
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{out.name}.", dir=out.parent))
    try:
        for folder, images in (("reference", traverse.reference), ("query", traverse.query)):
            (tmp / folder).mkdir()
            width = max(5, len(str(len(images) - 1)))
            for i in range(len(images)):
                arr = _as_uint8(images.image(i), f"{images.name} image {i}")
                if arr.ndim == 3 and arr.shape[2] == 1:
                    arr = arr[..., 0]
                Image.fromarray(arr).save(tmp / folder / f"{i:0{width}d}.png")
        if not traverse.ground_truth.is_aligned():
            lines = ["query_index,reference_index"]
            lines += [f"{q},{r}" for q, r in traverse.ground_truth.pairs()]
            (tmp / GT_FILE).write_text("\n".join(lines) + "\n", encoding="utf-8")
        if out.exists():
            shutil.rmtree(out)
        os.replace(tmp, out)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    return out


def open_traverse(path: str | Path, *, layout: str | None = None, **options: object) -> Traverse:
    """Open a dataset folder in the generic layout or in one of the published layouts.

    Parameters
    ----------
    path
        The dataset folder: a generic-layout folder (``reference/`` and ``query/``),
        or the data root of a published layout (the folder that holds ``nordland/``,
        ``ORC/``, ``St-Lucia/``, ``SFU-Mountain/`` or ``Synthia-NightToFall/``).
    layout
        ``"generic"`` or a published dataset name (see
        :data:`neurovpr.data.published.DATASETS`); found from the folder when omitted.
    **options
        Passed to :func:`neurovpr.data.published.load_published` (``lists``,
        ``n_places``).
    """
    from neurovpr.data import published

    path = Path(path)
    if not path.is_dir():
        raise ValidationError(f"dataset path {path} is not a folder.")
    if layout is None:
        if is_generic(path):
            layout = "generic"
        else:
            found = published.detect(path)
            if not found:
                raise ValidationError(
                    f"{path} is neither the generic layout (reference/ and query/ folders) nor a published layout "
                    f"(one of the folders {', '.join(sorted({s.folder for s in published.DATASETS.values()}))})."
                )
            if len(found) > 1:
                raise ValidationError(f"{path} holds several published datasets ({', '.join(found)}); choose one with layout=.")
            layout = found[0]
    if layout == "generic":
        if options:
            raise ValidationError(f"the generic layout takes no options, got {', '.join(sorted(options))}.")
        return read_generic(path)
    return published.load_published(layout, path, **options)  # type: ignore[arg-type]
