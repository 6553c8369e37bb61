"""Seeded random distributions for weights, delays and connector in-degrees.

A distribution is data; it is sampled by the code that expands a projection, with a
``numpy.random.Generator`` derived from the compile seed and the projection's name,
so every backend draws the same numbers for the same seed.
"""

from __future__ import annotations

import math
from dataclasses import KW_ONLY, dataclass

import numpy as np

from neurovpr.errors import ValidationError
from neurovpr.ir.node import IRNode, param

__all__ = ["Distribution", "Uniform", "Normal", "DISTRIBUTIONS"]

#: The first parameter may be given by position (``Normal(0.3, sigma=0.1)``), the rest by keyword.
_FIRST_POSITIONAL = {"frozen": True, "slots": True, "eq": False}


class Distribution(IRNode):
    """Base of the random distributions."""

    __slots__ = ()

    def sample(self, rng: np.random.Generator, n: int) -> np.ndarray:
        """Draw ``n`` values with ``rng``."""
        raise NotImplementedError

    @property
    def mean(self) -> float:
        """The distribution's mean (before clipping)."""
        raise NotImplementedError


@dataclass(**_FIRST_POSITIONAL)
class Uniform(Distribution):
    """Uniform on ``[low, high)``."""

    low: float = param(0.0)
    _: KW_ONLY
    high: float = param(1.0)

    def _validate(self) -> None:
        if not self.high > self.low:
            raise ValidationError(f"Uniform.high ({self.high!r}) must exceed low ({self.low!r}).")

    def sample(self, rng: np.random.Generator, n: int) -> np.ndarray:
        return rng.uniform(self.low, self.high, size=n)

    @property
    def mean(self) -> float:
        return 0.5 * (self.low + self.high)


@dataclass(**_FIRST_POSITIONAL)
class Normal(Distribution):
    """Normal ``N(mu, sigma)``, clipped to ``[low, high]`` (PyNN's ``normal_clipped_to_boundary``)."""

    mu: float = param(0.0)
    _: KW_ONLY
    sigma: float = param(1.0, low=0.0)
    low: float = param(-math.inf, high=None)
    high: float = param(math.inf)

    def __post_init__(self) -> None:
        for name in ("mu", "sigma", "low", "high"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
                raise ValidationError(f"Normal.{name} must be a number, got {value!r}.")
            object.__setattr__(self, name, float(value))
        if not (math.isfinite(self.mu) and math.isfinite(self.sigma)) or self.sigma < 0:
            raise ValidationError(
                f"Normal needs a finite mu and sigma >= 0, got mu={self.mu!r}, sigma={self.sigma!r}."
            )
        if math.isnan(self.low) or math.isnan(self.high) or not self.high >= self.low:
            raise ValidationError(f"Normal.high ({self.high!r}) must be >= low ({self.low!r}).")

    def sample(self, rng: np.random.Generator, n: int) -> np.ndarray:
        return np.clip(rng.normal(self.mu, self.sigma, size=n), self.low, self.high)

    @property
    def mean(self) -> float:
        return self.mu


DISTRIBUTIONS: dict[str, type[Distribution]] = {c.__name__: c for c in (Uniform, Normal)}
