"""Work-table surfaces under the hand cameras: grey, wood, conveyor belt and green.

Each is a large opaque :class:`PlaneTexture` (1 m x 0.8 m at 1 mm per texel by default) whose
frame is the table frame (origin at its centre, x along its columns, z into the table).
"""

from __future__ import annotations

import cv2
import numpy as np
from numpy.typing import NDArray

from photomodel.sim._conditions import TABLES
from photomodel.sim._textures import (
    MODEL_GREEN_BGR,
    TABLE_GREY_BGR,
    PlaneTexture,
    RngLike,
    _opaque,
    hsv_to_bgr,
)

__all__ = ["make_table"]


def _smooth_noise(shape: tuple[int, int], sigma_px: tuple[float, float],
                  gen: np.random.Generator) -> NDArray[np.float32]:
    """Zero-mean, unit-std smooth noise (H, W), Gaussian-correlated with (sigma_x, sigma_y).

    Drawn on a grid coarsened to about sigma / 3 per cell, blurred there and upsampled
    (bicubic): the same statistics at a fraction of the cost of a wide blur.
    """
    h, w = shape
    fx, fy = max(1.0, sigma_px[0] / 3.0), max(1.0, sigma_px[1] / 3.0)
    small = (max(2, int(np.ceil(w / fx)) + 4), max(2, int(np.ceil(h / fy)) + 4))
    noise = gen.standard_normal((small[1], small[0]), dtype=np.float32)
    noise = cv2.GaussianBlur(noise, (0, 0), sigmaX=sigma_px[0] / fx, sigmaY=sigma_px[1] / fy)
    smooth = cv2.resize(noise, (int(small[0] * fx), int(small[1] * fy)),
                        interpolation=cv2.INTER_CUBIC)[:h, :w]
    return (smooth - smooth.mean()) / max(float(smooth.std()), 1e-12)


def _mottled(colour_bgr: tuple[float, float, float], w: int, h: int, mm_per_px: float,
             gen: np.random.Generator, noise: float, mottle: float) -> PlaneTexture:
    """One colour with per-texel noise and a blotchy shading of about 30 mm features."""
    shade = noise * gen.standard_normal((h, w), dtype=np.float32)
    shade += mottle * _smooth_noise((h, w), (30.0 / mm_per_px, 30.0 / mm_per_px), gen)
    return _opaque(np.asarray(colour_bgr, np.float32)[None, None, :] + shade[..., None],
                   mm_per_px)


def _wood(w: int, h: int, mm_per_px: float, gen: np.random.Generator) -> PlaneTexture:
    """Planks along x, 90-160 mm wide, with growth-ring grain, knots of colour and dark seams."""
    image = np.zeros((h, w, 3), np.float32)
    y = 0
    v, u = np.mgrid[0:h, 0:w].astype(np.float32)
    warp = _smooth_noise((h, w), (60.0 / mm_per_px, 6.0 / mm_per_px), gen)
    fine = _smooth_noise((h, w), (25.0 / mm_per_px, 0.6 / mm_per_px), gen)
    while y < h:
        width = int(gen.uniform(90.0, 160.0) / mm_per_px)
        rows = slice(y, min(y + width, h))
        hsv = [gen.uniform(9.0, 17.0), gen.uniform(95.0, 150.0), gen.uniform(130.0, 190.0)]
        base = hsv_to_bgr(hsv)[0].astype(np.float32)
        period = gen.uniform(4.0, 9.0) / mm_per_px
        phase = (v[rows] + 12.0 * warp[rows] + 0.002 * (u[rows] - w / 2) ** 2 / period)
        rings = 0.5 + 0.5 * np.sin(2 * np.pi * phase / period)
        shade = 1.0 - 0.16 * rings ** 3 + 0.05 * fine[rows]
        image[rows] = base * shade[..., None]
        image[y:y + max(1, int(1.0 / mm_per_px))] *= 0.55  # the seam between planks
        y += width
    return _opaque(image, mm_per_px)


def _conveyor(w: int, h: int, mm_per_px: float, gen: np.random.Generator) -> PlaneTexture:
    """Dark rubber belt running along y: fine diamond tread, scuffs, a splice across it."""
    v, u = np.mgrid[0:h, 0:w].astype(np.float32)
    pitch = 6.0 / mm_per_px
    tread = (np.abs(((u + v) / pitch) % 1.0 - 0.5) < 0.12) | (np.abs(((u - v) / pitch) % 1.0
                                                                     - 0.5) < 0.12)
    level = 58.0 + 9.0 * tread + 3.0 * gen.standard_normal((h, w), dtype=np.float32)
    level += 7.0 * _smooth_noise((h, w), (4.0 / mm_per_px, 60.0 / mm_per_px), gen)  # scuffs
    splice = int(gen.uniform(0.2, 0.8) * h)
    level[splice:splice + max(1, int(3.0 / mm_per_px))] -= 18.0
    tint = np.array([1.04, 1.0, 0.97], np.float32)  # a faintly blue-black rubber
    return _opaque(level[..., None] * tint, mm_per_px)


def make_table(kind: str, rng: RngLike = None, size_mm: tuple[float, float] = (1000.0, 800.0),
               mm_per_px: float = 1.0) -> PlaneTexture:
    """A table surface of the given kind (:data:`TABLES`), drawn from ``rng``.

    Parameters
    ----------
    kind : str
        ``"grey"`` (mid-grey, mottled), ``"wood"`` (planks with grain: hues near the
        garments'), ``"conveyor"`` (dark rubber belt) or ``"green"`` (like the model station's
        plane).
    rng : int or Generator, optional
        Seed or generator.
    size_mm : (float, float)
        (width, height), mm.
    mm_per_px : float
        Texel size, mm.
    """
    gen = np.random.default_rng(rng)
    w, h = round(size_mm[0] / mm_per_px), round(size_mm[1] / mm_per_px)
    if kind == "grey":
        return _mottled(TABLE_GREY_BGR, w, h, mm_per_px, gen, noise=2.0, mottle=3.0)
    if kind == "wood":
        return _wood(w, h, mm_per_px, gen)
    if kind == "conveyor":
        return _conveyor(w, h, mm_per_px, gen)
    if kind == "green":
        return _mottled(MODEL_GREEN_BGR, w, h, mm_per_px, gen, noise=2.0, mottle=6.0)
    raise ValueError(f"kind: expected one of {TABLES}, got {kind!r}")
