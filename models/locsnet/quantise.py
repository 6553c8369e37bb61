"""A chip's weight format, read from its hwspec, and rounding weights to it.

Loihi stores each synaptic weight as a signed mantissa (7 bits of magnitude plus a
sign on Kapoho Bay and Loihi 2, ``[formats] weight_mantissa_bits``) with one exponent
per synapse group (``weight_scaling = "per-synapse-group"``); NengoLoihi and Lava scale
each projection so its largest weight uses the full mantissa. Every projection of
LoCS-Net feeds its own population, so the weights of one layer lie on a uniform grid
of step ``max|W| / (2**mantissa_bits - 1)``. This module computes that grid; the
numbers come from the hwspec file, none is written here.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from neurovpr.errors import ValidationError

__all__ = ["WeightFormat", "weight_format", "quantise_weights", "quantise_parameters"]


@dataclass(frozen=True, slots=True, kw_only=True)
class WeightFormat:
    """Per-layer uniform weight grid: ``levels`` steps of magnitude either side of zero.

    Attributes
    ----------
    hardware
        The hwspec it was read from.
    mantissa_bits
        Magnitude bits of a weight.
    """

    hardware: str
    mantissa_bits: int

    def __post_init__(self) -> None:
        if isinstance(self.mantissa_bits, bool) or not isinstance(self.mantissa_bits, int) or not 1 <= self.mantissa_bits <= 24:
            raise ValidationError(f"WeightFormat.mantissa_bits must be an integer in 1..24, got {self.mantissa_bits!r}.")

    @property
    def levels(self) -> int:
        """Largest mantissa magnitude: ``2**mantissa_bits - 1``."""
        return (1 << self.mantissa_bits) - 1


def weight_format(hardware: str) -> WeightFormat:
    """The weight format of the hwspec ``hardware`` (e.g. ``"kapoho-bay"``, ``"loihi2"``)."""
    from neurovpr.hardware.hwspec import load_hwspec

    spec = load_hwspec(hardware)
    fmt = spec.formats
    if fmt.weight_scaling != "per-synapse-group":
        raise ValidationError(
            f"hwspec {spec.name!r} scales weights {fmt.weight_scaling!r}; quantisation-aware training of LoCS-Net "
            "supports 'per-synapse-group' scaling only."
        )
    if not fmt.weight_signed:
        raise ValidationError(f"hwspec {spec.name!r} has unsigned weights; LoCS-Net needs signed weights.")
    return WeightFormat(hardware=spec.name, mantissa_bits=int(fmt.weight_mantissa_bits))


def quantise_weights(weights: np.ndarray, fmt: WeightFormat) -> np.ndarray:
    """``weights`` rounded to the layer's grid (step ``max|w| / levels``)."""
    w = np.asarray(weights, dtype=np.float64)
    top = float(np.abs(w).max()) if w.size else 0.0
    if top == 0.0:
        return w.copy()
    step = top / fmt.levels
    return np.round(w / step) * step


def quantise_parameters(params: dict[str, np.ndarray], fmt: WeightFormat) -> dict[str, np.ndarray]:
    """Every ``*.weight`` array rounded to its grid; biases are kept (Loihi's bias format is far finer)."""
    return {k: quantise_weights(v, fmt) if k.endswith(".weight") else np.array(v, dtype=np.float64)
            for k, v in params.items()}
