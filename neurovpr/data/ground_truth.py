"""Ground truth of a traverse pair: which reference places each query matches.

Every form the datasets use (aligned indices, a boolean matrix, a list of index
pairs, positions with a distance tolerance) becomes one boolean matrix indexed
``[reference, query]``, the same convention as every distance matrix in neurovpr:
``matrix[r, q]`` is true when query ``q`` was taken at reference place ``r``.
A query may match several references, or none (such a query is left out of
Recall@N and of the precision-recall curve).
"""

from __future__ import annotations

import re
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from neurovpr.errors import ValidationError

__all__ = ["GroundTruth", "read_pairs_csv"]


@dataclass(frozen=True, slots=True, kw_only=True, eq=False)
class GroundTruth:
    """Boolean match matrix indexed ``[reference, query]``.

    Build one with :meth:`aligned`, :meth:`from_matrix`, :meth:`from_pairs` or
    :meth:`from_positions`; the stored matrix is read-only.
    """

    matrix: np.ndarray

    def __post_init__(self) -> None:
        arr = np.asarray(self.matrix)
        if arr.ndim != 2:
            raise ValidationError(f"GroundTruth.matrix must be 2-D [reference, query], got {arr.ndim}-D.")
        if arr.shape[0] == 0 or arr.shape[1] == 0:
            raise ValidationError(f"GroundTruth.matrix must not be empty, got shape {arr.shape}.")
        if arr.dtype != np.bool_:
            raise ValidationError(f"GroundTruth.matrix must be boolean, got dtype {arr.dtype}.")
        frozen = np.array(arr, dtype=np.bool_, copy=True, order="C")
        frozen.setflags(write=False)
        object.__setattr__(self, "matrix", frozen)

    # ------------------------------------------------------------------ builders
    @classmethod
    def aligned(cls, n_places: int) -> GroundTruth:
        """Query ``i`` matches reference ``i`` only (zero tolerance)."""
        if int(n_places) < 1:
            raise ValidationError(f"GroundTruth.aligned needs at least 1 place, got {n_places}.")
        return cls(matrix=np.eye(int(n_places), dtype=bool))

    @classmethod
    def from_matrix(cls, matrix: np.ndarray, *, match_value: int | bool = True) -> GroundTruth:
        """From a numeric or boolean ``[reference, query]`` matrix; entries equal to ``match_value`` match.

        The St Lucia file of the Modular SNN code marks a match with 0, so it is read
        with ``match_value=0``.
        """
        arr = np.asarray(matrix)
        if arr.ndim != 2:
            raise ValidationError(f"ground-truth matrix must be 2-D [reference, query], got shape {arr.shape}.")
        if not (np.issubdtype(arr.dtype, np.number) or arr.dtype == np.bool_):
            raise ValidationError(f"ground-truth matrix must be numeric or boolean, got dtype {arr.dtype}.")
        return cls(matrix=arr == match_value)

    @classmethod
    def from_pairs(cls, pairs: Iterable[tuple[int, int]], n_reference: int, n_query: int) -> GroundTruth:
        """From ``(query_index, reference_index)`` pairs (0-based), several per query allowed."""
        matrix = np.zeros((int(n_reference), int(n_query)), dtype=bool)
        for k, (q, r) in enumerate(pairs):
            if not 0 <= q < n_query:
                raise ValidationError(
                    f"ground-truth pair {k} has query_index {q}, outside the {n_query} query images (0..{n_query - 1})."
                )
            if not 0 <= r < n_reference:
                raise ValidationError(
                    f"ground-truth pair {k} has reference_index {r}, outside the {n_reference} reference images "
                    f"(0..{n_reference - 1})."
                )
            matrix[r, q] = True
        return cls(matrix=matrix)

    @classmethod
    def from_positions(cls, reference_xy: np.ndarray, query_xy: np.ndarray, tolerance: float) -> GroundTruth:
        """Query ``q`` matches every reference within ``tolerance`` (same unit as the positions, e.g. metres)."""
        ref = np.asarray(reference_xy, dtype=np.float64)
        qry = np.asarray(query_xy, dtype=np.float64)
        if ref.ndim != 2 or qry.ndim != 2 or ref.shape[1] != qry.shape[1]:
            raise ValidationError(
                f"positions must be (n, d) arrays with the same d, got reference {ref.shape} and query {qry.shape}."
            )
        if not (np.isfinite(ref).all() and np.isfinite(qry).all()):
            raise ValidationError("positions must be finite numbers, got NaN or infinity.")
        if not (np.isfinite(tolerance) and tolerance >= 0):
            raise ValidationError(f"position tolerance must be a finite number >= 0, got {tolerance!r}.")
        d2 = ((ref[:, None, :] - qry[None, :, :]) ** 2).sum(axis=-1)
        return cls(matrix=d2 <= float(tolerance) ** 2)

    # ------------------------------------------------------------------ queries
    @property
    def shape(self) -> tuple[int, int]:
        """``(n_reference, n_query)``."""
        return self.matrix.shape  # type: ignore[return-value]

    @property
    def n_reference(self) -> int:
        return int(self.matrix.shape[0])

    @property
    def n_query(self) -> int:
        return int(self.matrix.shape[1])

    def matches(self, query: int) -> np.ndarray:
        """Reference indices that match ``query``."""
        return np.flatnonzero(self.matrix[:, query])

    def has_match(self) -> np.ndarray:
        """Boolean per query: true when the query matches at least one reference."""
        return self.matrix.any(axis=0)

    def is_aligned(self) -> bool:
        """True when this is the identity (query ``i`` matches reference ``i`` only)."""
        n_r, n_q = self.shape
        return n_r == n_q and bool(np.array_equal(self.matrix, np.eye(n_r, dtype=bool)))

    def with_tolerance(self, frames: int) -> GroundTruth:
        """Widen every match by ``frames`` reference indices either side (``0`` returns ``self``)."""
        frames = int(frames)
        if frames < 0:
            raise ValidationError(f"ground-truth tolerance must be >= 0 frames, got {frames}.")
        if frames == 0:
            return self
        widened = self.matrix.copy()
        for shift in range(1, frames + 1):
            widened[shift:] |= self.matrix[:-shift]
            widened[:-shift] |= self.matrix[shift:]
        return GroundTruth(matrix=widened)

    def subset(self, reference: np.ndarray | slice, query: np.ndarray | slice) -> GroundTruth:
        """The ground truth restricted to the given reference and query indices."""
        return GroundTruth(matrix=self.matrix[reference][:, query])

    def pairs(self) -> np.ndarray:
        """``(n, 2)`` array of ``(query_index, reference_index)`` pairs, sorted by query."""
        r, q = np.nonzero(self.matrix)
        order = np.lexsort((r, q))
        return np.stack([q[order], r[order]], axis=1)


_INDEX = re.compile(r"-?[0-9]{1,18}")


def read_pairs_csv(path: str | Path, n_reference: int, n_query: int) -> GroundTruth:
    """Read a ``query_index,reference_index`` CSV (0-based, one pair per line).

    A first line ``query_index,reference_index`` is accepted as a header; blank lines
    and lines starting with ``#`` are skipped.
    """
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise ValidationError(f"ground-truth file {path} cannot be read as text ({exc}).") from exc
    matrix = np.zeros((int(n_reference), int(n_query)), dtype=bool)
    n_pairs = 0
    for lineno, raw in enumerate(text.splitlines(), start=1):
        line = raw.strip()
        if not line or line.startswith("#"):
            continue
        fields = [f.strip() for f in line.split(",")]
        if lineno == 1 and fields == ["query_index", "reference_index"]:
            continue
        if len(fields) != 2 or not all(_INDEX.fullmatch(f) for f in fields):
            raise ValidationError(
                f"ground-truth file {path} line {lineno} is {line!r}, expected 'query_index,reference_index' as two integers."
            )
        q, r = int(fields[0]), int(fields[1])
        if not 0 <= q < n_query:
            raise ValidationError(
                f"ground-truth file {path} line {lineno} has query_index {q}, outside the {n_query} query images "
                f"(0..{n_query - 1})."
            )
        if not 0 <= r < n_reference:
            raise ValidationError(
                f"ground-truth file {path} line {lineno} has reference_index {r}, outside the {n_reference} "
                f"reference images (0..{n_reference - 1})."
            )
        matrix[r, q] = True
        n_pairs += 1
    if n_pairs == 0:
        raise ValidationError(f"ground-truth file {path} lists no query_index,reference_index pairs.")
    return GroundTruth(matrix=matrix)
