"""The Modular SNN paper's image preprocessing: 28x28 grayscale, 7x7 patch normalisation.

Hussaini, Milford & Fischer (T-RO 2024) and their published code (QVPR/VPRSNN,
``tools/data_utils.py: processImage``) turn every image into the network input by

1. resizing it to 28x28 pixels with OpenCV's bilinear interpolation
   (``cv2.resize(img, (28, 28))``, default ``INTER_LINEAR``), on the RGB image;
2. converting it to grayscale (``cv2.cvtColor(img, cv2.COLOR_RGB2GRAY)``,
   Y = 0.299 R + 0.587 G + 0.114 B);
3. patch-normalising it: every pixel minus the mean of the 7x7 patch centred on it,
   divided by that patch's standard deviation (population std, ``ddof=0``), where
   patches at the border only use the pixels inside the image (the image is padded
   with NaN and ``nanmean``/``nanstd`` are used); 0/0 (a flat patch) becomes 0; the
   result is clipped to [-1, 1];
4. scaling to 0..255 with ``uint8(255 * (1 + x) / 2)`` (truncation, so 0 -> 127).

This module computes the same thing without OpenCV. Resizing uses OpenCV's
``INTER_LINEAR`` sample positions (pixel centres: ``src = (dst + 0.5) * scale - 0.5``,
clamped at the borders, no anti-aliasing); for ``uint8`` input it also uses OpenCV 4's
11-bit fixed-point weights and the rounding of its vectorised code. The grayscale
conversion of ``uint8`` input is OpenCV 4's integer formula
``(9798 R + 19235 G + 3735 B + 16384) >> 15``, and the patch statistics are summed in
the same order as VPRSNN's ``nanmean``/``nanstd`` calls. For ``uint8`` RGB input the
result is bit-identical to VPRSNN's ``processImage`` with OpenCV 4.14 (checked on the
4,800 nordland64 images and on random images of random sizes). Other dtypes are
processed in floating point without intermediate rounding.

Which inputs are accepted: the paper's pipeline resizes any input to 28x28 and
converts it to grayscale, so RGB and grayscale images of any size are accepted
silently. Two cases are accepted with a ``UserWarning``: an image smaller than 28
pixels in height or width (it is upsampled, which invents detail the paper's data
never needed) and an image with an alpha channel (2 or 4 channels; the alpha is
ignored, as ``cv2.imread`` ignores it). Refused with a
:class:`~neurovpr.errors.ValidationError`: NaN or infinite values, empty arrays,
1-D or more than 3-D arrays, other channel counts, non-numeric arrays and files that
are not images.
"""

from __future__ import annotations

import warnings
from collections.abc import Iterable, Sequence

import numpy as np

from neurovpr.data.images import check_image_array
from neurovpr.errors import ValidationError

__all__ = [
    "INPUT_SIZE",
    "PATCH_SIZE",
    "resize_linear",
    "rgb_to_gray",
    "resized_gray",
    "patch_normalise",
    "to_uint8_range",
    "preprocess_image",
    "preprocess_images",
]

#: Network input size (height, width) of the Modular SNN (Hussaini et al. 2024).
INPUT_SIZE = (28, 28)
#: Side of the square patch used for patch normalisation (Hussaini et al. 2024).
PATCH_SIZE = 7

_COEF_BITS = 11  # OpenCV INTER_RESIZE_COEF_BITS
_COEF_SCALE = 1 << _COEF_BITS


def _axis_weights(src: int, dst: int, *, clamp_weight: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """OpenCV INTER_LINEAR source indices and weights along one axis.

    OpenCV sets the weight of a clamped border sample to 0 along x but keeps it along y
    (both source rows are then the same clipped row); ``clamp_weight`` picks which.
    """
    scale = src / dst
    d = np.arange(dst, dtype=np.float64)
    f = ((d + 0.5) * scale - 0.5).astype(np.float32)  # OpenCV computes the position in single precision
    s = np.floor(f).astype(np.int64)
    frac = (f - s.astype(np.float32)).astype(np.float64)
    if clamp_weight:
        low = s < 0
        frac[low] = 0.0
        s[low] = 0
        high = s >= src - 1
        frac[high] = 0.0
        s[high] = src - 1
    return np.clip(s, 0, src - 1), np.clip(s + 1, 0, src - 1), frac


def resize_linear(image: np.ndarray, height: int, width: int) -> np.ndarray:
    """Resize like ``cv2.resize(image, (width, height))`` with ``INTER_LINEAR``.

    ``uint8`` input gives ``uint8`` output computed with OpenCV's 11-bit fixed-point
    weights and the rounding of its vectorised vertical pass
    (``((S0 >> 4) * b0 >> 16) + ((S1 >> 4) * b1 >> 16) + 2 >> 2``); any other dtype
    gives ``float64`` output.
    """
    arr = np.asarray(image)
    src_h, src_w = arr.shape[:2]
    if (src_h, src_w) == (height, width):
        return arr.copy() if arr.dtype == np.uint8 else arr.astype(np.float64)
    ys0, ys1, fy = _axis_weights(src_h, height, clamp_weight=False)
    xs0, xs1, fx = _axis_weights(src_w, width, clamp_weight=True)
    shape_x = (1, width) + (1,) * (arr.ndim - 2)
    shape_y = (height, 1) + (1,) * (arr.ndim - 2)
    if arr.dtype == np.uint8:
        ax0 = np.rint((1.0 - fx) * _COEF_SCALE).astype(np.int64)
        ax1 = np.rint(fx * _COEF_SCALE).astype(np.int64)
        by0 = np.rint((1.0 - fy) * _COEF_SCALE).astype(np.int64)
        by1 = np.rint(fy * _COEF_SCALE).astype(np.int64)
        src = arr.astype(np.int64)
        rows = src[:, xs0] * ax0.reshape(shape_x) + src[:, xs1] * ax1.reshape(shape_x)
        top = ((rows[ys0] >> 4) * by0.reshape(shape_y)) >> 16
        bottom = ((rows[ys1] >> 4) * by1.reshape(shape_y)) >> 16
        return np.clip((top + bottom + 2) >> 2, 0, 255).astype(np.uint8)
    src = arr.astype(np.float64)
    rows = src[:, xs0] * (1.0 - fx).reshape(shape_x) + src[:, xs1] * fx.reshape(shape_x)
    return rows[ys0] * (1.0 - fy).reshape(shape_y) + rows[ys1] * fy.reshape(shape_y)


def rgb_to_gray(image: np.ndarray) -> np.ndarray:
    """Grayscale like ``cv2.cvtColor(image, cv2.COLOR_RGB2GRAY)`` for ``(H, W, 3)`` RGB input."""
    arr = np.asarray(image)
    if arr.ndim != 3 or arr.shape[2] != 3:
        raise ValidationError(f"rgb_to_gray needs an (H, W, 3) RGB image, got shape {arr.shape}.")
    if arr.dtype == np.uint8:
        rgb = arr.astype(np.int64)
        gray = (rgb[..., 0] * 9798 + rgb[..., 1] * 19235 + rgb[..., 2] * 3735 + (1 << 14)) >> 15
        return gray.astype(np.uint8)
    rgb = arr.astype(np.float64)
    return rgb[..., 0] * 0.299 + rgb[..., 1] * 0.587 + rgb[..., 2] * 0.114


def patch_normalise(images: np.ndarray, patch_size: int = PATCH_SIZE) -> np.ndarray:
    """Normalise every pixel by the mean and std of the ``patch_size`` square patch centred on it.

    Works on one ``(H, W)`` image or a stack ``(..., H, W)``. Border patches use only
    the pixels inside the image; a flat patch gives 0; values are clipped to [-1, 1].
    """
    if patch_size < 1 or patch_size % 2 == 0:
        raise ValidationError(f"patch_size must be an odd number >= 1, got {patch_size}.")
    arr = np.asarray(images, dtype=np.float64)
    if arr.ndim < 2:
        raise ValidationError(f"patch_normalise needs (H, W) or (..., H, W) images, got shape {arr.shape}.")
    lead = arr.shape[:-2]
    h, w = arr.shape[-2:]
    flat = arr.reshape((-1, h, w))
    half = (patch_size - 1) // 2
    out = np.empty_like(flat)
    chunk = max(1, 4_000_000 // (h * w * patch_size * patch_size))
    for start in range(0, flat.shape[0], chunk):
        block = flat[start : start + chunk]
        padded = np.pad(block, ((0, 0), (half, half), (half, half)), constant_values=np.nan)
        windows = np.lib.stride_tricks.sliding_window_view(padded, (patch_size, patch_size), axis=(1, 2))
        # (patch pixels, images * pixels), reduced over axis 0 like VPRSNN's get_patches2D, so the
        # floating-point sums are added in the same order and the result is bit-identical
        patches = np.ascontiguousarray(np.moveaxis(windows, (3, 4), (0, 1))).reshape(patch_size * patch_size, -1)
        mus = np.nanmean(patches, axis=0).reshape(block.shape)
        stds = np.nanstd(patches, axis=0).reshape(block.shape)
        with np.errstate(divide="ignore", invalid="ignore"):
            norm = (block - mus) / stds
        norm[np.isnan(norm)] = 0.0
        out[start : start + chunk] = np.clip(norm, -1.0, 1.0)
    return out.reshape((*lead, h, w))


def to_uint8_range(normalised: np.ndarray) -> np.ndarray:
    """Map patch-normalised values in [-1, 1] to 0..255 as ``uint8(255 * (1 + x) / 2)`` (truncating)."""
    x = np.asarray(normalised, dtype=np.float64)
    return (255.0 * (1.0 + x) / 2.0).astype(np.uint8)


def resized_gray(image: np.ndarray, size: tuple[int, int], *, name: str = "image", warn: bool = True) -> np.ndarray:
    """One image (H, W) or (H, W, C) resized to ``size`` (bilinear) and converted to gray, float 0..255.

    Parameters
    ----------
    image
        The image; checked by :func:`neurovpr.data.images.check_image_array`.
    size
        Output (height, width).
    name
        How errors and warnings name the image.
    warn
        Warn when the image is upsampled or carries an alpha channel (which is ignored).
    """
    arr = check_image_array(image, name=name)
    h, w = arr.shape[:2]
    if warn and (h < size[0] or w < size[1]):
        warnings.warn(
            f"{name} is {h}x{w} pixels, smaller than the {size[0]}x{size[1]} network input; it is upsampled.",
            UserWarning,
            stacklevel=3,
        )
    if arr.ndim == 3:
        channels = arr.shape[2]
        if warn and channels in (2, 4):
            warnings.warn(f"{name} has an alpha channel ({channels} channels); the alpha is ignored.", UserWarning, stacklevel=3)
        arr = arr[..., 0] if channels in (1, 2) else arr[..., :3]
    if arr.dtype != np.uint8:
        arr = arr.astype(np.float64)
    resized = resize_linear(arr, size[0], size[1])
    if resized.ndim == 3:
        resized = rgb_to_gray(resized)
    return np.asarray(resized, dtype=np.float64)


def preprocess_image(
    image: np.ndarray, *, size: tuple[int, int] = INPUT_SIZE, patch_size: int = PATCH_SIZE, name: str = "image"
) -> np.ndarray:
    """One image through the paper's pipeline: ``uint8`` array of shape ``size`` with values 0..255.

    Parameters
    ----------
    image
        ``(H, W)`` grayscale or ``(H, W, C)`` image, ``C`` in 1..4 (RGB order).
    size
        Output ``(height, width)``; the paper uses 28x28.
    patch_size
        Side of the normalisation patch; the paper uses 7.
    name
        How errors and warnings refer to the image (e.g. its file name).
    """
    gray = resized_gray(image, size, name=name)
    return to_uint8_range(patch_normalise(gray, patch_size))


def preprocess_images(
    images: np.ndarray | Iterable[np.ndarray],
    *,
    size: tuple[int, int] = INPUT_SIZE,
    patch_size: int = PATCH_SIZE,
    names: Sequence[str] | None = None,
) -> np.ndarray:
    """Preprocess a stack or sequence of images; returns ``uint8`` ``(N, height, width)``.

    A 3-D array is read as a stack of 2-D grayscale images ``(N, H, W)`` and a 4-D one
    as ``(N, H, W, C)``.
    """
    if isinstance(images, np.ndarray) and images.ndim in (3, 4):
        seq: Iterable[np.ndarray] = list(images)
    elif isinstance(images, np.ndarray):
        raise ValidationError(
            f"preprocess_images needs a stack (N, H, W) or (N, H, W, C) or a sequence of images, "
            f"got an array of shape {images.shape}."
        )
    else:
        seq = images
    grays = []
    for i, img in enumerate(seq):
        label = names[i] if names is not None else f"image {i}"
        grays.append(resized_gray(img, size, name=label))
    if not grays:
        raise ValidationError("preprocess_images got no images, expected at least one.")
    return to_uint8_range(patch_normalise(np.stack(grays), patch_size))
