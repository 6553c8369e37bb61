"""Reading image files and checking image arrays before anything uses them.

Files are decoded with Pillow. What comes back mirrors what the Modular SNN code
gets from ``cv2.imread``: 8-bit values, RGB channel order (that code flips OpenCV's
BGR to RGB right after reading), the EXIF orientation applied, 16-bit files reduced to
8 bits by dropping the low byte. Grayscale files stay 2-D here (OpenCV would copy the
gray value into three channels; the grayscale conversion of three equal channels
gives the same value back). PNG files decode identically in both libraries; JPEG
decoders of different builds can differ by a gray level.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from neurovpr.errors import ValidationError

__all__ = ["IMAGE_SUFFIXES", "MAX_IMAGE_PIXELS", "is_image_file", "image_size", "read_image", "check_image_array"]

#: File name endings read as images (compared case-insensitively).
IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff", ".ppm", ".pgm", ".pnm", ".webp")


#: Most pixels one image file may declare (Pillow's own decompression-bomb limit); larger files are refused.
MAX_IMAGE_PIXELS = 89_478_485


def image_size(path: str | Path) -> tuple[int, int]:
    """``(width, height)`` of an image file from its header, without decoding the pixels.

    Raises
    ------
    ValidationError
        When the file is missing, empty, not a decodable image, declares more than
        :data:`MAX_IMAGE_PIXELS` pixels, or is smaller than 2 x 2 pixels.
    """
    from PIL import Image, UnidentifiedImageError

    path = Path(path)
    if not path.is_file():
        raise ValidationError(f"image file {path} does not exist.")
    if path.stat().st_size == 0:
        raise ValidationError(f"image file {path} is empty (0 bytes).")
    try:
        with Image.open(path) as opened:
            width, height = opened.size
    except Image.DecompressionBombError as exc:
        raise ValidationError(
            f"image file {path} declares more than the limit of {MAX_IMAGE_PIXELS} pixels per image ({exc})"
        ) from None
    except (UnidentifiedImageError, OSError, ValueError, SyntaxError) as exc:
        raise ValidationError(f"file {path} is not a readable image ({type(exc).__name__}: {exc}).") from None
    if width * height > MAX_IMAGE_PIXELS:
        raise ValidationError(
            f"image file {path} is {width}x{height} pixels ({width * height}), more than the limit of "
            f"{MAX_IMAGE_PIXELS} pixels per image."
        )
    if width < 2 or height < 2:
        raise ValidationError(f"image file {path} is {width}x{height} pixels; an image needs at least 2x2 pixels.")
    return int(width), int(height)


def is_image_file(path: str | Path) -> bool:
    """True when the file name ends with one of :data:`IMAGE_SUFFIXES`."""
    return Path(path).suffix.lower() in IMAGE_SUFFIXES


def read_image(path: str | Path) -> np.ndarray:
    """Decode one image file into a ``uint8`` array ``(H, W)``, ``(H, W, 2)``, ``(H, W, 3)`` or ``(H, W, 4)``.

    Raises
    ------
    ValidationError
        When the file is missing, is not a decodable image, or has a pixel format
        with no 8-bit meaning (32-bit integer or floating-point pixels).
    """
    from PIL import Image, ImageOps, UnidentifiedImageError

    path = Path(path)
    image_size(path)
    try:
        with Image.open(path) as opened:
            opened.load()
            img = ImageOps.exif_transpose(opened)  # cv2.imread applies the EXIF orientation too
            mode = img.mode
            if mode in ("I;16", "I;16B", "I;16L", "I;16N"):
                arr = (np.asarray(img, dtype=np.uint16) >> 8).astype(np.uint8)
            elif mode in ("I", "F"):
                raise ValidationError(
                    f"image file {path} has {mode!r} pixels (32-bit), which have no 8-bit meaning; save it as 8- or 16-bit."
                )
            elif mode == "L":
                arr = np.asarray(img, dtype=np.uint8)
            elif mode == "1":
                arr = np.asarray(img.convert("L"), dtype=np.uint8)
            elif mode == "LA":
                arr = np.asarray(img, dtype=np.uint8)
            elif mode in ("RGBA", "RGBa") or (mode == "P" and "transparency" in img.info):
                arr = np.asarray(img.convert("RGBA"), dtype=np.uint8)
            else:
                arr = np.asarray(img.convert("RGB"), dtype=np.uint8)
    except ValidationError:
        raise
    except (UnidentifiedImageError, OSError, ValueError, SyntaxError) as exc:
        raise ValidationError(f"file {path} is not a readable image ({type(exc).__name__}: {exc}).") from exc
    return check_image_array(arr, name=str(path))


def check_image_array(image: np.ndarray, *, name: str = "image") -> np.ndarray:
    """Return ``image`` as an array after checking it is a usable 2-D image.

    Accepted: 2-D ``(H, W)`` or 3-D ``(H, W, C)`` arrays with ``C`` in 1..4, of an
    integer or floating-point dtype, with finite values and at least one pixel.

    Raises
    ------
    ValidationError
        For any other shape, dtype, an empty array, or NaN/infinite values.
    """
    arr = np.asarray(image)
    if arr.dtype == np.bool_ or not (np.issubdtype(arr.dtype, np.integer) or np.issubdtype(arr.dtype, np.floating)):
        raise ValidationError(f"{name} has dtype {arr.dtype}, expected integer or floating-point pixel values.")
    if arr.ndim not in (2, 3):
        raise ValidationError(
            f"{name} has {arr.ndim} dimension(s) (shape {arr.shape}), expected a 2-D (H, W) or 3-D (H, W, C) image."
        )
    if arr.size == 0 or arr.shape[0] == 0 or arr.shape[1] == 0:
        raise ValidationError(f"{name} is empty (shape {arr.shape}), expected at least one pixel.")
    if arr.ndim == 3 and not 1 <= arr.shape[2] <= 4:
        raise ValidationError(
            f"{name} has {arr.shape[2]} channels (shape {arr.shape}), expected 1 (gray), 2 (gray+alpha), 3 (RGB) or 4 (RGBA)."
        )
    if np.issubdtype(arr.dtype, np.floating) and not np.isfinite(arr).all():
        n_bad = int((~np.isfinite(arr)).sum())
        raise ValidationError(f"{name} has {n_bad} NaN or infinite pixel value(s), expected finite values.")
    return arr
