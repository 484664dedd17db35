"""Synthetic garments: a fabric texture cut to a silhouette, with the model frame at its centroid.

The garment frame is the photo-model frame of DESIGN.md: origin at the area centroid of the
silhouette, x along the texture's columns, y along its rows, z into the plane it lies on.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
from numpy.typing import NDArray

from photomodel.sim._textures import (
    PlaneTexture,
    RngLike,
    garment_hues,
    hsv_to_bgr,
    plaid_fabric,
    plain_fabric,
)

__all__ = ["FABRICS", "GARMENT_SHAPES", "Garment", "garment_outline_mm", "make_garment"]

GARMENT_SHAPES: tuple[str, ...] = ("tshirt", "towel", "trousers")
FABRICS: tuple[str, ...] = ("plaid", "plain")

_MARGIN_PX = 4  # transparent border around the silhouette, texture pixels
_AA = 4  # silhouettes are drawn at 4x and area-averaged down
_SHIFT = 4  # fractional bits for cv2.fillPoly

# Outlines in units of the garment's (width, height), y down, clockwise on screen.
_TSHIRT = np.array([
    (0.24, 0.05), (0.37, 0.0), (0.63, 0.0), (0.76, 0.05), (1.0, 0.27), (0.89, 0.42),
    (0.78, 0.33), (0.79, 1.0), (0.21, 1.0), (0.22, 0.33), (0.11, 0.42), (0.0, 0.27),
])
_TROUSERS = np.array([
    (0.1, 0.0), (0.9, 0.0), (0.94, 0.3), (1.0, 1.0), (0.56, 1.0), (0.5, 0.3),
    (0.44, 1.0), (0.0, 1.0), (0.06, 0.3),
])


@dataclass(frozen=True)
class Garment:
    """A flat garment.

    Parameters
    ----------
    name : str
        Label, e.g. ``"tshirt-plaid"``.
    texture : PlaneTexture
        Fabric whose alpha is the silhouette and whose origin is the silhouette's area centroid
        (the garment frame's origin).
    size_mm : (float, float)
        (width, height) of the silhouette's bounding box, mm.
    """

    name: str
    texture: PlaneTexture
    size_mm: tuple[float, float]


def _neck(w: float, h: float, n: int = 12) -> NDArray[np.float64]:
    """Neck cut-out between the outline's 2nd and 3rd points: half ellipse dipping down."""
    t = np.linspace(np.pi, 0.0, n + 2)[1:-1]
    return np.stack([w * (0.5 + 0.13 * np.cos(t)), h * 0.11 * np.sin(t)], axis=-1)


def _rounded_rect(w: float, h: float, n: int = 10) -> NDArray[np.float64]:
    r = 0.08 * min(w, h)
    corners = [(w - r, r, -np.pi / 2), (w - r, h - r, 0.0), (r, h - r, np.pi / 2),
               (r, r, np.pi)]
    pts = []
    for cx, cy, a0 in corners:
        a = a0 + np.linspace(0.0, np.pi / 2, n)
        pts.append(np.stack([cx + r * np.cos(a), cy + r * np.sin(a)], axis=-1))
    return np.concatenate(pts)


def garment_outline_mm(shape: str, size_mm: tuple[float, float]) -> NDArray[np.float64]:
    """Silhouette polygon (N, 2), mm, in bounding-box coordinates ((0, 0) = top-left corner).

    Parameters
    ----------
    shape : str
        One of :data:`GARMENT_SHAPES`.
    size_mm : (float, float)
        (width, height) of the bounding box, mm.
    """
    w, h = (float(s) for s in size_mm)
    if not (w > 0 and h > 0):
        raise ValueError(f"size_mm: expected positive (width, height), got {size_mm}")
    if shape == "tshirt":
        pts = _TSHIRT * (w, h)
        return np.concatenate([pts[:2], _neck(w, h), pts[2:]])
    if shape == "towel":
        return _rounded_rect(w, h)
    if shape == "trousers":
        return _TROUSERS * (w, h)
    raise ValueError(f"shape: expected one of {GARMENT_SHAPES}, got {shape!r}")


def _silhouette(outline_px: NDArray[np.float64], size_px: tuple[int, int]) -> NDArray[np.float32]:
    """Anti-aliased coverage (H, W) of a polygon given in texture pixels (u, v)."""
    w, h = size_px
    # Texture pixel u covers 4x pixels 4u .. 4u + 3, whose centres are at 4u + 1.5.
    fine = np.rint((outline_px * _AA + (_AA - 1) / 2) * (1 << _SHIFT)).astype(np.int32)
    mask = np.zeros((h * _AA, w * _AA), np.float32)
    cv2.fillPoly(mask, [fine.reshape(-1, 1, 2)], 1.0, lineType=cv2.LINE_8, shift=_SHIFT)
    return cv2.resize(mask, (w, h), interpolation=cv2.INTER_AREA)


def _area_centroid_px(alpha: NDArray[np.float32]) -> NDArray[np.float64]:
    v, u = np.indices(alpha.shape, dtype=np.float64)
    a = alpha.astype(np.float64)
    return np.array([(a * u).sum(), (a * v).sum()]) / a.sum()


def make_garment(
    shape: str,
    fabric: str,
    size_mm: tuple[float, float] = (200.0, 160.0),
    rng: RngLike = None,
    mm_per_px: float = 0.5,
    colour_bgr: tuple[float, float, float] | None = None,
    name: str | None = None,
) -> Garment:
    """Make a garment: a fabric cut to a silhouette, origin at the silhouette's area centroid.

    Parameters
    ----------
    shape : str
        ``"tshirt"`` (body, two sleeves, neck cut-out), ``"towel"`` (rounded rectangle) or
        ``"trousers"``.
    fabric : str
        ``"plaid"`` (colourful tartan) or ``"plain"`` (one colour).
    size_mm : (float, float)
        (width, height) of the silhouette's bounding box, mm (the paper's models are up to
        250 x 200 mm).
    rng : int or Generator, optional
        Seed or generator for the fabric (and the plain colour when not given).
    mm_per_px : float
        Texture pixel size, mm.
    colour_bgr : (3,), optional
        Colour of a plain fabric (default: a saturated, non-green colour drawn from ``rng``);
        ignored for plaid.
    name : str, optional
        Default ``f"{shape}-{fabric}"``.
    """
    if fabric not in FABRICS:
        raise ValueError(f"fabric: expected one of {FABRICS}, got {fabric!r}")
    if not mm_per_px > 0:
        raise ValueError(f"mm_per_px: must be positive, got {mm_per_px}")
    outline = garment_outline_mm(shape, size_mm)
    gen = np.random.default_rng(rng)
    w_px = int(np.ceil(size_mm[0] / mm_per_px)) + 2 * _MARGIN_PX
    h_px = int(np.ceil(size_mm[1] / mm_per_px)) + 2 * _MARGIN_PX
    # Bounding-box corner (0, 0) mm is the outer corner of pixel (_MARGIN_PX, _MARGIN_PX).
    alpha = _silhouette(outline / mm_per_px + (_MARGIN_PX - 0.5), (w_px, h_px))
    if fabric == "plaid":
        cloth = plaid_fabric((w_px, h_px), gen, mm_per_px=mm_per_px)
    else:
        if colour_bgr is None:
            hsv = [garment_hues(1, gen)[0], gen.uniform(150, 240), gen.uniform(90, 210)]
            colour_bgr = tuple(hsv_to_bgr(hsv)[0])
        cloth = plain_fabric((w_px, h_px), colour_bgr, gen, mm_per_px=mm_per_px)
    texture = PlaneTexture(cloth.image_bgr, alpha, mm_per_px, _area_centroid_px(alpha))
    return Garment(name or f"{shape}-{fabric}", texture,
                   (float(size_mm[0]), float(size_mm[1])))
