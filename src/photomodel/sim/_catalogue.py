"""The built-in catalogue of the paper's 12 garments, and garments cut from a user's photos.

The seed paper recognises 12 garments, photographed as models of at most 250 x 200 mm; garment
No. 3 (small, light and colourful) is the one of its Table 1. The catalogue stands in for them:
each entry is a :class:`GarmentSpec` that :func:`catalogue_garment` turns into the same
:class:`~photomodel.sim.Garment` (same bytes) every time. It covers every silhouette of
``GARMENT_SHAPES``, every fabric, and on purpose the cases that hue alone handles badly: a dark
(navy), a white and a grey plain garment. :data:`PLANE_COLOURED` adds garments that share the
model station plane's colour (a print on a green ground, a dark-green hem; grey, white and black
garments photographed on a plane of their own colour): the cases the paper's average-hue rule
loses and the per-pixel comparison with the background photo must recover.

A simulated catalogue of up to 100,000 random articles, ``cat-00000`` ... ``cat-99999``, with
look-alike pairs, lives in :mod:`photomodel.sim._random_catalogue`; its names work here as the
others do (``catalogue_garment("cat-00042")``, ``--garments catalogue:1000``).

A user's own garment comes from a photo and a mask (:func:`garment_from_image`,
:func:`load_garment`).
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, replace
from functools import lru_cache
from pathlib import Path

import cv2
import numpy as np
from numpy.typing import ArrayLike, NDArray

from photomodel.errors import InputError
from photomodel.image import read_color_image, read_grey_image
from photomodel.sim._garments import _MARGIN_PX, Garment, _area_centroid_px, make_garment
from photomodel.sim._textures import PlaneTexture, plain_fabric

__all__ = [
    "CATALOGUE",
    "GARMENT_GROUPS",
    "SIMILAR",
    "PLANE_COLOURED",
    "GarmentSpec",
    "catalogue_garment",
    "expand_garments",
    "garment_from_image",
    "garment_names",
    "known_garments",
    "load_garment",
]


@dataclass(frozen=True)
class GarmentSpec:
    """Recipe of a catalogue garment: everything :func:`~photomodel.sim.make_garment` needs.

    Parameters
    ----------
    name : str
        Catalogue name, ``"No.1"`` ... ``"No.12"``.
    shape : str
        One of ``GARMENT_SHAPES``.
    fabric : str
        One of ``FABRICS``.
    size_mm : (float, float)
        (width, height) of the silhouette's bounding box, mm (at most 250 x 200).
    seed : int
        Seed of the fabric's random draws.
    colour_bgr : (3,), optional
        Plain colour, or ground colour of stripes, dots and print (BGR 0-255); None: drawn.
    photo : str, optional
        Picture of a ``photo`` fabric (one of ``PHOTO_PRINTS``).
    description : str
        Words for people.
    plane_bgr : (3,), optional
        Colour of the model station's plane the garment is photographed on (BGR 0-255);
        None: the station's green.
    hem : (float, (3,)), optional
        A band of another colour along the bottom edge: (height mm, BGR colour).
    photo_tile_mm : float, optional
        A ``photo`` fabric's repeat width, mm (mirrored tiles); None: one picture over the
        whole garment.
    """

    name: str
    shape: str
    fabric: str
    size_mm: tuple[float, float]
    seed: int
    colour_bgr: tuple[int, int, int] | None = None
    photo: str | None = None
    description: str = ""
    plane_bgr: tuple[int, int, int] | None = None
    hem: tuple[float, tuple[int, int, int]] | None = None
    photo_tile_mm: float | None = None


_NAVY_BGR = (72, 36, 26)  # value 72: dark, hue unreliable
_WHITE_BGR = (238, 240, 241)  # saturation 2: white, hue meaningless
_GREY_BGR = (160, 160, 160)  # achromatic, lighter than the table's grey (128)
_CREAM_BGR = (190, 232, 248)  # light butter-yellow ground of No. 3 (saturation 60)
_RED_BGR = (45, 40, 196)
_DARK_BLUE_BGR = (96, 44, 30)
_OFF_WHITE_BGR = (236, 238, 240)

CATALOGUE: dict[str, GarmentSpec] = {
    spec.name: spec
    for spec in (
        GarmentSpec("No.1", "tshirt", "plaid", (240.0, 200.0), 101,
                    description="T-shirt, colourful tartan"),
        GarmentSpec("No.2", "trousers", "plain", (160.0, 200.0), 102, _NAVY_BGR,
                    description="navy trousers (dark: low value)"),
        GarmentSpec("No.3", "tshirt", "print", (130.0, 110.0), 103, _CREAM_BGR,
                    description="small baby T-shirt, multicolour flowers on light butter-yellow"),
        GarmentSpec("No.4", "longsleeve", "stripes", (250.0, 190.0), 104, _OFF_WHITE_BGR,
                    description="long-sleeve shirt, coloured stripes on white"),
        GarmentSpec("No.5", "skirt", "dots", (220.0, 180.0), 105, _RED_BGR,
                    description="A-line skirt, white polka dots on red"),
        GarmentSpec("No.6", "sock", "plain", (150.0, 200.0), 106, _GREY_BGR,
                    description="grey sock (achromatic)"),
        GarmentSpec("No.7", "dress", "print", (180.0, 200.0), 107, _DARK_BLUE_BGR,
                    description="sleeveless dress, flowers on a dark blue ground"),
        GarmentSpec("No.8", "towel", "plain", (240.0, 180.0), 108, _WHITE_BGR,
                    description="white hand towel (low saturation)"),
        GarmentSpec("No.9", "shorts", "camo", (220.0, 170.0), 109,
                    description="shorts, camouflage"),
        GarmentSpec("No.10", "tshirt", "photo", (230.0, 200.0), 110, photo="astronaut",
                    description="T-shirt with a photo print (astronaut)"),
        GarmentSpec("No.11", "vest", "stripes", (190.0, 200.0), 111,
                    description="tank top, yarn-dyed stripes"),
        GarmentSpec("No.12", "towel", "photo", (250.0, 170.0), 112, photo="chelsea",
                    description="tea towel with a photo print (cat)"),
    )
}
"""The 12 garments of the paper's experiment, by name (``"No.1"`` ... ``"No.12"``)."""

SIMILAR: dict[str, GarmentSpec] = {
    spec.name: spec
    for spec in (
        GarmentSpec("No.1-small", "tshirt", "plaid", (200.0, 167.0), 101,
                    description="No.1 cut smaller (0.83x): differs only in size"),
        GarmentSpec("No.3-red", "tshirt", "print", (130.0, 110.0), 103, _RED_BGR,
                    description="No.3 on a red ground: differs only in colour"),
        GarmentSpec("No.4-dots", "longsleeve", "dots", (250.0, 190.0), 104, _OFF_WHITE_BGR,
                    description="No.4 with coloured dots instead of stripes: differs only in "
                                "print"),
    )
}
"""Look-alikes of catalogue garments for identification: each differs from its
original in one respect only (size, colour or print). Not part of the paper's 12."""

_LEAF_GREEN_BGR = (70, 170, 40)  # hue 8 deg from the plane's green: the hue rule loses it
_DARK_GREEN_BGR = (40, 85, 20)  # hue 13 deg from the plane's, value 0.53 of it
_MID_BLUE_BGR = (170, 120, 60)
_GREY_PLANE_BGR = (128, 128, 128)
_LIGHT_GREY_BGR = (146, 146, 146)  # 14 % lighter than the grey plane
_WHITE_PLANE_BGR = (218, 220, 222)  # a white board, a little darker than the white towel
_BLACK_PLANE_BGR = (24, 24, 26)  # black velvet
_BLACK_BGR = (46, 44, 44)  # black cloth, lighter than the velvet

PLANE_COLOURED: dict[str, GarmentSpec] = {
    spec.name: spec
    for spec in (
        GarmentSpec("green-print", "tshirt", "print", (220.0, 190.0), 201, _LEAF_GREEN_BGR,
                    description="T-shirt, flowers on a leaf-green ground (the plane's hue)"),
        GarmentSpec("green-hem", "skirt", "plain", (220.0, 180.0), 202, _MID_BLUE_BGR,
                    hem=(15.0, _DARK_GREEN_BGR),
                    description="blue skirt with a 15 mm dark-green hem"),
        GarmentSpec("grey-on-grey", "sock", "plain", (150.0, 200.0), 203, _LIGHT_GREY_BGR,
                    plane_bgr=_GREY_PLANE_BGR,
                    description="light grey sock photographed on a grey plane"),
        GarmentSpec("white-on-white", "towel", "plain", (240.0, 180.0), 204, _WHITE_BGR,
                    plane_bgr=_WHITE_PLANE_BGR,
                    description="white hand towel photographed on a white plane"),
        GarmentSpec("black-on-black", "trousers", "plain", (160.0, 200.0), 205, _BLACK_BGR,
                    plane_bgr=_BLACK_PLANE_BGR,
                    description="black trousers photographed on black velvet"),
    )
}
"""Garments whose colour, or part of it, is the model station plane's: not part of the
paper's 12 (``all`` leaves them out, so that studies stay comparable); group
``plane-coloured``."""

GARMENT_GROUPS: dict[str, tuple[str, ...]] = {
    "all": tuple(CATALOGUE),
    "similar": ("No.1", "No.1-small", "No.3", "No.3-red", "No.4", "No.4-dots"),
    "plane-coloured": tuple(PLANE_COLOURED),
}
"""Named sets of garments for ``--garments``: ``all`` is the paper's 12, ``similar`` the
look-alike pairs (each original with its twin), ``plane-coloured`` the garments of
:data:`PLANE_COLOURED`. Besides these, ``catalogue:N`` names the first N articles of the
simulated catalogue (``cat-00000`` ... ``cat-99999``)."""

_SPECS: dict[str, GarmentSpec] = {**CATALOGUE, **SIMILAR, **PLANE_COLOURED}
_CATALOGUE_GROUP = "catalogue:"
_SIMULATED_NAMES = ("cat-NNNNN (an article of the simulated catalogue, cat-00000 to "
                    "cat-99999)")


def _spec(name: str) -> GarmentSpec | None:
    """The spec of a built-in garment or of an article of the simulated catalogue; None for
    any other name."""
    from photomodel.sim import _random_catalogue as random_catalogue

    if name in _SPECS:
        return _SPECS[name]
    if random_catalogue.is_catalogue_name(name):
        return random_catalogue.catalogue_spec(int(name[4:]))
    return None


def _catalogue_group(text: str) -> tuple[str, ...]:
    """The names of ``catalogue:N`` (the first N articles of the simulated catalogue)."""
    from photomodel.sim._random_catalogue import MAX_CATALOGUE, catalogue_names

    value = text[len(_CATALOGUE_GROUP):].strip()
    if not (value.isascii() and value.isdigit() and 1 <= int(value) <= MAX_CATALOGUE):
        raise ValueError(f"{text!r}: catalogue:N takes the number of articles of the simulated "
                         f"catalogue, an integer from 1 to {MAX_CATALOGUE}, got {value!r}")
    return catalogue_names(int(value))


def garment_names() -> tuple[str, ...]:
    """Names of the catalogue garments, ``("No.1", ..., "No.12")``."""
    return tuple(CATALOGUE)


def known_garments() -> tuple[str, ...]:
    """The named garments :func:`catalogue_garment` builds: the paper's 12, the look-alikes and
    the plane-coloured ones (besides the simulated catalogue's ``cat-00000`` ...
    ``cat-99999``)."""
    return tuple(_SPECS)


def expand_garments(text: str) -> tuple[str, ...]:
    """Garment names of a ``--garments`` value: comma-separated names and groups, in order,
    without repeats.

    A name is a garment of :func:`known_garments` or an article of the simulated catalogue
    (``cat-00042``); a group is one of :data:`GARMENT_GROUPS` or ``catalogue:N``, the first N
    articles of the simulated catalogue (1 <= N <= 100000).

    Raises
    ------
    ValueError
        An unknown name (the message lists the known ones and the groups) or a bad
        ``catalogue:N``.
    """
    names: list[str] = []
    for part in (t.strip() for t in text.split(",")):
        if not part:
            continue
        if part in GARMENT_GROUPS:
            names += GARMENT_GROUPS[part]
        elif part.startswith(_CATALOGUE_GROUP):
            names += _catalogue_group(part)
        elif _spec(part) is not None:
            names.append(part)
        else:
            raise ValueError(f"unknown garment {part!r}; known: {', '.join(_SPECS)}, "
                             f"{_SIMULATED_NAMES}; groups: {', '.join(GARMENT_GROUPS)}, "
                             f"catalogue:N (its first N articles)")
    return tuple(dict.fromkeys(names))


@lru_cache(maxsize=64)  # at most 64 textures, up to 1.5 MB each at 0.5 mm per pixel
def _build(name: str, mm_per_px: float) -> Garment:
    spec = _spec(name)
    assert spec is not None
    garment = make_garment(spec.shape, spec.fabric, spec.size_mm, rng=spec.seed,
                           mm_per_px=mm_per_px, colour_bgr=spec.colour_bgr, name=spec.name,
                           photo=spec.photo, description=spec.description,
                           photo_tile_mm=spec.photo_tile_mm)
    if spec.hem is not None:
        garment = _with_hem(garment, *spec.hem, rng=spec.seed + 1)
    if spec.plane_bgr is not None:
        garment = replace(garment, plane_bgr=spec.plane_bgr)
    # The cached garment is shared by every caller: make its arrays read-only.
    for array in (garment.texture.image_bgr, garment.texture.alpha, garment.texture.origin_px):
        array.flags.writeable = False
    return garment


def _with_hem(garment: Garment, height_mm: float, colour_bgr: tuple[int, int, int],
              rng: int) -> Garment:
    """``garment`` with the band within ``height_mm`` of its bottom edge (column by column,
    so that it follows a curved hem) recoloured with a plain fabric of ``colour_bgr``."""
    tex = garment.texture
    inside = tex.alpha > 0
    rows = np.arange(tex.alpha.shape[0])[:, None]
    bottom = np.where(inside.any(axis=0), tex.alpha.shape[0] - 1 - np.argmax(inside[::-1],
                                                                              axis=0), -1)
    band = rows >= bottom[None, :] - height_mm / tex.mm_per_px
    cloth = plain_fabric(tex.size_px, colour_bgr, rng, mm_per_px=tex.mm_per_px).image_bgr
    image = np.where(band[..., None], cloth, tex.image_bgr)
    texture = PlaneTexture(image, tex.alpha, tex.mm_per_px, tex.origin_px)
    return replace(garment, texture=texture)


def catalogue_garment(name: str, mm_per_px: float = 0.5) -> Garment:
    """Build a catalogue garment from its :class:`GarmentSpec` (deterministic, cached).

    Parameters
    ----------
    name : str
        ``"No.1"`` ... ``"No.12"`` (see :func:`garment_names`), a look-alike of
        :data:`SIMILAR`, a garment of :data:`PLANE_COLOURED` or an article of the simulated
        catalogue, ``"cat-00000"`` ... ``"cat-99999"`` (:func:`catalogue_spec`).
    mm_per_px : float
        Texture pixel size, mm.

    Returns
    -------
    Garment
        The same object for the same arguments; its arrays are read-only (copy to modify).

    Raises
    ------
    ValueError
        Unknown name (the message lists the known ones) or a non-positive ``mm_per_px``.
    """
    if not isinstance(name, str) or _spec(name) is None:
        raise ValueError(f"name: no catalogue garment {name!r}; known: {', '.join(_SPECS)}, "
                         f"{_SIMULATED_NAMES}")
    if not (math.isfinite(mm_per_px) and mm_per_px > 0):
        raise ValueError(f"mm_per_px: must be positive, got {mm_per_px}")
    return _build(name, float(mm_per_px))


# --- A user's own garment -------------------------------------------------------------------


def _fill_outside(image: NDArray[np.uint8], inside: NDArray[np.bool_]) -> NDArray[np.uint8]:
    """Copy of ``image`` whose pixels outside ``inside`` take the nearest inside pixel's colour.

    Keeps the photo's background from tinting the garment's edge when the texture is sampled.
    """
    if inside.all():
        return image.copy()
    _, labels = cv2.distanceTransformWithLabels((~inside).astype(np.uint8), cv2.DIST_L2, 3,
                                                labelType=cv2.DIST_LABEL_PIXEL)
    # Labels number the zero (inside) pixels 1, 2, ... in raster order.
    return image[inside][labels - 1]


def garment_from_image(
    image_bgr: ArrayLike,
    mask: ArrayLike,
    width_mm: float,
    name: str,
    mm_per_px: float | None = None,
    *,
    description: str = "",
) -> Garment:
    """A user's garment from a photo of it and a mask, scaled to a known width.

    The photo is cropped to the mask's bounding box and scaled so that the box is ``width_mm``
    wide. The alpha is the mask, area-resampled and softened by a slight blur at its edges
    (the interior stays 1); a fully transparent margin of 4 pixels surrounds that soft edge.
    The garment frame's origin is the alpha's area centroid, as for the synthetic garments.
    Pixels outside the mask take the colour of the nearest garment pixel.

    Parameters
    ----------
    image_bgr : ndarray (H, W, 3) uint8
        Photo, BGR, taken square-on (the garment flat, the camera looking straight at it).
    mask : ndarray (H, W) uint8 or bool
        Nonzero where the garment is.
    width_mm : float
        Width of the mask's bounding box on the garment, mm.
    name : str
        Garment name.
    mm_per_px : float, optional
        Texture pixel size, mm. Default: the photo's own (``width_mm`` / box width in pixels).
        When given, the photo is resampled to it, adjusted by at most half a pixel over the
        box width so that a whole number of pixels spans ``width_mm`` exactly.
    description : str
        Words for people.

    Returns
    -------
    Garment
        ``shape == "user"``, ``fabric == "photo"``; ``size_mm`` = (``width_mm``, box height).

    Raises
    ------
    ValueError
        A bad argument; the message names it.
    """
    image = np.asarray(image_bgr)
    if image.ndim != 3 or image.shape[2] != 3 or image.dtype != np.uint8:
        raise ValueError(
            f"image_bgr: expected an (H, W, 3) uint8 BGR image, got {image.shape} {image.dtype}")
    m = np.asarray(mask)
    if m.ndim == 3 and m.shape[2] == 1:
        m = m[..., 0]
    if m.shape != image.shape[:2]:
        raise ValueError(f"mask: expected shape {image.shape[:2]} (the image's), got {m.shape}")
    if m.dtype != np.bool_ and m.dtype.kind not in "ui":
        raise ValueError(f"mask: expected uint8 or bool, got {m.dtype}")
    inside = m != 0
    if not inside.any():
        raise ValueError("mask: empty (no nonzero pixel marks the garment)")
    if not (isinstance(width_mm, (int, float, np.number)) and math.isfinite(width_mm)
            and width_mm > 0):
        raise ValueError(f"width_mm: expected a positive width, mm, got {width_mm!r}")
    if not isinstance(name, str) or not name:
        raise ValueError(f"name: expected a non-empty string, got {name!r}")
    if mm_per_px is not None and not (math.isfinite(mm_per_px) and mm_per_px > 0):
        raise ValueError(f"mm_per_px: must be positive, got {mm_per_px}")

    rows, cols = np.nonzero(inside.any(axis=1))[0], np.nonzero(inside.any(axis=0))[0]
    box = (slice(rows[0], rows[-1] + 1), slice(cols[0], cols[-1] + 1))
    bw, bh = cols[-1] - cols[0] + 1, rows[-1] - rows[0] + 1
    src_mm = float(width_mm) / bw  # size of a photo pixel on the garment, mm
    crop = _fill_outside(image[box], inside[box])
    cover = inside[box].astype(np.float32)
    if mm_per_px is None:
        out_mm = src_mm
    else:
        ow = max(1, round(float(width_mm) / mm_per_px))
        out_mm = float(width_mm) / ow
        oh = max(1, round(bh * src_mm / out_mm))
        interp = cv2.INTER_AREA if out_mm > src_mm else cv2.INTER_LINEAR
        crop = cv2.resize(crop, (ow, oh), interpolation=interp)
        cover = cv2.resize(cover, (ow, oh), interpolation=interp)
    # The 3 x 3 blur softens the edge by a pixel each way; one more pixel of border keeps a
    # fully transparent margin of _MARGIN_PX pixels.
    pad = _MARGIN_PX + 1
    crop = cv2.copyMakeBorder(crop, pad, pad, pad, pad, cv2.BORDER_REPLICATE)
    alpha = np.clip(cv2.GaussianBlur(np.pad(cover, pad), (3, 3), 0.5), 0.0, 1.0)
    alpha[alpha > 0.999] = 1.0
    alpha[alpha < 0.001] = 0.0
    texture = PlaneTexture(crop, alpha, out_mm, _area_centroid_px(alpha))
    height_mm = (alpha.shape[0] - 2 * pad) * out_mm
    return Garment(name, texture, (float(width_mm), float(height_mm)), "user", "photo",
                   description)


def load_garment(
    image_path: str | os.PathLike[str],
    mask_path: str | os.PathLike[str],
    width_mm: float,
    name: str | None = None,
    mm_per_px: float | None = None,
) -> Garment:
    """Read a user's garment from a colour photo and a mask image (see :func:`garment_from_image`).

    Parameters
    ----------
    image_path : path
        Colour photo (any format OpenCV reads).
    mask_path : path
        Mask of the same size, read as greyscale: nonzero = garment.
    width_mm : float
        Width of the mask's bounding box on the garment, mm.
    name : str, optional
        Default: the photo's file name without its suffix.
    mm_per_px : float, optional
        Texture pixel size, mm (default: the photo's own).

    Raises
    ------
    InputError
        A missing or unreadable file, a mask whose size differs from the photo's, an empty mask
        or a bad ``width_mm``; the message starts with the file (or argument) at fault.
    """
    image = read_color_image(image_path)
    mp = Path(mask_path)
    mask = read_grey_image(mp, "mask")
    if mask.shape != image.shape[:2]:
        raise InputError(mp, f"mask is {mask.shape[1]}x{mask.shape[0]} pixels but the photo "
                             f"{Path(image_path).name} is {image.shape[1]}x{image.shape[0]}")
    if not mask.any():
        raise InputError(mp, "mask is empty (no nonzero pixel marks the garment)")
    if not (isinstance(width_mm, (int, float, np.number)) and math.isfinite(width_mm)
            and width_mm > 0):
        raise InputError("width_mm", f"expected a positive width in mm, got {width_mm!r}")
    if mm_per_px is not None and not (math.isfinite(mm_per_px) and mm_per_px > 0):
        raise InputError("mm_per_px", f"expected a positive pixel size in mm, got {mm_per_px!r}")
    return garment_from_image(image, mask, width_mm, name or Path(image_path).stem, mm_per_px)
