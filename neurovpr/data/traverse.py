"""A place-recognition dataset: reference traverse(s), a query traverse and their ground truth.

Images stay on disk (a tuple of paths) or in memory (an array); both are an
:class:`ImageSet`. A :class:`Traverse` checks on construction that it can be used:
no empty set, reference traverses of equal length, a ground truth of shape
``(n_reference, n_query)`` in which at least one query has a match. Every problem is
one :class:`~neurovpr.errors.ValidationError` sentence, raised before any training.

Several reference traverses of the same places (the Modular SNN trains on Nordland
spring and fall) are aligned by index: ``references[k][i]`` shows place ``i``.
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from neurovpr.data.ground_truth import GroundTruth
from neurovpr.data.images import check_image_array, image_size, read_image
from neurovpr.errors import ValidationError

__all__ = ["ImageSet", "Traverse"]


def _check_sizes(name: str, paths: tuple[Path, ...]) -> None:
    """Read every image's header (no pixels): refuse unreadable ones, warn once when sizes differ."""
    first = image_size(paths[0])
    sizes = [image_size(path) for path in paths[1:]]
    for path, size in zip(paths[1:], sizes, strict=True):
        if size != first:
            warnings.warn(
                f"image set {name!r}: {path} is {size[0]}x{size[1]} pixels, {paths[0]} is {first[0]}x{first[1]}; "
                "images of different sizes are each resized to the model's input size.",
                UserWarning,
                stacklevel=4,
            )
            break


@dataclass(frozen=True, slots=True, kw_only=True, eq=False)
class ImageSet:
    """An ordered set of images, one per place: files on disk or an in-memory array.

    Give exactly one of ``paths`` (image files, read when needed) or ``array``
    (``(N, H, W)`` grayscale or ``(N, H, W, C)`` images).
    """

    name: str
    paths: tuple[Path, ...] | None = None
    array: np.ndarray | None = field(default=None)

    def __post_init__(self) -> None:
        if (self.paths is None) == (self.array is None):
            raise ValidationError(f"image set {self.name!r} needs exactly one of paths or array.")
        if self.paths is not None:
            paths = tuple(Path(p) for p in self.paths)
            if not paths:
                raise ValidationError(f"image set {self.name!r} is empty, expected at least one image.")
            missing = [p for p in paths if not p.is_file()]
            if missing:
                raise ValidationError(
                    f"image set {self.name!r} lists {len(missing)} missing file(s), the first being {missing[0]}."
                )
            _check_sizes(self.name, paths)
            object.__setattr__(self, "paths", paths)
        else:
            arr = np.asarray(self.array)
            if arr.ndim not in (3, 4) or arr.shape[0] == 0:
                raise ValidationError(
                    f"image set {self.name!r} array has shape {arr.shape}, expected a non-empty stack (N, H, W) or (N, H, W, C)."
                )
            check_image_array(arr[0], name=f"image set {self.name!r} image 0")
            if np.issubdtype(arr.dtype, np.floating) and not np.isfinite(arr).all():
                first = int(np.flatnonzero(~np.isfinite(arr).reshape(arr.shape[0], -1).all(axis=1))[0])
                raise ValidationError(f"image set {self.name!r} image {first} has NaN or infinite pixel values.")
            frozen = np.array(arr, copy=True, order="C")
            frozen.setflags(write=False)
            object.__setattr__(self, "array", frozen)

    def __len__(self) -> int:
        return len(self.paths) if self.paths is not None else int(self.array.shape[0])  # type: ignore[union-attr]

    @property
    def names(self) -> tuple[str, ...]:
        """File names, or ``"00000"``-style indices for in-memory images."""
        if self.paths is not None:
            return tuple(p.name for p in self.paths)
        width = max(5, len(str(len(self) - 1)))
        return tuple(f"{i:0{width}d}" for i in range(len(self)))

    def image(self, index: int) -> np.ndarray:
        """Image ``index`` as an array (read from disk when the set holds paths)."""
        if self.paths is not None:
            return read_image(self.paths[index])
        return self.array[index]  # type: ignore[index]

    def images(self, progress: bool = False) -> list[np.ndarray]:
        """Every image, in order (with a progress bar when ``progress`` and the set is on disk)."""
        if self.paths is None:
            return list(self.array)  # type: ignore[arg-type]
        indices = range(len(self))
        if progress:
            from tqdm.auto import tqdm

            indices = tqdm(indices, desc=f"reading {self.name}", unit="img", leave=False)
        return [read_image(self.paths[i]) for i in indices]

    def preprocessed(self, progress: bool = False) -> np.ndarray:
        """The Modular SNN input of every image: ``uint8`` ``(N, 28, 28)`` (see :mod:`neurovpr.data.preprocess`)."""
        from neurovpr.data.preprocess import preprocess_images

        names = [str(p) for p in self.paths] if self.paths is not None else [f"{self.name} image {i}" for i in range(len(self))]
        return preprocess_images(self.images(progress=progress), names=names)

    def subset(self, indices: np.ndarray | Sequence[int] | slice) -> ImageSet:
        """The images at ``indices``, in that order."""
        if self.paths is not None:
            idx = np.arange(len(self))[indices]
            return ImageSet(name=self.name, paths=tuple(self.paths[i] for i in idx))
        return ImageSet(name=self.name, array=self.array[indices])  # type: ignore[index]


@dataclass(frozen=True, slots=True, kw_only=True, eq=False)
class Traverse:
    """Reference traverse(s) and a query traverse of one route, with ground truth ``[reference, query]``.

    Attributes
    ----------
    name
        Dataset name, e.g. ``"nordland64"``.
    references
        One or more reference traverses of the same places, aligned by index.
    query
        The query traverse.
    ground_truth
        Which references each query matches.
    n_calibration
        How many leading queries the published protocol keeps for calibration
        (0 when it has none); informational, nothing is removed.
    """

    name: str
    references: tuple[ImageSet, ...]
    query: ImageSet
    ground_truth: GroundTruth
    n_calibration: int = 0

    def __post_init__(self) -> None:
        refs = tuple(self.references)
        object.__setattr__(self, "references", refs)
        if not refs:
            raise ValidationError(f"traverse {self.name!r} has no reference image set, expected at least one.")
        n_ref = len(refs[0])
        for other in refs[1:]:
            if len(other) != n_ref:
                raise ValidationError(
                    f"traverse {self.name!r} reference set {other.name!r} has {len(other)} images but "
                    f"{refs[0].name!r} has {n_ref}; reference traverses must show the same places."
                )
        n_query = len(self.query)
        if self.ground_truth.shape != (n_ref, n_query):
            raise ValidationError(
                f"traverse {self.name!r} ground truth has shape {self.ground_truth.shape} [reference, query] "
                f"but the sets hold {n_ref} reference and {n_query} query images."
            )
        if not self.ground_truth.has_match().any():
            raise ValidationError(f"traverse {self.name!r} ground truth gives no query a matching reference.")
        if not 0 <= int(self.n_calibration) < n_query:
            raise ValidationError(f"traverse {self.name!r} n_calibration is {self.n_calibration}, expected 0..{n_query - 1}.")

    @property
    def reference(self) -> ImageSet:
        """The first (primary) reference traverse."""
        return self.references[0]

    @property
    def n_reference(self) -> int:
        return len(self.references[0])

    @property
    def n_query(self) -> int:
        return len(self.query)

    def subset(self, reference: np.ndarray | Sequence[int] | slice, query: np.ndarray | Sequence[int] | slice) -> Traverse:
        """The traverse restricted to the given reference and query indices (ground truth follows)."""
        ref_idx = np.arange(self.n_reference)[reference]
        qry_idx = np.arange(self.n_query)[query]
        n_cal = int(np.count_nonzero(qry_idx < self.n_calibration)) if self.n_calibration else 0
        return Traverse(
            name=self.name,
            references=tuple(r.subset(ref_idx) for r in self.references),
            query=self.query.subset(qry_idx),
            ground_truth=self.ground_truth.subset(ref_idx, qry_idx),
            n_calibration=min(n_cal, len(qry_idx) - 1),
        )

    def first(self, n_places: int) -> Traverse:
        """The first ``n_places`` references and queries (the natural cut of an aligned traverse)."""
        n = int(n_places)
        if not 1 <= n <= min(self.n_reference, self.n_query):
            raise ValidationError(
                f"traverse {self.name!r} has {self.n_reference} reference and {self.n_query} query images, "
                f"so the first {n_places} places cannot be taken."
            )
        return self.subset(slice(0, n), slice(0, n))
