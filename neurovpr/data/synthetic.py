"""Procedural synthetic traverses with realistic appearance change, for the demo and tests.

A route is a long side-looking panorama ("strip") of a landscape: a sky with clouds,
a hilly horizon, textured ground, and objects along the way (trees, houses, poles).
Place ``i`` is the camera window starting at ``i * step`` pixels. The layout of the
world (terrain, objects, their sizes and wall colours, fine ground texture) is fixed by
``seed``; the reference and query traverses render it under different conditions:

- **season** (0 = same as the reference, 1 = deep winter): snow on the ground, roofs
  and tree crowns, bare trees, and the fine ground texture partly redrawn;
- **weather**: a different cloud field in the sky for every traverse;
- **illumination** and **contrast**: a global gain and a contrast scale around mid-gray,
  with a small random jitter per image (sun behind clouds);
- **blur**: Gaussian blur (motion, focus, rain on the lens);
- **shift**: the query window is displaced by up to ``shift_px`` pixels sideways and
  ``shift_px // 4`` vertically (the vehicle never stops at exactly the same spot);
- **noise**: Gaussian sensor noise.

Everything is drawn with numpy from ``numpy.random.Generator`` streams derived from the
seed, so the same arguments give the same images on every machine.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.ndimage import gaussian_filter, gaussian_filter1d

from neurovpr.data.ground_truth import GroundTruth
from neurovpr.data.traverse import ImageSet, Traverse
from neurovpr.errors import ValidationError

__all__ = ["AppearanceChange", "render_route", "synthetic_traverse"]


@dataclass(frozen=True, slots=True, kw_only=True)
class AppearanceChange:
    """How one traverse's appearance differs from the world's summer look (see the module docstring)."""

    season: float = 0.0
    illumination: float = 1.0
    contrast: float = 1.0
    blur_sigma: float = 0.0
    shift_px: int = 0
    noise_std: float = 0.01
    jitter: float = 0.05

    def __post_init__(self) -> None:
        checks = {
            "season": (0.0, 1.0),
            "illumination": (0.05, 4.0),
            "contrast": (0.05, 4.0),
            "blur_sigma": (0.0, 20.0),
            "noise_std": (0.0, 1.0),
            "jitter": (0.0, 0.5),
        }
        for name, (lo, hi) in checks.items():
            value = float(getattr(self, name))
            if not (np.isfinite(value) and lo <= value <= hi):
                raise ValidationError(f"AppearanceChange.{name} is {value!r}, expected a number in [{lo}, {hi}].")
        if not 0 <= int(self.shift_px) <= 64:
            raise ValidationError(f"AppearanceChange.shift_px is {self.shift_px!r}, expected 0..64 pixels.")

    @classmethod
    def reference(cls) -> AppearanceChange:
        """A summer day: the reference traverse's look."""
        return cls()

    @classmethod
    def winter_dusk(cls) -> AppearanceChange:
        """The default query: winter at dusk, slightly blurred, a few pixels off the reference path."""
        return cls(season=0.8, illumination=0.55, contrast=0.7, blur_sigma=0.8, shift_px=3, noise_std=0.03)


def _smooth1d(rng: np.random.Generator, n: int, sigma: float) -> np.ndarray:
    x = gaussian_filter1d(rng.standard_normal(n), sigma, mode="wrap")
    return x / (x.std() + 1e-12)


def _field(rng: np.random.Generator, shape: tuple[int, int], sigma: float) -> np.ndarray:
    f = gaussian_filter(rng.standard_normal(shape), sigma, mode="wrap")
    return f / (f.std() + 1e-12)


@dataclass(frozen=True, slots=True)
class _Object:
    kind: int  # 0 tree, 1 house, 2 pole
    x: int
    width: int
    height: int
    colour: tuple[float, float, float]


def _layout(rng: np.random.Generator, height: int, length: int) -> tuple[np.ndarray, list[_Object], np.ndarray]:
    """Terrain profile, objects and fixed ground texture: the parts of the world that never change."""
    horizon = height * 0.5 + height * 0.1 * _smooth1d(rng, length, 30.0)
    objects: list[_Object] = []
    x = int(rng.integers(0, 8))
    while x < length:
        kind = int(rng.choice(3, p=(0.55, 0.3, 0.15)))
        if kind == 0:
            w, h = int(rng.integers(4, 11)), int(height * rng.uniform(0.25, 0.55))
        elif kind == 1:
            w, h = int(rng.integers(8, 20)), int(height * rng.uniform(0.2, 0.4))
        else:
            w, h = 1, int(height * rng.uniform(0.3, 0.6))
        colour = tuple(float(c) for c in rng.uniform(0.25, 0.95, size=3))
        objects.append(_Object(kind=kind, x=x, width=w, height=max(h, 3), colour=colour))  # type: ignore[arg-type]
        x += w + int(rng.integers(2, 14))
    texture = _field(rng, (height, length), 1.2)
    return horizon, objects, texture


def _render_strip(
    height: int,
    length: int,
    layout: tuple[np.ndarray, list[_Object], np.ndarray],
    season: float,
    rng: np.random.Generator,
) -> np.ndarray:
    """The whole route as an RGB float image in [0, 1] for one season and weather."""
    horizon, objects, fixed_texture = layout
    y = np.arange(height, dtype=np.float64)[:, None]
    sky_mask = y < horizon[None, :]
    img = np.empty((height, length, 3))
    # sky: brighter towards the horizon, clouds differ between traverses (weather)
    clouds = np.clip(_field(rng, (height, length), 5.0), 0, None)
    grad = (y / height)[..., None]
    sky_top = np.array([0.35, 0.5, 0.8]) * (1 - season) + np.array([0.6, 0.62, 0.66]) * season
    sky = sky_top + 0.3 * grad + 0.15 * clouds[..., None]
    # ground: green in summer, snow in winter; fine texture partly redrawn by the season
    season_texture = _field(rng, (height, length), 1.2)
    texture = (1 - 0.6 * season) * fixed_texture + 0.6 * season * season_texture
    ground_base = np.array([0.3, 0.45, 0.2]) * (1 - season) + np.array([0.88, 0.9, 0.93]) * season
    depth = np.clip((y - horizon[None, :]) / height, 0, 1)[..., None]
    ground = ground_base - 0.15 * depth + 0.07 * texture[..., None]
    img[:] = np.where(sky_mask[..., None], sky, ground)
    # objects standing on the horizon line
    snow = np.array([0.92, 0.93, 0.95])
    for obj in objects:
        x0, x1 = obj.x, min(obj.x + obj.width, length)
        if x0 >= length:
            break
        base = round(float(horizon[min((x0 + x1) // 2, length - 1)])) + 1
        top = max(base - obj.height, 0)
        if top >= base:
            continue
        region = img[top:base, x0:x1]
        rows = np.arange(top, base)[:, None]
        cols = np.arange(x0, x1)[None, :]
        colour = np.asarray(obj.colour)
        if obj.kind == 0:  # tree: trunk and an elliptic crown; winter makes it bare and snowy
            cx, half_w = (x0 + x1 - 1) / 2.0, max(obj.width / 2.0, 1.0)
            trunk = np.broadcast_to(np.abs(cols - cx) <= max(half_w / 4.0, 0.5), region.shape[:2])
            crown_h = obj.height * 0.7
            cy = top + crown_h / 2.0
            crown = ((cols - cx) / half_w) ** 2 + ((rows - cy) / (crown_h / 2.0)) ** 2 <= 1.0
            leaves = np.array([0.12, 0.3 + 0.2 * colour[1], 0.1])
            bare = np.array([0.3, 0.27, 0.25])
            crown_col = leaves * (1 - season) + (bare * 0.8 + snow * 0.2) * season
            region[trunk] = np.array([0.25, 0.18, 0.12])
            region[crown & ~(trunk & (rows > cy))] = crown_col
        elif obj.kind == 1:  # house: wall, roof, windows; winter puts snow on the roof
            roof_h = max(2, obj.height // 3)
            wall = colour * (0.8 + 0.2 * (1 - season))
            region[:] = wall
            roof_col = np.array([0.45, 0.15, 0.12]) * (1 - season) + snow * season
            region[:roof_h] = roof_col
            win = ((rows - top - roof_h) % 4 == 1) & ((cols - x0) % 4 == 1) & (rows > top + roof_h)
            region[win] = np.array([0.1, 0.1, 0.15]) + 0.5 * season * np.array([0.8, 0.7, 0.3])
        else:  # pole
            region[:] = np.array([0.15, 0.15, 0.15])
    return np.clip(img, 0.0, 1.0)


def _camera(
    strip: np.ndarray, x0: int, y0: int, height: int, width: int, change: AppearanceChange, rng: np.random.Generator
) -> np.ndarray:
    """One camera image from the strip, with the photometric changes applied; uint8 RGB."""
    pad = strip.shape[0] - height
    y0 = int(np.clip(y0 + pad // 2, 0, pad))
    window = strip[y0 : y0 + height, x0 : x0 + width].copy()
    if change.blur_sigma > 0:
        window = gaussian_filter(window, sigma=(change.blur_sigma, change.blur_sigma, 0), mode="nearest")
    gain = change.illumination * (1.0 + rng.uniform(-change.jitter, change.jitter))
    window = (window - 0.5) * change.contrast + 0.5
    window = window * gain
    if change.noise_std > 0:
        window = window + rng.normal(0.0, change.noise_std, size=window.shape)
    return np.clip(np.rint(window * 255.0), 0, 255).astype(np.uint8)


def render_route(
    n_places: int,
    change: AppearanceChange,
    *,
    height: int = 32,
    width: int = 64,
    step: int = 16,
    seed: int = 0,
    traverse_seed: int = 1,
) -> np.ndarray:
    """Images ``(n_places, height, width, 3)`` (uint8 RGB) of one traverse of the route ``seed``.

    ``traverse_seed`` picks the weather, per-image jitter, shifts and noise of this
    traverse; the world itself depends only on ``seed``, ``height`` and the route length.
    """
    if int(n_places) < 1:
        raise ValidationError(f"synthetic route needs n_places >= 1, got {n_places}.")
    if not (8 <= height <= 1024 and 8 <= width <= 1024 and 1 <= step <= 4 * width):
        raise ValidationError(
            f"synthetic route needs 8..1024 pixel height and width and a step of 1..4*width, got {height}x{width}, step {step}."
        )
    margin = 64
    strip_h = height + 2 * (margin // 4)
    length = n_places * step + width + 2 * margin
    layout = _layout(np.random.default_rng([seed, 0]), strip_h, length)
    rng = np.random.default_rng([seed, 1, traverse_seed])
    strip = _render_strip(strip_h, length, layout, change.season, rng)
    out = np.empty((n_places, height, width, 3), dtype=np.uint8)
    for i in range(n_places):
        dx = int(rng.integers(-change.shift_px, change.shift_px + 1)) if change.shift_px else 0
        dy = int(rng.integers(-(change.shift_px // 4), change.shift_px // 4 + 1)) if change.shift_px >= 4 else 0
        out[i] = _camera(strip, margin + i * step + dx, dy, height, width, change, rng)
    return out


def synthetic_traverse(
    n_places: int = 100,
    *,
    height: int = 32,
    width: int = 64,
    step: int = 16,
    seed: int = 0,
    reference: AppearanceChange | None = None,
    query: AppearanceChange | None = None,
    name: str | None = None,
) -> Traverse:
    """A synthetic reference/query traverse pair, aligned by index (query ``i`` is place ``i``).

    Defaults: the reference is a summer day (:meth:`AppearanceChange.reference`), the
    query winter at dusk (:meth:`AppearanceChange.winter_dusk`). Write it to disk with
    :func:`neurovpr.data.generic.write_generic`.
    """
    ref_change = reference if reference is not None else AppearanceChange.reference()
    qry_change = query if query is not None else AppearanceChange.winter_dusk()
    kw = {"height": height, "width": width, "step": step, "seed": seed}
    ref = render_route(n_places, ref_change, traverse_seed=1, **kw)
    qry = render_route(n_places, qry_change, traverse_seed=2, **kw)
    return Traverse(
        name=name or f"synthetic-{seed}",
        references=(ImageSet(name="reference", array=ref),),
        query=ImageSet(name="query", array=qry),
        ground_truth=GroundTruth.aligned(n_places),
    )
