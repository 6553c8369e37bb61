"""Published dataset layouts, as the Modular SNN paper's code defines them.

Hussaini, Milford & Fischer (T-RO 2024) take their traverses from image-name lists in
their code (QVPR/VPRSNN, MIT licence, ``dataset_imagenames/*.txt`` and
``dataset_gt_files/``). neurovpr does not ship those lists: pass the folder that holds
``dataset_imagenames/`` (and, for St Lucia, ``dataset_gt_files/``) as ``lists=``, or
download it once with :func:`neurovpr.data.download.fetch_vprsnn_lists`.

The selection follows ``tools/data_utils.py: processImageDataset``: walk the list in
order, skip lines that name no ``.png``/``.jpg`` file, keep line ``i`` only when
``i % skip == 0``, stop after ``n`` kept images. Image paths in the lists are relative
to the data root (the code's ``./../data``), e.g. ``./nordland/winter/images-00202.png``.
The settings are those of the code's example commands (``modular_snn_processing.py``):

=================  ==========================  ==========  ====  ===========  =====
name               reference traverse(s)       query       skip  places       calib
=================  ==========================  ==========  ====  ===========  =====
``nordland-sfs``   spring + fall               summer      8     3300         600
``nordland-sfw``   spring + fall               winter      8     3300         600
``orc``            Sun + Rain                  Dusk        8     450          75
``sfu-mountain``   dry                         dusk        1     375          75
``synthia``        ref (night)                 query (fall) 1    250          50
``st-lucia``       190809_0845                 180809_1545 1     500 x 1037   50
=================  ==========================  ==========  ====  ===========  =====

Nordland lists exclude the segments where the train runs below 15 km/h, and every 8th
kept frame is about 100 m apart. Ground truth: query ``i`` matches reference place
``i`` exactly (the code's ``gt_labels = np.arange(...)``, zero tolerance), except St
Lucia, whose 500 x 1037 ``[reference, query]`` matrix marks each query's match with 0.
The Synthia example command asks for 275 places but the lists hold 250, so 250 are used.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from types import MappingProxyType

import numpy as np

from neurovpr.data.ground_truth import GroundTruth
from neurovpr.data.traverse import ImageSet, Traverse
from neurovpr.errors import ValidationError

__all__ = [
    "PublishedDataset",
    "DATASETS",
    "detect",
    "select_lines",
    "published_paths",
    "load_published",
    "orc_original_names",
    "default_lists_folder",
]

NAMES_DIR = "dataset_imagenames"
GT_DIR = "dataset_gt_files"


@dataclass(frozen=True, slots=True, kw_only=True)
class PublishedDataset:
    """How one dataset's traverses are picked from the VPRSNN lists."""

    name: str
    folder: str
    reference_lists: tuple[str, ...]
    query_list: str
    skip: int
    n_reference: int
    n_query: int
    n_calibration: int
    gt_file: str | None = None
    gt_match_value: int = 0
    query_subfolder: str = ""


DATASETS: MappingProxyType[str, PublishedDataset] = MappingProxyType(
    {
        d.name: d
        for d in (
            PublishedDataset(
                name="nordland-sfs",
                folder="nordland",
                reference_lists=("nordland_imageNames_spring.txt", "nordland_imageNames_fall.txt"),
                query_list="nordland_imageNames_summer.txt",
                skip=8,
                n_reference=3300,
                n_query=3300,
                n_calibration=600,
                query_subfolder="summer",
            ),
            PublishedDataset(
                name="nordland-sfw",
                folder="nordland",
                reference_lists=("nordland_imageNames_spring.txt", "nordland_imageNames_fall.txt"),
                query_list="nordland_imageNames_winter.txt",
                skip=8,
                n_reference=3300,
                n_query=3300,
                n_calibration=600,
                query_subfolder="winter",
            ),
            PublishedDataset(
                name="orc",
                folder="ORC",
                reference_lists=("ORC_imageNames_Sun.txt", "ORC_imageNames_Rain.txt"),
                query_list="ORC_imageNames_Dusk.txt",
                skip=8,
                n_reference=450,
                n_query=450,
                n_calibration=75,
            ),
            PublishedDataset(
                name="sfu-mountain",
                folder="SFU-Mountain",
                reference_lists=("SFU-Mountain_imageNames_dry.txt",),
                query_list="SFU-Mountain_imageNames_dusk.txt",
                skip=1,
                n_reference=375,
                n_query=375,
                n_calibration=75,
            ),
            PublishedDataset(
                name="synthia",
                folder="Synthia-NightToFall",
                reference_lists=("Synthia-NightToFall_imageNames_ref.txt",),
                query_list="Synthia-NightToFall_imageNames_query.txt",
                skip=1,
                n_reference=250,
                n_query=250,
                n_calibration=50,
            ),
            PublishedDataset(
                name="st-lucia",
                folder="St-Lucia",
                reference_lists=("St-Lucia_imageNames_190809_0845.txt",),
                query_list="St-Lucia_imageNames_180809_1545.txt",
                skip=1,
                n_reference=500,
                n_query=1037,
                n_calibration=50,
                gt_file="St_Lucia_gt_boolean_matrix.npy",
                gt_match_value=0,
            ),
        )
    }
)


def default_lists_folder() -> Path:
    """Where :func:`neurovpr.data.download.fetch_vprsnn_lists` stores the lists."""
    from neurovpr.paths import cache_dir

    return cache_dir("vprsnn_lists")


def detect(root: str | Path) -> list[str]:
    """Names of the published datasets whose folders exist under ``root``."""
    root = Path(root)
    found = []
    for spec in DATASETS.values():
        base = root / spec.folder
        if not base.is_dir():
            continue
        if spec.query_subfolder and not (base / spec.query_subfolder).is_dir():
            continue
        found.append(spec.name)
    return found


def _lists_folder(lists: str | Path | None, root: Path | None) -> Path:
    candidates = [Path(lists)] if lists is not None else []
    if lists is None:
        if root is not None:
            candidates.append(root)
        candidates.append(default_lists_folder())
    for folder in candidates:
        if (folder / NAMES_DIR).is_dir():
            return folder
    where = Path(lists) if lists is not None else " or ".join(str(c) for c in candidates)
    raise ValidationError(
        f"no {NAMES_DIR}/ folder of the VPRSNN image-name lists found in {where}; pass lists= or run "
        "neurovpr.data.download.fetch_vprsnn_lists()."
    )


def _read_list(folder: Path, filename: str) -> list[str]:
    path = folder / NAMES_DIR / filename
    if not path.is_file():
        raise ValidationError(f"image-name list {path} does not exist.")
    return path.read_text(encoding="utf-8").splitlines()


def select_lines(lines: list[str], skip: int, n: int) -> list[str]:
    """The list entries VPRSNN's ``processImageDataset`` keeps (see the module docstring)."""
    kept: list[str] = []
    for i, line in enumerate(lines):
        if len(kept) == n:
            break
        if ".jpg" not in line and ".png" not in line:
            continue
        if skip != 0 and i % skip != 0:
            continue
        kept.append(line.strip())
    return kept


def _spec(name: str) -> PublishedDataset:
    if name not in DATASETS:
        raise ValidationError(f"unknown published dataset {name!r}; known: {', '.join(DATASETS)}.")
    return DATASETS[name]


def published_paths(
    name: str, lists: str | Path | None = None, n_places: int | None = None
) -> tuple[tuple[list[str], ...], list[str]]:
    """Relative image paths of each reference traverse and of the query traverse.

    ``n_places`` caps both counts (default: the published numbers).
    """
    spec = _spec(name)
    folder = _lists_folder(lists, None)
    n_ref, n_qry = spec.n_reference, spec.n_query
    if n_places is not None:
        if int(n_places) < 1:
            raise ValidationError(f"n_places must be >= 1, got {n_places}.")
        n_ref, n_qry = min(n_ref, int(n_places)), min(n_qry, int(n_places))
    refs = tuple(select_lines(_read_list(folder, f), spec.skip, n_ref) for f in spec.reference_lists)
    qry = select_lines(_read_list(folder, spec.query_list), spec.skip, n_qry)
    for lst, got in zip(spec.reference_lists, refs, strict=True):
        if len(got) < n_ref:
            raise ValidationError(f"list {lst} yields {len(got)} images with skip {spec.skip}, fewer than {n_ref}.")
    if len(qry) < n_qry:
        raise ValidationError(f"list {spec.query_list} yields {len(qry)} images with skip {spec.skip}, fewer than {n_qry}.")
    return refs, qry


def _ground_truth(spec: PublishedDataset, folder: Path, n_ref: int, n_qry: int) -> GroundTruth:
    if spec.gt_file is None:
        if n_ref != n_qry:
            raise ValidationError(f"dataset {spec.name} is aligned by index but has {n_ref} references and {n_qry} queries.")
        return GroundTruth.aligned(n_ref)
    path = folder / GT_DIR / spec.gt_file
    if not path.is_file():
        raise ValidationError(f"ground-truth file {path} of dataset {spec.name} does not exist.")
    try:
        matrix = np.load(path, allow_pickle=False)
    except (OSError, ValueError) as exc:
        raise ValidationError(f"ground-truth file {path} is not a readable .npy array ({exc}).") from exc
    if matrix.shape != (spec.n_reference, spec.n_query):
        raise ValidationError(
            f"ground-truth file {path} has shape {matrix.shape}, expected ({spec.n_reference}, {spec.n_query})."
        )
    return GroundTruth.from_matrix(matrix[:n_ref, :n_qry], match_value=spec.gt_match_value)


def load_published(name: str, root: str | Path, *, lists: str | Path | None = None, n_places: int | None = None) -> Traverse:
    """Open a published dataset stored under the data root ``root``.

    Parameters
    ----------
    name
        One of :data:`DATASETS`.
    root
        Folder holding the dataset's folder (e.g. ``root/nordland/winter/...``).
    lists
        Folder holding ``dataset_imagenames/`` (and ``dataset_gt_files/``); by default
        ``root`` itself, then the download cache.
    n_places
        Use only the first ``n_places`` references and queries.
    """
    spec = _spec(name)
    root = Path(root)
    folder = _lists_folder(lists, root)
    refs, qry = published_paths(name, folder, n_places)

    def resolve(entries: list[str]) -> tuple[Path, ...]:
        return tuple(root / (e[2:] if e.startswith("./") else e) for e in entries)

    ref_sets = tuple(
        ImageSet(name=Path(lst).stem, paths=resolve(entries)) for lst, entries in zip(spec.reference_lists, refs, strict=True)
    )
    query = ImageSet(name=Path(spec.query_list).stem, paths=resolve(qry))
    gt = _ground_truth(spec, folder, len(refs[0]), len(qry))
    n_cal = spec.n_calibration if spec.n_calibration < len(qry) else 0
    return Traverse(name=spec.name, references=ref_sets, query=query, ground_truth=gt, n_calibration=n_cal)


def orc_original_names(lists: str | Path | None, condition: str) -> dict[str, str]:
    """Map VPRSNN's renamed Oxford RobotCar frames (``000000.png``) to the original timestamp names.

    ``condition`` is ``"Sun"``, ``"Rain"`` or ``"Dusk"`` (``ORC_<condition>_timestamps.csv``).
    """
    folder = _lists_folder(lists, None)
    rows = _read_list(folder, f"ORC_{condition}_timestamps.csv")
    mapping = {}
    for lineno, row in enumerate(rows[1:], start=2):
        parts = [p.strip() for p in row.split(",")]
        if len(parts) != 2:
            raise ValidationError(f"ORC_{condition}_timestamps.csv line {lineno} is {row!r}, expected two names.")
        mapping[parts[0]] = parts[1]
    return mapping
