"""LoCS-Net's input: grayscale images resized to the network's input, values in [0, 1].

Each image is resized with bilinear interpolation (OpenCV's ``INTER_LINEAR`` sample
positions, :func:`neurovpr.data.preprocess.resize_linear`) and converted to grayscale
(ITU-R 601 weights). With ``patch_norm`` (the default) every pixel is then normalised
by the mean and standard deviation of the ``patch_size`` square patch around it
(patches at the border use the pixels inside the image; a flat patch gives 0; clipped
to [-1, 1], as :func:`neurovpr.data.preprocess.patch_normalise` defines it) and mapped
to [0, 1] by ``(1 + x) / 2``; without it the gray level is divided by 255. Patch
normalisation removes the global brightness and contrast that change most between
seasons. The patch statistics are computed with box sums, so they agree with
:func:`~neurovpr.data.preprocess.patch_normalise` to rounding (not bit for bit).
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence

import numpy as np

from neurovpr.data.preprocess import resized_gray
from neurovpr.errors import ValidationError

__all__ = ["to_gray", "box_patch_normalise", "preprocess", "DEFAULT_PATCH_SIZE"]

#: Side of the normalisation patch (the Modular SNN's 7x7 on 28x28, doubled with the input).
DEFAULT_PATCH_SIZE = 13


def to_gray(image: np.ndarray, size: tuple[int, int], *, name: str = "image") -> np.ndarray:
    """One image (H, W) or (H, W, C) resized to ``size`` and converted to gray, float 0..255 (no warnings)."""
    return resized_gray(image, size, name=name, warn=False)


def _box_sum(a: np.ndarray, half: int) -> np.ndarray:
    """Sum over the ``(2 half + 1)`` square around every pixel of ``a`` (N, H, W), zero outside."""
    n, h, w = a.shape
    padded = np.zeros((n, h + 2 * half + 1, w + 2 * half + 1))
    padded[:, half + 1 : half + 1 + h, half + 1 : half + 1 + w] = a
    c = padded.cumsum(axis=1).cumsum(axis=2)
    k = 2 * half + 1
    return c[:, k:, k:] - c[:, :-k, k:] - c[:, k:, :-k] + c[:, :-k, :-k]


def box_patch_normalise(images: np.ndarray, patch_size: int = DEFAULT_PATCH_SIZE) -> np.ndarray:
    """Patch normalisation of (N, H, W) images with box sums; values in [-1, 1]."""
    if isinstance(patch_size, bool) or not isinstance(patch_size, int) or patch_size < 1 or patch_size % 2 == 0:
        raise ValidationError(f"patch size must be an odd integer >= 1, got {patch_size!r}.")
    x = np.asarray(images, dtype=np.float64)
    half = patch_size // 2
    count = _box_sum(np.ones_like(x[:1]), half)
    mean = _box_sum(x, half) / count
    var = np.maximum(_box_sum(x * x, half) / count - mean * mean, 0.0)
    std = np.sqrt(var)
    with np.errstate(divide="ignore", invalid="ignore"):
        norm = np.where(std > 1e-9 * np.maximum(1.0, np.abs(mean)), (x - mean) / std, 0.0)
    return np.clip(norm, -1.0, 1.0)


def preprocess(
    images: np.ndarray | Iterable[np.ndarray],
    size: tuple[int, int] = (56, 56),
    *,
    patch_norm: bool = True,
    patch_size: int = DEFAULT_PATCH_SIZE,
    names: Sequence[str] | None = None,
) -> np.ndarray:
    """Images to network input: float (N, height, width) in [0, 1]."""
    seq = list(images) if not isinstance(images, np.ndarray) or images.ndim in (3, 4) else None
    if seq is None:
        raise ValidationError(
            f"preprocess needs a stack (N, H, W) or (N, H, W, C) or a sequence of images, got shape {np.shape(images)}."
        )
    if not seq:
        raise ValidationError("preprocess got no images, expected at least one.")
    gray = np.stack([to_gray(img, size, name=names[i] if names is not None else f"image {i}")
                     for i, img in enumerate(seq)])
    if not patch_norm:
        return np.clip(gray / 255.0, 0.0, 1.0)
    return (1.0 + box_patch_normalise(gray, patch_size)) / 2.0
