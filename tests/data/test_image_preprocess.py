"""The Modular SNN preprocessing: resize, grayscale, patch normalisation, 0..255 scaling, bad input."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from PIL import Image

from neurovpr.data.images import read_image
from neurovpr.data.preprocess import (
    patch_normalise,
    preprocess_image,
    preprocess_images,
    resize_linear,
    rgb_to_gray,
    to_uint8_range,
)
from neurovpr.errors import ValidationError


def test_resize_uses_opencv_pixel_centres_and_fixed_point_rounding():
    src = np.array([[0.0, 100.0]])
    # OpenCV INTER_LINEAR 2 -> 4: sample points -0.25 (clamped), 0.25, 0.75, 1.25 (clamped)
    assert resize_linear(src, 1, 4).tolist() == [[0.0, 25.0, 75.0, 100.0]]
    # uint8: 11-bit weights; 100 * 512 / 2048 = 25 exactly, and 1 -> 0.25 rounds 0.25 -> 0
    assert resize_linear(np.array([[0, 100]], dtype=np.uint8), 1, 4).tolist() == [[0, 25, 75, 100]]
    assert resize_linear(np.array([[0, 1]], dtype=np.uint8), 1, 4).tolist() == [[0, 0, 1, 1]]


def test_resize_matches_values_recorded_from_opencv():
    # cv2.resize(img, (4, 5)) with OpenCV 4.14 (upsampling: border rows keep their weights)
    img = np.array([[10, 200, 37], [255, 0, 91], [3, 128, 77]], dtype=np.uint8)
    assert resize_linear(img, 5, 4).tolist() == [
        [10, 129, 139, 37],
        [108, 115, 97, 58],
        [255, 96, 34, 91],
        [104, 87, 79, 82],
        [3, 81, 109, 77],
    ]
    rgb = (np.arange(5 * 7 * 3).reshape(5, 7, 3) * 3 % 256).astype(np.uint8)
    assert resize_linear(rgb, 2, 3).tolist() == [
        [[53, 56, 59], [74, 77, 80], [95, 98, 101]],
        [[168, 171, 152], [168, 171, 174], [189, 192, 195]],
    ]


def test_resize_halving_is_the_2x2_mean():
    rng = np.random.default_rng(0)
    img = rng.uniform(0, 255, size=(56, 56))
    expected = img.reshape(28, 2, 28, 2).mean(axis=(1, 3))
    np.testing.assert_allclose(resize_linear(img, 28, 28), expected, atol=1e-4)


def test_gray_matches_opencv_integer_formula():
    rgb = np.array(
        [[[255, 0, 0], [0, 255, 0], [0, 0, 255], [255, 255, 255], [172, 181, 16], [92, 45, 84], [232, 79, 147]]],
        dtype=np.uint8,
    )
    # values cv2.cvtColor(..., COLOR_RGB2GRAY) returns in OpenCV 4.14; the last three are where a
    # 14-bit formula (4899, 9617, 1868) would be off by one
    assert rgb_to_gray(rgb).tolist() == [[76, 150, 29, 255, 160, 63, 132]]
    np.testing.assert_allclose(rgb_to_gray(rgb.astype(float))[0, :3], [76.245, 149.685, 29.07])


def _direct_patch_normalise(img: np.ndarray, k: int) -> np.ndarray:
    h, w = img.shape
    half = k // 2
    out = np.zeros_like(img, dtype=float)
    for y in range(h):
        for x in range(w):
            patch = img[max(0, y - half) : y + half + 1, max(0, x - half) : x + half + 1].astype(float)
            mu, sd = patch.mean(), patch.std()
            out[y, x] = 0.0 if sd == 0 else np.clip((img[y, x] - mu) / sd, -1, 1)
    return out


def test_patch_normalisation_matches_a_direct_computation():
    rng = np.random.default_rng(1)
    img = rng.integers(0, 256, size=(28, 28)).astype(float)
    img[:6, :6] = 50.0  # a flat corner: 0/0 patches become 0
    np.testing.assert_allclose(patch_normalise(img, 7), _direct_patch_normalise(img, 7), atol=1e-12)
    stack = np.stack([img, img[::-1]])
    np.testing.assert_allclose(patch_normalise(stack, 7)[1], _direct_patch_normalise(img[::-1], 7), atol=1e-12)


def test_uint8_scaling_truncates_like_vprsnn():
    assert to_uint8_range(np.array([-1.0, 0.0, 1.0, 0.5])).tolist() == [0, 127, 255, 191]


def test_preprocess_pipeline_shape_and_gray_rgb_equivalence():
    rng = np.random.default_rng(2)
    gray = rng.integers(0, 256, size=(32, 64), dtype=np.uint8)
    out = preprocess_image(gray)
    assert out.shape == (28, 28) and out.dtype == np.uint8
    rgb = np.repeat(gray[..., None], 3, axis=2)
    np.testing.assert_array_equal(preprocess_image(rgb), out)
    expected = to_uint8_range(_direct_patch_normalise(resize_linear(gray, 28, 28).astype(float), 7))
    np.testing.assert_array_equal(out, expected)
    flat = preprocess_image(np.full((40, 40, 3), 200, dtype=np.uint8))
    assert (flat == 127).all()


def test_preprocess_images_stack_equals_one_by_one():
    rng = np.random.default_rng(3)
    stack = rng.integers(0, 256, size=(3, 32, 64, 3), dtype=np.uint8)
    out = preprocess_images(stack)
    assert out.shape == (3, 28, 28)
    for i in range(3):
        np.testing.assert_array_equal(out[i], preprocess_image(stack[i]))


def test_normal_inputs_do_not_warn():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        preprocess_image(np.zeros((64, 64, 3), dtype=np.uint8))
        preprocess_image(np.zeros((28, 28), dtype=np.float32))


@pytest.mark.parametrize(
    ("image", "needle"),
    [
        (np.zeros((10, 64, 3), dtype=np.uint8), "smaller than the 28x28"),
        (np.zeros((64, 64, 4), dtype=np.uint8), "alpha channel"),
        (np.zeros((64, 64, 2), dtype=np.uint8), "alpha channel"),
    ],
)
def test_resized_or_alpha_inputs_warn(image, needle):
    with pytest.warns(UserWarning, match=needle):
        out = preprocess_image(image)
    assert out.shape == (28, 28)


@pytest.mark.parametrize(
    ("image", "needle"),
    [
        (np.array([[1.0, np.nan], [0.0, 1.0]]), "NaN or infinite"),
        (np.zeros((0, 5)), "empty"),
        (np.zeros(100), "1 dimension"),
        (np.zeros((2, 28, 28, 3)), "4 dimension"),
        (np.zeros((28, 28, 5)), "5 channels"),
        (np.array([["a", "b"], ["c", "d"]]), "dtype"),
        (np.zeros((28, 28), dtype=bool), "dtype"),
    ],
)
def test_bad_images_are_refused(image, needle):
    with pytest.raises(ValidationError, match=needle):
        preprocess_image(image, name="probe")


def test_read_image_files(tmp_path):
    gray = np.arange(64 * 32, dtype=np.uint16).reshape(32, 64) * 30
    Image.fromarray(gray.astype(np.uint16)).save(tmp_path / "deep.png")
    assert read_image(tmp_path / "deep.png").tolist() == (gray >> 8).astype(np.uint8).tolist()
    rgb = np.random.default_rng(4).integers(0, 256, size=(32, 64, 3), dtype=np.uint8)
    Image.fromarray(rgb).save(tmp_path / "rgb.png")
    np.testing.assert_array_equal(read_image(tmp_path / "rgb.png"), rgb)
    (tmp_path / "fake.png").write_text("this is not an image")
    with pytest.raises(ValidationError, match=r"fake\.png is not a readable image"):
        read_image(tmp_path / "fake.png")
    with pytest.raises(ValidationError, match="does not exist"):
        read_image(tmp_path / "missing.png")
