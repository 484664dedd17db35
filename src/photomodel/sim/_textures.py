"""Plane textures for the renderer: fabrics, the model station's green plane and the table.

Fabrics: ``plaid`` (tartan), ``plain`` (one colour), ``stripes`` (yarn-dyed stripes), ``dots``
(polka dots), ``print`` (a procedural floral print), ``camo`` (camouflage) and ``photo`` (a
photograph printed on the cloth, from the pictures scikit-image bundles in its wheel). Every
fabric carries the same faint weave and grain. Chromatic colours are drawn from
:data:`PLAID_HUES`, a hue range that keeps off the model station's green and in which no two
colours blend to a green at a shared edge.

Texture frame (mm): x along the texture's columns, y along its rows, z the plane normal pointing
away from the viewer (into the table). Texture pixel (u, v) = (column, row), origin at the centre
of the top-left pixel, lies at ``((u - origin_u) * mm_per_px, (v - origin_v) * mm_per_px, 0)``.
"""

from __future__ import annotations

import importlib.util
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import cv2
import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = [
    "MODEL_GREEN_BGR",
    "PHOTO_PRINTS",
    "PLAID_HUES",
    "PLAIN_HUES",
    "TABLE_GREY_BGR",
    "PlaneTexture",
    "RngLike",
    "camo_fabric",
    "dot_fabric",
    "garment_hues",
    "hsv_to_bgr",
    "photo_fabric",
    "photo_print_image",
    "plaid_fabric",
    "plain_fabric",
    "print_fabric",
    "stripe_fabric",
    "table_plane",
    "uniform_plane",
]

RngLike = int | np.random.Generator | None
"""A seed or a numpy ``Generator`` (``None``: fresh OS entropy); see docs/contracts.md."""

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

    def sample_premultiplied(self, map_u: NDArray[np.float32],
                             map_v: NDArray[np.float32]) -> NDArray[np.float32]:
        """Premultiplied (B, G, R, alpha) (H, W, 4) at texture pixel maps (H, W), bilinear;
        transparent outside the texture."""
        a = self.alpha[..., None]
        layer = np.concatenate([self.image_bgr.astype(np.float32) * a, a], axis=-1)
        return cv2.remap(layer, map_u, map_v, cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT,
                         borderValue=0)

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


# --- More fabrics ---------------------------------------------------------------------------

PHOTO_PRINTS: tuple[str, ...] = ("astronaut", "chelsea", "coffee", "rocket")
"""Pictures for the ``photo`` fabric: colour photographs that scikit-image ships inside its wheel
(``skimage/data/``). They are read from the installed package directory, never downloaded, and
have almost no saturated green (under 0.5 % of their pixels)."""

_PHOTO_FILES: dict[str, str] = {
    "astronaut": "astronaut.png",
    "chelsea": "chelsea.png",
    "coffee": "coffee.png",
    "rocket": "rocket.jpg",
}
_SUPER = 4  # supersampling of drawn prints (area-averaged down: anti-aliased edges)
_DRAW_SHIFT = 4  # fractional bits of drawing coordinates


def _hsv_colours(hues: ArrayLike, sat: ArrayLike, val: ArrayLike) -> NDArray[np.float64]:
    hsv = np.stack(np.broadcast_arrays(np.asarray(hues, float), np.asarray(sat, float),
                                       np.asarray(val, float)), axis=-1)
    return hsv_to_bgr(hsv.reshape(-1, 3))


def _chromatic(n: int, rng: np.random.Generator, sat: tuple[float, float] = (170.0, 250.0),
               val: tuple[float, float] = (110.0, 235.0)) -> NDArray[np.float64]:
    """n saturated BGR colours (n, 3) with well-spread hues in :data:`PLAID_HUES`."""
    return _hsv_colours(garment_hues(n, rng, PLAID_HUES), rng.uniform(*sat, n),
                        rng.uniform(*val, n))


def _ground(rng: np.random.Generator) -> NDArray[np.float64]:
    """A ground colour (3,) BGR: light (white, cream, pastel), dark (navy, wine) or bright."""
    kind = int(rng.integers(3))
    hue = garment_hues(1, rng, PLAID_HUES)[0]
    if kind == 0:  # light: white, cream or a pastel
        return _hsv_colours(hue, rng.uniform(10, 70), rng.uniform(225, 250))[0]
    if kind == 1:  # dark
        return _hsv_colours(hue, rng.uniform(150, 230), rng.uniform(55, 90))[0]
    return _hsv_colours(hue, rng.uniform(180, 240), rng.uniform(150, 220))[0]


def _is_light(bgr: NDArray[np.float64]) -> bool:
    hsv = cv2.cvtColor(np.clip(bgr, 0, 255).astype(np.uint8).reshape(1, 1, 3), cv2.COLOR_BGR2HSV)
    return bool(hsv[0, 0, 2] > 180 and hsv[0, 0, 1] < 90)


def _finish(image: NDArray[np.floating], rng: np.random.Generator, weave_sigma: float,
            mm_per_px: float) -> PlaneTexture:
    h, w = image.shape[:2]
    return _opaque(image + _weave(w, h, rng, weave_sigma)[..., None], mm_per_px)


def _ground_colour(ground_bgr: ArrayLike | None, rng: np.random.Generator) -> NDArray[np.float64]:
    if ground_bgr is None:
        return _ground(rng)
    colour = np.asarray(ground_bgr, dtype=np.float64).reshape(-1)
    if colour.shape != (3,) or not np.all((colour >= 0) & (colour <= 255)):
        raise ValueError(f"ground_bgr: expected 3 values in [0, 255], got {ground_bgr}")
    return colour


def stripe_fabric(
    size_px: tuple[int, int],
    rng: RngLike = None,
    *,
    n_colours: int | None = None,
    ground_bgr: tuple[float, float, float] | None = None,
    vertical: bool | None = None,
    stripe_mm: tuple[float, float] = (1.5, 12.0),
    mm_per_px: float = 0.5,
    weave_sigma: float = 2.5,
) -> PlaneTexture:
    """A yarn-dyed stripe: ground stripes alternating with accent stripes of random widths.

    One repeat holds one or two rounds of the accent colours, each accent stripe between two
    ground stripes; stripe edges fall anywhere within a pixel and are anti-aliased.

    Parameters
    ----------
    size_px : (int, int)
        (width, height) in texture pixels.
    rng : int or Generator, optional
        Seed or generator.
    n_colours : int, optional
        Colours in all, ground included, 2 to 6 (default: 2 to 4, drawn).
    ground_bgr : (3,), optional
        Ground colour, BGR 0-255 (default: drawn: light, dark or bright).
    vertical : bool, optional
        Stripes along the texture's columns (default: drawn; False = horizontal stripes).
    stripe_mm : (float, float)
        Range of stripe widths, mm (ground stripes are at least 1.5 times the minimum).
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
    n = int(gen.integers(2, 5)) if n_colours is None else int(n_colours)
    if not 2 <= n <= 6:
        raise ValueError(f"n_colours: expected 2 to 6, got {n}")
    lo, hi = (float(s) for s in stripe_mm)
    if not 0 < lo <= hi:
        raise ValueError(f"stripe_mm: expected 0 < min <= max, got {stripe_mm}")
    vertical = bool(gen.integers(2)) if vertical is None else bool(vertical)
    palette = np.vstack([_ground_colour(ground_bgr, gen), _chromatic(n - 1, gen)])
    rounds = int(gen.integers(1, 3))
    accents = np.concatenate([gen.permutation(np.arange(1, n)) for _ in range(rounds)])
    colours = np.stack([np.zeros_like(accents), accents], axis=-1).reshape(-1)
    widths = np.where(colours == 0, gen.uniform(min(1.5 * lo, hi), hi, colours.size),
                      gen.uniform(lo, hi, colours.size))
    edges = np.cumsum(widths) / mm_per_px  # stripe ends in one repeat, texture pixels
    length = w if vertical else h
    # Pixel i covers [i - 0.5, i + 0.5]; 8 samples per pixel give its colour by area.
    x = (np.arange(length * 8) + 0.5) / 8 - 0.5 + gen.uniform(0.0, edges[-1])
    index = np.searchsorted(edges, x % edges[-1], side="right")
    line = palette[colours[index]].reshape(length, 8, 3).mean(axis=1)
    image = np.broadcast_to(line[None, :, :] if vertical else line[:, None, :], (h, w, 3))
    return _finish(image.astype(np.float64), gen, weave_sigma, mm_per_px)


def dot_fabric(
    size_px: tuple[int, int],
    rng: RngLike = None,
    *,
    ground_bgr: tuple[float, float, float] | None = None,
    n_dot_colours: int | None = None,
    radius_mm: float | None = None,
    mm_per_px: float = 0.5,
    weave_sigma: float = 2.5,
) -> PlaneTexture:
    """Polka dots of one or two colours on a ground, on a diagonal (half-drop) grid.

    Each pixel shows the dot colour in proportion to the part of it a dot covers (anti-aliased
    edges). On a light ground the dots are saturated colours; on a dark or bright ground the
    first dot colour is white.

    Parameters
    ----------
    size_px : (int, int)
        (width, height) in texture pixels.
    rng : int or Generator, optional
        Seed or generator.
    ground_bgr : (3,), optional
        Ground colour, BGR 0-255 (default: drawn).
    n_dot_colours : int, optional
        1 or 2 (default: drawn); with 2, the two interleaved dot lattices differ in colour.
    radius_mm : float, optional
        Dot radius, mm (default: 1.5 to 5 mm, drawn); the dots lie 3 to 4.2 radii apart.
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
    ground = _ground_colour(ground_bgr, gen)
    k = int(gen.integers(1, 3)) if n_dot_colours is None else int(n_dot_colours)
    if k not in (1, 2):
        raise ValueError(f"n_dot_colours: expected 1 or 2, got {n_dot_colours}")
    r_mm = float(gen.uniform(1.5, 5.0)) if radius_mm is None else float(radius_mm)
    if not r_mm > 0:
        raise ValueError(f"radius_mm: must be positive, got {radius_mm}")
    dots = _chromatic(2, gen)
    if not _is_light(ground):
        dots[0] = _hsv_colours(garment_hues(1, gen, PLAID_HUES), 15.0, 245.0)[0]
    if k == 1:
        dots[1] = dots[0]
    r = r_mm / mm_per_px
    step = r * gen.uniform(3.0, 4.2)  # lattice period; the nearest dots are step / sqrt(2) apart
    offset = gen.uniform(0.0, step, 2)
    v, u = np.mgrid[0:h, 0:w].astype(np.float64)
    image = np.broadcast_to(ground, (h, w, 3)).copy()
    for i, shift in enumerate((0.0, step / 2)):
        du = (u - offset[0] - shift + step / 2) % step - step / 2
        dv = (v - offset[1] - shift + step / 2) % step - step / 2
        cover = np.clip(r - np.hypot(du, dv) + 0.5, 0.0, 1.0)[..., None]
        image += cover * (dots[i] - image)
    return _finish(image, gen, weave_sigma, mm_per_px)


def _draw_ellipse(canvas: NDArray[np.uint8], centre: ArrayLike, axes: ArrayLike,
                  angle_deg: float, colour: NDArray[np.float64]) -> None:
    scale = _SUPER * (1 << _DRAW_SHIFT)
    c = tuple(int(x) for x in np.rint((np.asarray(centre) * _SUPER + (_SUPER - 1) / 2)
                                      * (1 << _DRAW_SHIFT)))
    a = tuple(int(max(x, 1)) for x in np.rint(np.asarray(axes) * scale))
    cv2.ellipse(canvas, c, a, float(angle_deg), 0.0, 360.0,
                tuple(float(x) for x in colour), -1, cv2.LINE_8, _DRAW_SHIFT)


def _flower(canvas: NDArray[np.uint8], c: NDArray[np.float64], size: float,
            rng: np.random.Generator, petal: NDArray[np.float64],
            heart: NDArray[np.float64]) -> None:
    k = int(rng.integers(5, 8))
    a0 = rng.uniform(0.0, 2 * np.pi)
    for a in a0 + 2 * np.pi * np.arange(k) / k:
        d = np.array([np.cos(a), np.sin(a)])
        _draw_ellipse(canvas, c + 0.27 * size * d, (0.27 * size, 0.13 * size),
                      np.degrees(a), petal)
    _draw_ellipse(canvas, c, (0.13 * size, 0.13 * size), 0.0, heart)


def _sprig(canvas: NDArray[np.uint8], c: NDArray[np.float64], size: float,
           rng: np.random.Generator, leaf: NDArray[np.float64]) -> None:
    a = rng.uniform(0.0, 2 * np.pi)
    for da in (-0.6, 0.6, 0.0)[: int(rng.integers(2, 4))]:
        d = np.array([np.cos(a + da), np.sin(a + da)])
        _draw_ellipse(canvas, c + 0.28 * size * d, (0.3 * size, 0.1 * size),
                      np.degrees(a + da), leaf)


def print_fabric(
    size_px: tuple[int, int],
    rng: RngLike = None,
    *,
    ground_bgr: tuple[float, float, float] | None = None,
    n_colours: int | None = None,
    motif_mm: float = 22.0,
    mm_per_px: float = 0.5,
    weave_sigma: float = 2.5,
) -> PlaneTexture:
    """A multicolour floral print: flowers, leaf sprigs and small dots scattered on a ground.

    Motifs sit on a jittered grid, so the print covers the cloth evenly; flowers have five to
    seven petals and a heart of another colour. The leaves are teal to blue, never green.
    Drawn at 4x and area-averaged down (anti-aliased edges).

    Parameters
    ----------
    size_px : (int, int)
        (width, height) in texture pixels.
    rng : int or Generator, optional
        Seed or generator.
    ground_bgr : (3,), optional
        Ground colour, BGR 0-255 (default: drawn: light, dark or bright).
    n_colours : int, optional
        Petal colours, 2 to 6 (default: 3 to 5, drawn).
    motif_mm : float
        Spacing of the motifs, mm (a flower is about as wide).
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
    if not 2 <= n <= 6:
        raise ValueError(f"n_colours: expected 2 to 6, got {n}")
    if not motif_mm > 0:
        raise ValueError(f"motif_mm: must be positive, got {motif_mm}")
    ground = _ground_colour(ground_bgr, gen)
    petals = _chromatic(n, gen)
    hearts = _hsv_colours(gen.uniform(15, 25, n), 230.0, 250.0)  # orange to yellow
    leaf = _hsv_colours(gen.uniform(97, 112), gen.uniform(150, 230), gen.uniform(90, 170))[0]
    canvas = np.empty((h * _SUPER, w * _SUPER, 3), np.uint8)
    canvas[:] = np.clip(np.rint(ground), 0, 255).astype(np.uint8)
    step = motif_mm / mm_per_px
    gu, gv = np.meshgrid(np.arange(-1, w / step + 1), np.arange(-1, h / step + 1))
    cells = np.stack([gu.ravel(), gv.ravel()], axis=-1)
    for cell in cells[gen.permutation(len(cells))]:
        centre = (cell + 0.5 + gen.uniform(-0.3, 0.3, 2)) * step
        size = step * gen.uniform(0.6, 1.0)
        kind = gen.uniform()
        if kind < 0.3:
            _sprig(canvas, centre, size, gen, leaf)
        else:
            if kind < 0.55:
                _sprig(canvas, centre + gen.uniform(-0.3, 0.3, 2) * size, size, gen, leaf)
            i = int(gen.integers(n))
            _flower(canvas, centre, size, gen, petals[i], hearts[(i + 1) % n])
        spot = centre + step * np.array([0.5, 0.5]) + gen.uniform(-0.1, 0.1, 2) * step
        _draw_ellipse(canvas, spot, (0.05 * step, 0.05 * step), 0.0, petals[gen.integers(n)])
    image = cv2.resize(canvas, (w, h), interpolation=cv2.INTER_AREA).astype(np.float64)
    return _finish(image, gen, weave_sigma, mm_per_px)


def camo_fabric(
    size_px: tuple[int, int],
    rng: RngLike = None,
    *,
    n_colours: int | None = None,
    blob_mm: float = 18.0,
    mm_per_px: float = 0.5,
    weave_sigma: float = 2.5,
) -> PlaneTexture:
    """Camouflage: layered blotches of shades of one hue family (sand, wine, navy, ...).

    Each layer is a level set of smooth random noise (with finer noise for ragged edges) painted
    over the ones below it, anti-aliased by its distance to the level line.

    Parameters
    ----------
    size_px : (int, int)
        (width, height) in texture pixels.
    rng : int or Generator, optional
        Seed or generator.
    n_colours : int, optional
        Shades, 2 to 5 (default: 3 or 4, drawn); from dark to light, in a drawn order.
    blob_mm : float
        Typical blotch size, mm.
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
    n = int(gen.integers(3, 5)) if n_colours is None else int(n_colours)
    if not 2 <= n <= 5:
        raise ValueError(f"n_colours: expected 2 to 5, got {n}")
    if not blob_mm > 0:
        raise ValueError(f"blob_mm: must be positive, got {blob_mm}")
    lo, hi = PLAID_HUES
    hue = garment_hues(1, gen, (lo + 8.0, hi - 8.0))[0]
    hues = (hue + gen.uniform(-6.0, 6.0, n)) % 180.0
    colours = _hsv_colours(hues, gen.uniform(70, 200, n),
                           gen.permutation(np.linspace(55, 215, n)))
    sigma = 0.5 * blob_mm / mm_per_px
    image = np.broadcast_to(colours[0], (h, w, 3)).copy()
    for colour in colours[1:]:
        noise = gen.normal(0.0, 1.0, (2, h, w)).astype(np.float32)
        coarse, fine = (cv2.GaussianBlur(z, (0, 0), s).astype(np.float64)
                        for z, s in ((noise[0], sigma), (noise[1], sigma / 4)))
        field = (coarse / max(float(coarse.std()), 1e-12)
                 + 0.25 * fine / max(float(fine.std()), 1e-12))
        gv, gu = np.gradient(field)
        cover = np.clip((field - 0.15) / np.maximum(np.hypot(gu, gv), 1e-9) + 0.5, 0.0, 1.0)
        image += cover[..., None] * (colour - image)
    return _finish(image, gen, weave_sigma, mm_per_px)


@lru_cache(maxsize=len(_PHOTO_FILES))
def photo_print_image(name: str) -> NDArray[np.uint8]:
    """A bundled photograph (H, W, 3) uint8 BGR, read-only, from scikit-image's data folder.

    The file is read from the installed ``skimage`` package (``skimage/data/<file>``) without
    importing it, so nothing is ever downloaded.

    Parameters
    ----------
    name : str
        One of :data:`PHOTO_PRINTS`.

    Raises
    ------
    ValueError
        Unknown name.
    ModuleNotFoundError
        scikit-image is not installed.
    FileNotFoundError
        The installed scikit-image lacks the file.
    """
    if name not in _PHOTO_FILES:
        raise ValueError(f"photo: expected one of {PHOTO_PRINTS}, got {name!r}")
    spec = importlib.util.find_spec("skimage")
    if spec is None or not spec.submodule_search_locations:
        raise ModuleNotFoundError("the photo fabric needs scikit-image (pip install scikit-image)")
    path = Path(next(iter(spec.submodule_search_locations))) / "data" / _PHOTO_FILES[name]
    image = cv2.imread(str(path), cv2.IMREAD_COLOR) if path.is_file() else None
    if image is None:
        raise FileNotFoundError(f"{path}: scikit-image's bundled picture is missing or unreadable")
    image.flags.writeable = False
    return image


def photo_fabric(
    size_px: tuple[int, int],
    rng: RngLike = None,
    *,
    photo: str | None = None,
    tile_mm: float | None = None,
    mm_per_px: float = 0.5,
    weave_sigma: float = 2.0,
) -> PlaneTexture:
    """A photograph printed on cloth: one picture over the whole piece, or mirrored tiles.

    Parameters
    ----------
    size_px : (int, int)
        (width, height) in texture pixels.
    rng : int or Generator, optional
        Seed or generator (the picture when not given, its scale and crop).
    photo : str, optional
        One of :data:`PHOTO_PRINTS` (default: drawn).
    tile_mm : float, optional
        Width of one repeat, mm: the picture is tiled, every other tile mirrored so that the
        repeats meet seamlessly. Default: one picture, scaled to cover the whole piece (1 to
        1.25 times) and cropped at a drawn place.
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
    name = PHOTO_PRINTS[int(gen.integers(len(PHOTO_PRINTS)))] if photo is None else photo
    picture = photo_print_image(name)
    ph, pw = picture.shape[:2]
    if tile_mm is None:
        scale = max(w / pw, h / ph) * gen.uniform(1.0, 1.25)
    else:
        if not tile_mm > 0:
            raise ValueError(f"tile_mm: must be positive, got {tile_mm}")
        scale = tile_mm / mm_per_px / pw
    rw, rh = max(1, round(pw * scale)), max(1, round(ph * scale))
    interp = cv2.INTER_AREA if scale < 1 else cv2.INTER_CUBIC
    tile = cv2.resize(picture, (rw, rh), interpolation=interp)
    if tile_mm is None:  # one picture; rounding may leave it a pixel short
        u0, v0 = int(gen.integers(0, max(rw - w, 0) + 1)), int(gen.integers(0, max(rh - h, 0) + 1))
        tile = np.pad(tile, ((0, max(h - rh, 0)), (0, max(w - rw, 0)), (0, 0)), mode="edge")
    else:  # mirrored repeats, from a drawn place within one period (two tiles)
        u0, v0 = int(gen.integers(0, 2 * rw)), int(gen.integers(0, 2 * rh))
        tile = np.pad(tile, ((0, v0 + h), (0, u0 + w), (0, 0)), mode="symmetric")
    image = tile[v0:v0 + h, u0:u0 + w].astype(np.float64)
    return _finish(image, gen, weave_sigma, mm_per_px)
