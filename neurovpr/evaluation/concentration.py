"""How concentrated the best matches of a distance matrix are.

A model that sends most queries to a few reference places (near-blank frames, places
that own many broadly tuned neurons) can keep a fair Recall@N on a small set and
collapse on a large one; Recall@N does not show it, the concentration of the best
matches does. For a ``[reference, query]`` distance matrix (lower = more alike) each
query's best match is its closest reference (ties: the lowest index, as
:func:`~neurovpr.evaluation.metrics.best_matches`). Reported:

- ``distinct_best_matches``: how many different reference places are some query's best match;
- ``top_share``: the share of the queries whose best match is one of the ``top_places``
  most-chosen reference places, ``top_places = max(1, ceil(top_fraction * R))`` (2 % of
  the ``R`` reference places by default); a model that spreads its matches like the
  ground truth of an aligned traverse gives about ``top_fraction``.
"""

from __future__ import annotations

import math

import numpy as np

from neurovpr.errors import ValidationError
from neurovpr.evaluation.metrics import best_matches

__all__ = ["match_concentration", "most_chosen"]


def most_chosen(distances: np.ndarray, *, top_fraction: float = 0.02) -> tuple[np.ndarray, np.ndarray]:
    """How often each reference place is a query's best match, and the most-chosen places.

    Parameters
    ----------
    distances
        ``[reference, query]`` distance matrix.
    top_fraction
        Fraction of the reference places counted as the most chosen, in (0, 1].

    Returns
    -------
    tuple
        ``(chosen, top)``: ``chosen[r]`` queries have place ``r`` as their best match;
        ``top`` holds the ``max(1, ceil(top_fraction * R))`` most-chosen places, most
        chosen first (ties: the lower index first).
    """
    if not (isinstance(top_fraction, (int, float)) and 0 < top_fraction <= 1):
        raise ValidationError(f"match concentration: top_fraction is {top_fraction!r}, expected a number in (0, 1].")
    idx, _ = best_matches(distances)
    n_ref = np.asarray(distances).shape[0]
    chosen = np.bincount(idx, minlength=n_ref)
    n_top = max(1, math.ceil(top_fraction * n_ref - 1e-9))
    return chosen, np.argsort(-chosen, kind="stable")[:n_top]


def match_concentration(distances: np.ndarray, *, top_fraction: float = 0.02) -> dict[str, float]:
    """``{"distinct_best_matches", "top_places", "top_fraction", "top_share", "queries"}`` of ``distances``.

    Parameters
    ----------
    distances
        ``[reference, query]`` distance matrix.
    top_fraction
        Fraction of the reference places counted as the most chosen, in (0, 1].
    """
    chosen, top = most_chosen(distances, top_fraction=top_fraction)
    n_query = np.asarray(distances).shape[1]
    return {
        "queries": int(n_query),
        "distinct_best_matches": int(np.count_nonzero(chosen)),
        "top_fraction": float(top_fraction),
        "top_places": int(top.size),
        "top_share": float(chosen[top].sum() / n_query),
    }
