"""Synthetic garments: a fabric texture cut to a silhouette, with the model frame at its centroid.

The garment frame is the photo-model frame of docs/contracts.md: origin at the area centroid of the
silhouette, x along the texture's columns, y along its rows, z into the plane it lies on.

Silhouettes are simple polygons in bounding-box millimetres (y down), clockwise on screen,
touching all four sides of their box; curved edges (necklines, crotches, hems, heels) are
sampled finely enough that the rasterised outline looks smooth at 0.5 mm per pixel.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import cv2
import numpy as np
from numpy.typing import NDArray

from photomodel.sim._textures import (
    PlaneTexture,
    RngLike,
    camo_fabric,
    dot_fabric,
    garment_hues,
    hsv_to_bgr,
    photo_fabric,
    plaid_fabric,
    plain_fabric,
    print_fabric,
    stripe_fabric,
)

if TYPE_CHECKING:
    from photomodel.sim._labels import GarmentLabel

__all__ = ["FABRICS", "GARMENT_SHAPES", "Garment", "garment_outline_mm", "make_garment"]

GARMENT_SHAPES: tuple[str, ...] = (
    "tshirt", "towel", "trousers", "longsleeve", "shorts", "skirt", "sock", "dress", "vest",
)
"""Silhouettes of :func:`garment_outline_mm` (the first three are the original ones)."""

FABRICS: tuple[str, ...] = ("plaid", "plain", "stripes", "dots", "print", "camo", "photo")
"""Fabrics of :func:`make_garment`."""

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
    shape : str
        Silhouette name (one of :data:`GARMENT_SHAPES`; ``"user"`` for a garment cut from a
        photo; empty when unknown).
    fabric : str
        Fabric name (one of :data:`FABRICS`; ``"photo"`` for a user's garment; may be empty).
    description : str
        Words for people, e.g. ``"navy chinos"``.
    plane_bgr : (3,), optional
        Colour (BGR 0-255) of the model station's plane this garment is photographed on
        (:func:`~photomodel.sim.render_model_photos`); None: the green
        :data:`~photomodel.sim.MODEL_GREEN_BGR`.
    label : GarmentLabel or None
        The printed label pasted into ``texture`` (:func:`~photomodel.sim.labelled_garment`),
        None when it carries none.
    """

    name: str
    texture: PlaneTexture
    size_mm: tuple[float, float]
    shape: str = ""
    fabric: str = ""
    description: str = ""
    plane_bgr: tuple[int, int, int] | None = None
    label: GarmentLabel | None = None


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


_Point = tuple[float, float]
_CURVE_POINTS = 16  # samples per Bezier segment


def _path(start: _Point, *segments: tuple[_Point, ...]) -> NDArray[np.float64]:
    """Closed outline (N, 2) from ``start`` through segments, each given by its points after the
    current one: 1 point = straight line, 2 = quadratic Bezier (control, end), 3 = cubic
    (control, control, end). The last end may repeat ``start``; it is not repeated in the output.
    """
    pts: list[NDArray[np.float64]] = [np.asarray([start], dtype=np.float64)]
    t = np.linspace(0.0, 1.0, _CURVE_POINTS + 1)[1:, None]
    for seg in segments:
        p0 = pts[-1][-1]
        q = [np.asarray(x, dtype=np.float64) for x in seg]
        if len(q) == 1:
            pts.append(q[0][None])
        elif len(q) == 2:
            pts.append((1 - t) ** 2 * p0 + 2 * (1 - t) * t * q[0] + t**2 * q[1])
        else:
            pts.append((1 - t) ** 3 * p0 + 3 * (1 - t) ** 2 * t * q[0]
                       + 3 * (1 - t) * t**2 * q[1] + t**3 * q[2])
    out = np.concatenate(pts)
    return out[:-1] if np.allclose(out[-1], out[0]) else out


def _fit(unit: NDArray[np.float64], w: float, h: float) -> NDArray[np.float64]:
    """Scale an outline so that its bounding box is exactly [0, w] x [0, h]."""
    lo, hi = unit.min(axis=0), unit.max(axis=0)
    return (unit - lo) / (hi - lo) * (w, h)


# Outlines in units of the garment's (width, height), y down, clockwise on screen; _fit makes
# them touch their box exactly.
_LONGSLEEVE = _path(
    (0.40, 0.0),
    ((0.5, 0.16), (0.60, 0.0)),  # crew neck
    ((0.73, 0.045),),  # shoulder
    ((0.88, 0.10), (0.97, 0.42), (1.0, 0.82)),  # sleeve, outer edge
    ((0.895, 0.875),),  # cuff
    ((0.715, 0.37),),  # sleeve, inner edge, to the armpit
    ((0.725, 1.0),), ((0.275, 1.0),), ((0.285, 0.37),),  # side, hem, side
    ((0.105, 0.875),), ((0.0, 0.82),),
    ((0.03, 0.42), (0.12, 0.10), (0.27, 0.045)),
    ((0.40, 0.0),),
)
_SHORTS = _path(
    (0.07, 0.0), ((0.93, 0.0),), ((0.93, 0.12),), ((0.945, 0.12),),  # waistband
    ((0.985, 0.45), (1.0, 0.9)),  # hip to hem
    ((0.575, 1.0),),  # right leg hem
    ((0.535, 0.67),), ((0.5, 0.60), (0.465, 0.67)),  # inside leg, round crotch
    ((0.425, 1.0),), ((0.0, 0.9),),
    ((0.015, 0.45), (0.055, 0.12)),
    ((0.07, 0.12),), ((0.07, 0.0),),
)
_SKIRT = _path(
    (0.27, 0.0), ((0.73, 0.0),), ((0.73, 0.09),), ((0.745, 0.09),),  # waistband
    ((0.88, 0.48), (1.0, 0.92)),  # slightly convex A-line side
    ((0.5, 1.08), (0.0, 0.92)),  # curved hem
    ((0.12, 0.48), (0.255, 0.09)),
    ((0.27, 0.09),), ((0.27, 0.0),),
)
_SOCK = _path(
    (0.0, 0.0), ((0.55, 0.0),),  # cuff
    ((0.55, 0.52),),  # front of the leg
    ((0.555, 0.64), (0.70, 0.64)),  # instep
    ((0.80, 0.645),),  # top of the foot
    ((1.02, 0.645), (1.02, 1.0), (0.80, 1.0)),  # toe
    ((0.24, 1.0),),  # sole
    ((0.04, 1.0), (-0.03, 0.86), (0.0, 0.62)),  # heel
    ((0.0, 0.0),),  # back of the leg
)
_DRESS = _path(
    (0.30, 0.0), ((0.38, 0.0),),  # left strap
    ((0.40, 0.18), (0.60, 0.18), (0.62, 0.0)),  # neckline
    ((0.70, 0.0),),  # right strap
    ((0.71, 0.14), (0.74, 0.22), (0.80, 0.25)),  # armhole
    ((0.78, 0.35), (0.72, 0.44)),  # bodice to the waist
    ((1.0, 0.93),),  # flared skirt
    ((0.5, 1.07), (0.0, 0.93)),  # hem
    ((0.28, 0.44),), ((0.22, 0.35), (0.20, 0.25)),
    ((0.26, 0.22), (0.29, 0.14), (0.30, 0.0)),
)
_VEST = _path(
    (0.22, 0.0), ((0.36, 0.0),),
    ((0.37, 0.25), (0.63, 0.25), (0.64, 0.0)),  # scoop neck
    ((0.78, 0.0),),
    ((0.79, 0.20), (0.86, 0.33), (1.0, 0.36)),  # armhole
    ((0.985, 0.97),),  # side
    ((0.5, 1.03), (0.015, 0.97)),  # hem
    ((0.0, 0.36),),
    ((0.14, 0.33), (0.21, 0.20), (0.22, 0.0)),
)
_FITTED: dict[str, NDArray[np.float64]] = {
    "longsleeve": _LONGSLEEVE, "shorts": _SHORTS, "skirt": _SKIRT, "sock": _SOCK,
    "dress": _DRESS, "vest": _VEST,
}


def garment_outline_mm(shape: str, size_mm: tuple[float, float]) -> NDArray[np.float64]:
    """Silhouette polygon (N, 2), mm, in bounding-box coordinates ((0, 0) = top-left corner).

    Parameters
    ----------
    shape : str
        One of :data:`GARMENT_SHAPES`: ``"tshirt"`` (short sleeves, neck cut-out), ``"towel"``
        (rounded rectangle), ``"trousers"``, ``"longsleeve"`` (sleeves angled down along the
        body, crew neck), ``"shorts"`` (waistband, rounded crotch), ``"skirt"`` (A-line,
        waistband, curved hem), ``"sock"`` (L-shaped, leg up and foot to the right, rounded
        heel and toe), ``"dress"`` (straps, neckline, fitted waist, flared skirt) or ``"vest"``
        (tank top: wide straps, scoop neck, deep armholes).
    size_mm : (float, float)
        (width, height) of the bounding box, mm.

    Returns
    -------
    ndarray (N, 2)
        Vertices (x, y), mm, of a simple polygon, clockwise on screen (y down), touching all
        four sides of the box ``[0, width] x [0, height]``.
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
    if shape in _FITTED:
        return _fit(_FITTED[shape], w, h)
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
    *,
    photo: str | None = None,
    description: str = "",
    photo_tile_mm: float | None = None,
) -> Garment:
    """Make a garment: a fabric cut to a silhouette, origin at the silhouette's area centroid.

    Parameters
    ----------
    shape : str
        One of :data:`GARMENT_SHAPES` (see :func:`garment_outline_mm`).
    fabric : str
        One of :data:`FABRICS`: ``"plaid"`` (colourful tartan), ``"plain"`` (one colour),
        ``"stripes"`` (yarn-dyed stripes), ``"dots"`` (polka dots), ``"print"`` (floral
        print), ``"camo"`` (camouflage) or ``"photo"`` (a photograph printed on the cloth).
    size_mm : (float, float)
        (width, height) of the silhouette's bounding box, mm (the paper's models are up to
        250 x 200 mm).
    rng : int or Generator, optional
        Seed or generator for the fabric (and the plain colour when not given).
    mm_per_px : float
        Texture pixel size, mm.
    colour_bgr : (3,), optional
        Colour of a plain fabric (default: a saturated, non-green colour drawn from ``rng``), or
        the ground colour of stripes, dots and print (default: drawn); ignored for plaid, camo
        and photo.
    name : str, optional
        Default ``f"{shape}-{fabric}"``.
    photo : str, optional
        The photo fabric's picture, one of :data:`~photomodel.sim.PHOTO_PRINTS` (default:
        drawn from ``rng``); ignored for the other fabrics.
    description : str
        Words for people, stored in the garment.
    photo_tile_mm : float, optional
        The photo fabric's repeat width, mm (mirrored tiles, see
        :func:`~photomodel.sim.photo_fabric`); default: one picture over the whole garment.
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
    size_px = (w_px, h_px)
    if fabric == "plaid":
        cloth = plaid_fabric(size_px, gen, mm_per_px=mm_per_px)
    elif fabric == "plain":
        if colour_bgr is None:
            hsv = [garment_hues(1, gen)[0], gen.uniform(150, 240), gen.uniform(90, 210)]
            colour_bgr = tuple(hsv_to_bgr(hsv)[0])
        cloth = plain_fabric(size_px, colour_bgr, gen, mm_per_px=mm_per_px)
    elif fabric == "stripes":
        cloth = stripe_fabric(size_px, gen, ground_bgr=colour_bgr, mm_per_px=mm_per_px)
    elif fabric == "dots":
        cloth = dot_fabric(size_px, gen, ground_bgr=colour_bgr, mm_per_px=mm_per_px)
    elif fabric == "print":
        cloth = print_fabric(size_px, gen, ground_bgr=colour_bgr, mm_per_px=mm_per_px)
    elif fabric == "camo":
        cloth = camo_fabric(size_px, gen, mm_per_px=mm_per_px)
    else:
        cloth = photo_fabric(size_px, gen, photo=photo, tile_mm=photo_tile_mm,
                             mm_per_px=mm_per_px)
    texture = PlaneTexture(cloth.image_bgr, alpha, mm_per_px, _area_centroid_px(alpha))
    return Garment(name or f"{shape}-{fabric}", texture,
                   (float(size_mm[0]), float(size_mm[1])), shape, fabric, description)
