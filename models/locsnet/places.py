"""Places as classes: frame groups of aligned traverses, grid tiles of GPS-tagged traverses.

LoCS-Net casts place recognition as classification. Two labelings:

- **Aligned traverses** (Nordland): reference frame ``i`` belongs to place
  ``i // frames_per_place``. With ``frames_per_place = 1`` every reference frame is a
  place (the paper samples every 8th Nordland frame; ``nordland64`` is already every
  10th frame, so 1 is the closest setting).
- **GPS-tagged traverses** (Oxford RobotCar in the paper): positions are binned into
  square tiles of side ``tile_size`` (metres); every tile holding at least
  ``min_images`` reference images is a place and the reference images of rarer tiles
  are dropped, as the paper filters rare tiles. A query matches the place of the tile
  it lies in (a query in a dropped or unseen tile has no match and is left out of the
  metrics).

A query's ground truth over places is the union of its matches over the reference
frames of each place. With grid labels, :func:`distance_confusion` reports how far
each answer is from the query's true position.
"""

from __future__ import annotations

import csv
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from neurovpr.data.ground_truth import GroundTruth
from neurovpr.errors import ValidationError

__all__ = [
    "PlaceLabels",
    "frame_labels",
    "grid_labels",
    "place_ground_truth",
    "query_tiles",
    "distance_confusion",
    "read_positions_csv",
]


@dataclass(frozen=True, slots=True, kw_only=True, eq=False)
class PlaceLabels:
    """Reference frame -> place assignment.

    Attributes
    ----------
    labels
        Place of each reference frame, ``-1`` for a frame left out (a rare tile).
    n_places
        Number of places.
    scheme
        ``"frames"`` or ``"grid"``.
    frames_per_place
        For ``"frames"``.
    tile_size, origin, tiles
        For ``"grid"``: tile side, grid origin ``(x, y)`` and each place's tile
        indices ``(n_places, 2)``.
    """

    labels: np.ndarray
    n_places: int
    scheme: str
    frames_per_place: int = 1
    tile_size: float = 0.0
    origin: tuple[float, float] = (0.0, 0.0)
    tiles: np.ndarray | None = None

    def training_set(self) -> tuple[np.ndarray, np.ndarray]:
        """``(reference indices, labels)`` of the frames used for training."""
        keep = np.flatnonzero(self.labels >= 0)
        return keep, self.labels[keep]

    def centres(self) -> np.ndarray:
        """Tile centres ``(n_places, 2)`` (grid labels only)."""
        if self.tiles is None:
            raise ValidationError("place centres exist only for grid labels.")
        return (self.tiles + 0.5) * self.tile_size + np.asarray(self.origin)

    def to_arrays(self) -> dict[str, np.ndarray]:
        """Arrays for an ``.npz`` file (no objects)."""
        out = {"labels": self.labels, "n_places": np.array(self.n_places), "scheme": np.array(self.scheme),
               "frames_per_place": np.array(self.frames_per_place), "tile_size": np.array(self.tile_size),
               "origin": np.array(self.origin, dtype=np.float64)}
        if self.tiles is not None:
            out["tiles"] = self.tiles
        return out

    @classmethod
    def from_arrays(cls, data: dict[str, np.ndarray]) -> PlaceLabels:
        """Inverse of :meth:`to_arrays`."""
        try:
            return cls(labels=np.asarray(data["labels"], dtype=np.int64), n_places=int(data["n_places"]),
                       scheme=str(data["scheme"]), frames_per_place=int(data["frames_per_place"]),
                       tile_size=float(data["tile_size"]), origin=tuple(np.asarray(data["origin"], dtype=float)),
                       tiles=np.asarray(data["tiles"], dtype=np.int64) if "tiles" in data else None)
        except KeyError as exc:
            raise ValidationError(f"place labels file lacks {exc}.") from None


def frame_labels(n_frames: int, frames_per_place: int = 1) -> PlaceLabels:
    """Frame ``i`` is place ``i // frames_per_place``."""
    if isinstance(frames_per_place, bool) or not isinstance(frames_per_place, (int, np.integer)) or frames_per_place < 1:
        raise ValidationError(f"frames per place must be an integer >= 1, got {frames_per_place!r}.")
    if n_frames < 1:
        raise ValidationError(f"the reference traverse has {n_frames} frames, expected at least 1.")
    k = int(frames_per_place)
    labels = np.arange(n_frames, dtype=np.int64) // k
    n_places = int(labels[-1]) + 1
    if n_places < 2:
        raise ValidationError(
            f"{n_frames} reference frames at {k} frames per place make {n_places} place; at least 2 are needed."
        )
    return PlaceLabels(labels=labels, n_places=n_places, scheme="frames", frames_per_place=k)


def grid_labels(positions: np.ndarray, tile_size: float, min_images: int = 2) -> PlaceLabels:
    """Tiles of side ``tile_size`` holding at least ``min_images`` reference positions are the places."""
    xy = np.asarray(positions, dtype=np.float64)
    if xy.ndim != 2 or xy.shape[1] != 2 or xy.shape[0] == 0:
        raise ValidationError(f"reference positions must be an (n, 2) array of x, y, got shape {xy.shape}.")
    if not np.isfinite(xy).all():
        raise ValidationError("reference positions contain NaN or infinite values.")
    if not (np.isfinite(tile_size) and tile_size > 0):
        raise ValidationError(f"tile size must be a positive number of metres, got {tile_size!r}.")
    if isinstance(min_images, bool) or not isinstance(min_images, (int, np.integer)) or min_images < 1:
        raise ValidationError(f"minimum images per tile must be an integer >= 1, got {min_images!r}.")
    origin = xy.min(axis=0)
    cells = np.floor((xy - origin) / tile_size).astype(np.int64)
    uniq, inverse, counts = np.unique(cells, axis=0, return_inverse=True, return_counts=True)
    inverse = inverse.ravel()
    kept = np.flatnonzero(counts >= min_images)
    if kept.size < 2:
        raise ValidationError(
            f"only {kept.size} tile(s) of {tile_size:g} m hold at least {min_images} reference images; "
            "at least 2 places are needed (use smaller tiles or a lower minimum)."
        )
    new_id = np.full(uniq.shape[0], -1, dtype=np.int64)
    new_id[kept] = np.arange(kept.size)
    return PlaceLabels(labels=new_id[inverse], n_places=int(kept.size), scheme="grid", tile_size=float(tile_size),
                       origin=(float(origin[0]), float(origin[1])), tiles=uniq[kept])


def query_tiles(labels: PlaceLabels, query_positions: np.ndarray) -> np.ndarray:
    """The place of each query position's tile, ``-1`` where that tile is not a place."""
    if labels.tiles is None:
        raise ValidationError("query tiles need grid labels.")
    q = np.asarray(query_positions, dtype=np.float64)
    if q.ndim != 2 or q.shape[1] != 2 or not np.isfinite(q).all():
        raise ValidationError(f"query positions must be a finite (n, 2) array, got shape {q.shape}.")
    cells = np.floor((q - np.asarray(labels.origin)) / labels.tile_size).astype(np.int64)
    lookup = {tuple(t): i for i, t in enumerate(labels.tiles.tolist())}
    return np.array([lookup.get(tuple(c), -1) for c in cells.tolist()], dtype=np.int64)


def place_ground_truth(ground_truth: GroundTruth, labels: PlaceLabels) -> np.ndarray:
    """Boolean ``[place, query]`` matrix: a query matches a place when it matches any of its frames."""
    gt = ground_truth.matrix
    if gt.shape[0] != labels.labels.size:
        raise ValidationError(
            f"ground truth covers {gt.shape[0]} reference frames but the labels {labels.labels.size}."
        )
    out = np.zeros((labels.n_places, gt.shape[1]), dtype=bool)
    keep = labels.labels >= 0
    np.logical_or.at(out, labels.labels[keep], gt[keep])
    return out


def distance_confusion(
    labels: PlaceLabels, predicted: np.ndarray, query_positions: np.ndarray, thresholds: tuple[float, ...] = (25.0, 50.0, 100.0)
) -> dict[str, float]:
    """How far each answer (the centre of the predicted tile) lies from the query's position.

    Returns the median and mean error (m) and the fraction of queries answered within
    each threshold (``"within_25m"``, ...).
    """
    centres = labels.centres()
    pred = np.asarray(predicted, dtype=np.int64)
    q = np.asarray(query_positions, dtype=np.float64)
    if pred.shape != (q.shape[0],):
        raise ValidationError(f"{pred.size} predictions for {q.shape[0]} query positions.")
    err = np.linalg.norm(centres[pred] - q, axis=1)
    out = {"median_error_m": float(np.median(err)), "mean_error_m": float(err.mean())}
    for t in thresholds:
        out[f"within_{t:g}m"] = float(np.mean(err <= t))
    return out


def read_positions_csv(path: str | Path, n_reference: int, n_query: int) -> tuple[np.ndarray, np.ndarray]:
    """Positions from a CSV with header ``set,index,x,y`` (``set`` is ``reference`` or ``query``, metres).

    Every reference and query image needs exactly one row.
    """
    path = Path(path)
    ref = np.full((n_reference, 2), np.nan)
    qry = np.full((n_query, 2), np.nan)
    try:
        with path.open(newline="", encoding="utf-8") as fh:
            reader = csv.DictReader(fh)
            if reader.fieldnames is None or not {"set", "index", "x", "y"} <= set(reader.fieldnames):
                raise ValidationError(f"{path} must have the header set,index,x,y.")
            for line, row in enumerate(reader, start=2):
                target = {"reference": ref, "query": qry}.get(row["set"])
                if target is None:
                    raise ValidationError(f"{path} line {line}: set is {row['set']!r}, expected reference or query.")
                try:
                    i, x, y = int(row["index"]), float(row["x"]), float(row["y"])
                except (TypeError, ValueError):
                    raise ValidationError(f"{path} line {line}: index, x and y must be numbers.") from None
                if not 0 <= i < target.shape[0]:
                    raise ValidationError(f"{path} line {line}: index {i} is outside 0..{target.shape[0] - 1}.")
                target[i] = (x, y)
    except OSError as exc:
        raise ValidationError(f"positions file {path} cannot be read ({exc}).") from None
    for name, arr in (("reference", ref), ("query", qry)):
        missing = np.flatnonzero(np.isnan(arr).any(axis=1))
        if missing.size:
            raise ValidationError(f"{path} gives no position for {name} image {int(missing[0])} ({missing.size} missing).")
    return ref, qry
