"""What :class:`~neurovpr.runtime.simulation.Simulation` checks and computes for weights a user writes.

One validator for every way weights are written (``set_weights``, ``normalise_weights``, on
every backend), and the reference computation of the per-neuron normalisation that a backend
may do faster in its own storage (with the same sums in the same order).
"""

from __future__ import annotations

import math

import numpy as np

from neurovpr.errors import ValidationError
from neurovpr.ir.network import Network

__all__ = ["check_weight_range", "check_normalisation", "normalised"]


def check_weight_range(network: Network, projection: str, lo: float, hi: float, *, finite: bool = True) -> None:
    """Refuse new weights of ``projection`` whose smallest is ``lo`` and largest ``hi`` when it cannot hold them.

    Parameters
    ----------
    network
        The simulated network.
    projection
        The projection's name.
    lo, hi
        The smallest and largest new weight (ignored when ``finite`` is False).
    finite
        Whether every new weight is a finite number.

    Raises
    ------
    ValidationError
        NaN or infinite weights, weights outside the synapse's ``weight_bounds``, or negative
        weights onto conductance-based cells or an inhibitory receptor.
    """
    proj = network.projections[projection]
    if not (finite and math.isfinite(lo) and math.isfinite(hi)):
        raise ValidationError(f"set_weights: weights for {projection!r} contain NaN or infinite values.")
    bounds = proj.synapse.weight_bounds
    if bounds is not None and (lo < bounds[0] or hi > bounds[1]):
        raise ValidationError(
            f"set_weights: weights for {projection!r} must lie in [{bounds[0]}, {bounds[1]}], got [{lo:g}, {hi:g}]."
        )
    post_pop = network.populations[proj.post]
    if (post_pop.cell_type.conductance_based or proj.receptor_type == "inhibitory") and lo < 0:
        raise ValidationError(f"set_weights: weights for {projection!r} must be >= 0, got {lo:g}.")


def check_normalisation(projection: str, total: object, w_max: object) -> tuple[float, float | None]:
    """``total`` and ``w_max`` of ``normalise_weights`` as floats, or a one-sentence ``ValidationError``."""
    for name, value in (("total", total), ("w_max", w_max)):
        if name == "w_max" and value is None:
            continue
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not (math.isfinite(value) and value > 0):
            raise ValidationError(f"normalise_weights: {name} for {projection!r} is {value!r}, expected a finite number > 0.")
    return float(total), None if w_max is None else float(w_max)  # type: ignore[arg-type]


def normalised(w: np.ndarray, post: np.ndarray, n_post: int, total: float, w_max: float | None) -> np.ndarray:
    """Weights ``w`` (one per connection onto neuron ``post``) scaled so that each neuron's sum is ``total``.

    The sums are taken in connection order (``np.bincount``); a neuron whose weights sum to
    0 or less keeps them; the scaled weights are then clipped at ``w_max`` when given.
    """
    sums = np.bincount(post, weights=w, minlength=n_post)
    factor = np.divide(total, sums, out=np.ones_like(sums), where=sums > 0)
    out = w * factor[post]
    return out if w_max is None else np.minimum(out, w_max, out=out)
