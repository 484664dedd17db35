"""Plane textures for the renderer: fabrics, the model station's green plane and the table.

Texture frame (mm): x along the texture's columns, y along its rows, z the plane normal pointing
away from the viewer (into the table). Texture pixel (u, v) = (column, row), origin at the centre
of the top-left pixel, lies at ``((u - origin_u) * mm_per_px, (v - origin_v) * mm_per_px, 0)``.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = [
    "MODEL_GREEN_BGR",
    "PLAID_HUES",
    "PLAIN_HUES",
    "TABLE_GREY_BGR",
    "PlaneTexture",
    "garment_hues",
    "hsv_to_bgr",
    "RngLike",
    "plaid_fabric",
    "plain_fabric",
    "table_plane",
    "uniform_plane",
]

RngLike = int | np.random.Generator | None
"""A seed or a numpy ``Generator`` (``None``: fresh OS entropy); see DESIGN.md."""

MODEL_GREEN_BGR: tuple[int, int, int] = (60, 160, 50)
"""The model station's green plane (saturated green, BGR)."""

TABLE_GREY_BGR: tuple[int, int, int] = (128, 128, 128)
"""The work table's grey (BGR)."""

PLAIN_HUES: tuple[float, float] = (90.0, 215.0)
"""OpenCV hue range (0-180, wrapping) of plain garments: all but the plane's green band."""

PLAID_HUES: tuple[float, float] = (95.0, 205.0)
"""Hue range of plaid stripes (blue to orange): no two of them average to a green."""


@dataclass(frozen=True)
class PlaneTexture:
    """A flat, partly transparent picture lying in the z = 0 plane of its texture frame.

    Parameters
    ----------
    image_bgr : ndarray (H, W, 3) uint8
        Colour, BGR.
    alpha : ndarray (H, W) float32
        Opacity in [0, 1] (1 = opaque, 0 = nothing there).
    mm_per_px : float
        Size of one texture pixel, mm.
    origin_px : ndarray (2,)
        Texture pixel (u, v) at the texture frame's origin.
    """

    image_bgr: NDArray[np.uint8]
    alpha: NDArray[np.float32]
    mm_per_px: float
    origin_px: NDArray[np.float64]

    def __post_init__(self) -> None:
        image = np.asarray(self.image_bgr)
        if image.ndim != 3 or image.shape[2] != 3 or image.dtype != np.uint8:
            raise ValueError(
                f"image_bgr: expected (H, W, 3) uint8, got {image.shape} {image.dtype}")
        alpha = np.asarray(self.alpha, dtype=np.float32)
        if alpha.shape != image.shape[:2]:
            raise ValueError(f"alpha: expected shape {image.shape[:2]}, got {alpha.shape}")
        if not (np.all(alpha >= 0.0) and np.all(alpha <= 1.0)):
            raise ValueError("alpha: values must lie in [0, 1]")
        if not float(self.mm_per_px) > 0:
            raise ValueError(f"mm_per_px: must be positive, got {self.mm_per_px}")
        origin = np.asarray(self.origin_px, dtype=np.float64).reshape(-1)
        if origin.shape != (2,) or not np.isfinite(origin).all():
            raise ValueError(f"origin_px: expected 2 finite values, got {self.origin_px}")
        object.__setattr__(self, "image_bgr", image)
        object.__setattr__(self, "alpha", alpha)
        object.__setattr__(self, "mm_per_px", float(self.mm_per_px))
        object.__setattr__(self, "origin_px", origin)

    @property
    def size_px(self) -> tuple[int, int]:
        """(width, height) in texture pixels."""
        return self.image_bgr.shape[1], self.image_bgr.shape[0]

    @property
    def size_mm(self) -> tuple[float, float]:
        """(width, height) in mm."""
        w, h = self.size_px
        return w * self.mm_per_px, h * self.mm_per_px

    def px_from_mm(self, xy_mm: ArrayLike) -> NDArray[np.float64]:
        """Texture pixels (..., 2) = (u, v) of texture-frame points (..., 2) = (x, y), mm."""
        return np.asarray(xy_mm, dtype=np.float64) / self.mm_per_px + self.origin_px

    def mm_from_px(self, uv: ArrayLike) -> NDArray[np.float64]:
        """Texture-frame points (..., 2) = (x, y), mm, of texture pixels (..., 2) = (u, v)."""
        return (np.asarray(uv, dtype=np.float64) - self.origin_px) * self.mm_per_px


def _size(size_px: tuple[int, int]) -> tuple[int, int]:
    w, h = (int(s) for s in size_px)
    if w < 1 or h < 1:
        raise ValueError(f"size_px: expected (width, height) >= 1, got {size_px}")
    return w, h


def _opaque(image: NDArray[np.floating], mm_per_px: float) -> PlaneTexture:
    h, w = image.shape[:2]
    bgr = np.clip(np.rint(image), 0, 255).astype(np.uint8)
    return PlaneTexture(bgr, np.ones((h, w), np.float32), mm_per_px,
                        np.array([(w - 1) / 2.0, (h - 1) / 2.0]))


def _weave(w: int, h: int, rng: np.random.Generator, sigma: float) -> NDArray[np.float32]:
    """Grey-level (H, W) fabric grain: a faint 2/2 twill plus per-pixel noise, std about sigma."""
    v, u = np.mgrid[0:h, 0:w]
    twill = np.where(((u + v) // 2) % 2 == 0, 1.0, -1.0)
    grain = rng.normal(0.0, 1.0, (h, w))
    return (sigma * (0.5 * twill + 0.85 * grain)).astype(np.float32)


def garment_hues(n: int, rng: RngLike = None,
                 hue_range: tuple[float, float] = PLAIN_HUES) -> NDArray[np.float64]:
    """n well-spread OpenCV hues (n,) in [0, 180), drawn within ``hue_range`` (wrapping at 180).

    The default range keeps garments off the green of the model station's plane.
    """
    gen = np.random.default_rng(rng)
    lo, hi = hue_range
    span = hi - lo
    h = (gen.uniform(0, span) + np.arange(n) * span / n + gen.uniform(-0.1, 0.1, n) * span / n)
    return (lo + h % span) % 180.0


def hsv_to_bgr(hsv: ArrayLike) -> NDArray[np.float64]:
    """BGR colours (N, 3) of OpenCV HSV colours (N, 3) (hue 0-180, saturation and value 0-255)."""
    hsv_u8 = np.clip(np.rint(np.asarray(hsv, dtype=np.float64)), 0, 255).astype(np.uint8)
    return cv2.cvtColor(hsv_u8.reshape(1, -1, 3), cv2.COLOR_HSV2BGR).reshape(-1, 3).astype(float)


def _plaid_palette(n: int, rng: np.random.Generator) -> NDArray[np.float64]:
    """n saturated BGR colours (n, 3) with well-spread hues, plus one dark thread colour."""
    hsv = np.stack([garment_hues(n, rng, PLAID_HUES), rng.uniform(190, 255, n),
                    rng.uniform(120, 235, n)], axis=-1)
    dark = [garment_hues(1, rng, PLAID_HUES)[0], 200.0, 45.0]
    return hsv_to_bgr(np.vstack([hsv, dark]))


def _sett(length: int, n_colours: int, rng: np.random.Generator,
          stripe_px: tuple[int, int]) -> NDArray[np.intp]:
    """Colour index per pixel (length,) of a mirrored tartan stripe sequence."""
    n = int(rng.integers(4, 8))
    widths = rng.integers(stripe_px[0], stripe_px[1] + 1, n)
    # Neighbouring stripes never share a colour.
    colours = (rng.integers(n_colours) + np.cumsum(rng.integers(1, n_colours, n))) % n_colours
    half = np.repeat(colours, widths)
    period = np.concatenate([half, half[::-1]])
    return np.resize(period, length)


def plaid_fabric(
    size_px: tuple[int, int],
    rng: RngLike = None,
    *,
    n_colours: int | None = None,
    stripe_px: tuple[int, int] = (6, 36),
    mm_per_px: float = 0.5,
    weave_sigma: float = 3.0,
) -> PlaneTexture:
    """A colourful plaid (tartan): saturated stripes both ways, woven over each other.

    Where a warp and a weft stripe cross, the fabric shows their average colour (as a camera
    sees a fine twill). Stripe hues lie in :data:`PLAID_HUES`, so no crossing looks green.

    Parameters
    ----------
    size_px : (int, int)
        (width, height) in texture pixels.
    rng : int or Generator, optional
        Seed or generator.
    n_colours : int, optional
        Number of saturated stripe colours (default: 3 to 5, drawn); a dark thread colour
        is added.
    stripe_px : (int, int)
        Range of stripe widths, texture pixels.
    mm_per_px : float
        Texture pixel size, mm.
    weave_sigma : float
        Grey-level std of the fine weave and grain.

    Returns
    -------
    PlaneTexture
        Opaque; origin at the texture centre.
    """
    w, h = _size(size_px)
    gen = np.random.default_rng(rng)
    n = int(gen.integers(3, 6)) if n_colours is None else int(n_colours)
    if n < 2:
        raise ValueError(f"n_colours: expected at least 2, got {n}")
    palette = _plaid_palette(n, gen)
    warp = palette[_sett(w, n + 1, gen, stripe_px)]  # (W, 3), colour of each column's thread
    weft = palette[_sett(h, n + 1, gen, stripe_px)]  # (H, 3), colour of each row's thread
    image = 0.5 * (warp[None, :, :] + weft[:, None, :])
    image += _weave(w, h, gen, weave_sigma)[..., None]
    return _opaque(image, mm_per_px)


def plain_fabric(
    size_px: tuple[int, int],
    colour_bgr: tuple[float, float, float],
    rng: RngLike = None,
    *,
    mm_per_px: float = 0.5,
    weave_sigma: float = 2.5,
) -> PlaneTexture:
    """A single-colour fabric with a faint weave and per-pixel grain (std about 2-3 levels).

    Parameters
    ----------
    size_px : (int, int)
        (width, height) in texture pixels.
    colour_bgr : (3,)
        Mean colour, BGR 0-255.
    rng : int or Generator, optional
        Seed or generator.
    mm_per_px : float
        Texture pixel size, mm.
    weave_sigma : float
        Grey-level std of the weave and grain.
    """
    w, h = _size(size_px)
    gen = np.random.default_rng(rng)
    colour = np.asarray(colour_bgr, dtype=np.float64).reshape(3)
    image = colour[None, None, :] + _weave(w, h, gen, weave_sigma)[..., None]
    return _opaque(image, mm_per_px)


def uniform_plane(
    colour_bgr: tuple[float, float, float] = MODEL_GREEN_BGR,
    size_mm: tuple[float, float] = (600.0, 480.0),
    mm_per_px: float = 0.5,
    rng: RngLike = None,
    noise: float = 1.5,
    mottle: float = 0.0,
) -> PlaneTexture:
    """A large flat surface of one colour: the model station's plane or the table.

    Parameters
    ----------
    colour_bgr : (3,)
        Mean colour, BGR 0-255 (default: the model station's green).
    size_mm : (float, float)
        (width, height), mm.
    mm_per_px : float
        Texture pixel size, mm.
    rng : int or Generator, optional
        Seed or generator.
    noise : float
        Per-pixel grey-level std.
    mottle : float
        Grey-level std of a smooth blotchy shading (features about 15 mm); 0 for none.

    Returns
    -------
    PlaneTexture
        Opaque; origin at its centre.
    """
    w, h = _size((round(size_mm[0] / mm_per_px), round(size_mm[1] / mm_per_px)))
    gen = np.random.default_rng(rng)
    shade = gen.normal(0.0, noise, (h, w)).astype(np.float32)
    if mottle > 0:
        blobs = cv2.GaussianBlur(gen.normal(0.0, 1.0, (h, w)).astype(np.float32), (0, 0),
                                 15.0 / mm_per_px)
        shade += blobs * np.float32(mottle / max(float(blobs.std()), 1e-12))
    colour = np.asarray(colour_bgr, dtype=np.float64).reshape(3)
    return _opaque(colour[None, None, :] + shade[..., None], mm_per_px)


def table_plane(rng: RngLike = None, size_mm: tuple[float, float] = (1000.0, 800.0),
                mm_per_px: float = 1.0) -> PlaneTexture:
    """The hand cameras' grey work table: mid grey with mild mottling, origin at its centre."""
    return uniform_plane(TABLE_GREY_BGR, size_mm, mm_per_px, rng, noise=2.0, mottle=5.0)
