"""Labels on simulated garments: a printed QR code, DataMatrix or Code 128 sticker.

A label is zxing-cpp's symbol (:func:`~photomodel.image._barcode.barcode_modules`) printed
black on a white sticker with a quiet zone around it, pasted flat into the garment's texture
at any in-plane angle, wholly inside the silhouette; each texture pixel takes the share of
paper and ink of 4 x 4 sub-samples, so that modules of any size and angle print without
aliasing. The garment carries it (:attr:`Garment.label`), so its model photos and every scene
show it, and the truth can say where it is and how large its modules appear
(:meth:`GarmentLabel.truth`). ``photomodel simulate --labels`` gives every garment one
(:func:`article_code`, :func:`labelled_garment`).

Frames follow docs/contracts.md: the label's place is in the garment frame (mm, x along the
texture's columns, y along its rows); its own frame has x along the symbol's columns and y
along its rows, origin at the symbol's centre.
"""

from __future__ import annotations

import zlib
from dataclasses import dataclass, replace
from typing import Any

import cv2
import numpy as np
from numpy.typing import NDArray

from photomodel.camera import PinholeCamera, StereoRig
from photomodel.geometry import transform_points
from photomodel.image import LINEAR_FORMATS, barcode_modules
from photomodel.sim._garments import Garment
from photomodel.sim._rigs import WORK_DISTANCE_MM
from photomodel.sim._textures import PlaneTexture, RngLike

__all__ = ["LABEL_FORMATS", "MODULE_PX_RANGE", "GarmentLabel", "article_code",
           "labelled_garment", "random_label"]

LABEL_FORMATS: tuple[str, ...] = ("QRCode", "DataMatrix", "Code128")
"""Symbologies of the simulated labels (zxing-cpp's names)."""

MODULE_PX_RANGE: tuple[float, float] = (1.5, 6.0)
"""Module widths (px in the hand cameras at the working distance) a drawn label size spans."""

NOMINAL_PX_PER_MM = 800.0 / WORK_DISTANCE_MM
"""Image pixels per mm of the table in the hand cameras (f about 800 px at 685 mm): turns
:data:`MODULE_PX_RANGE` into module sizes on the garment."""

QUIET_MODULES: dict[str, int] = {"QRCode": 2, "DataMatrix": 2, "Code128": 8}
"""White margin of the sticker around the symbol, modules (other formats: 4)."""

BAR_HEIGHT = 0.25
"""A linear code's bars are this share of its length high (at least 10 modules)."""

_PAPER_BGR = np.array([232.0, 236.0, 238.0])
_INK_BGR = np.array([30.0, 28.0, 26.0])
_AA = 4            # sub-samples per texture pixel and axis
_FIT_TRIES = 200   # random places (and angles) tried per size
_SHRINK = 0.9      # a drawn size that fits nowhere is shrunk by this, down to the range's low end
_INSIDE = 0.999    # alpha from which a texture pixel is garment interior


@dataclass(frozen=True)
class GarmentLabel:
    """A printed label on a garment: what it encodes, its symbol, where it lies.

    Attributes
    ----------
    text : str
        What it encodes (an article code).
    format : str
        zxing-cpp's name of its symbology (one of :data:`LABEL_FORMATS` or another it prints).
    modules : ndarray (rows, columns) bool
        The symbol's modules, True dark, quiet zone excluded; a linear code is one row.
    module_mm : float
        Width of one module on the garment, mm.
    centre_mm : (float, float)
        The symbol's centre in the garment frame, mm.
    angle_deg : float
        In-plane angle of the symbol's x axis (along its columns) from the garment's x axis,
        degrees (towards the garment's y).
    height_mm : float
        The symbol's height, mm: ``rows * module_mm`` for a 2D code, the bars' height for a
        linear one.
    quiet_modules : int
        The sticker's white margin around the symbol, modules.
    """

    text: str
    format: str
    modules: NDArray[np.bool_]
    module_mm: float
    centre_mm: tuple[float, float]
    angle_deg: float
    height_mm: float
    quiet_modules: int

    @property
    def linear(self) -> bool:
        """A one-row (linear) code."""
        return self.modules.shape[0] == 1

    @property
    def size_mm(self) -> tuple[float, float]:
        """(width, height) of the symbol, quiet zone excluded, mm."""
        return self.modules.shape[1] * self.module_mm, self.height_mm

    @property
    def sticker_mm(self) -> tuple[float, float]:
        """(width, height) of the sticker (symbol and quiet zone), mm."""
        w, h = self.size_mm
        margin = 2 * self.quiet_modules * self.module_mm
        return w + margin, h + margin

    def _axes(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        a = np.radians(self.angle_deg)
        return np.array([np.cos(a), np.sin(a)]), np.array([-np.sin(a), np.cos(a)])

    def _rectangle_mm(self, width: float, height: float) -> NDArray[np.float64]:
        ex, ey = self._axes()
        c = np.asarray(self.centre_mm)
        return np.array([c + sx * width / 2 * ex + sy * height / 2 * ey
                         for sx, sy in ((-1, -1), (1, -1), (1, 1), (-1, 1))])

    def corners_mm(self) -> NDArray[np.float64]:
        """The symbol's corners (4, 2) in the garment frame, mm, in its own orientation:
        top-left, top-right, bottom-right, bottom-left (the order zxing-cpp reports)."""
        return self._rectangle_mm(*self.size_mm)

    def sticker_corners_mm(self) -> NDArray[np.float64]:
        """The sticker's corners (4, 2) in the garment frame, mm, in the same order."""
        return self._rectangle_mm(*self.sticker_mm)

    def module_px(self, camera: PinholeCamera, T_cam_model: NDArray[np.float64]) -> float:
        """The module width in ``camera``'s image, px, with the garment at ``T_cam_model``:
        the image length of one module along the symbol's x axis at its centre (and along
        its y axis, the smaller of the two, for a 2D code); NaN behind the camera."""
        ex, ey = self._axes()
        c = np.asarray(self.centre_mm)
        pts = np.array([c, c + self.module_mm * ex, c + self.module_mm * ey])
        uv = camera.project(transform_points(T_cam_model, np.column_stack([pts, np.zeros(3)])))
        lengths = np.linalg.norm(uv[1:] - uv[0], axis=1)
        return float(lengths[0] if self.linear else lengths.min())

    def corners_px(self, camera: PinholeCamera, T_cam_model: NDArray[np.float64]
                   ) -> NDArray[np.float64]:
        """The symbol's corners (4, 2) in ``camera``'s image, px (order of
        :meth:`corners_mm`), with the garment at ``T_cam_model``."""
        pts = np.column_stack([self.corners_mm(), np.zeros(4)])
        return camera.project(transform_points(T_cam_model, pts))

    def truth(self, rig: StereoRig, T_cam1_model: NDArray[np.float64]) -> dict[str, Any]:
        """The truth file's ``label`` of the garment lying at ``T_cam1_model``.

        Returns
        -------
        dict
            ``{"text", "format", "module_mm", "module_px": [camera 1, camera 2],
            "corners_cam1", "corners_cam2": 4 [u, v], "in_view": [camera 1, camera 2]}``;
            ``in_view``: the whole symbol lies inside that image (whether something hides it
            is not checked). A wrinkled garment's label is taken as flat.
        """
        out: dict[str, Any] = {"text": self.text, "format": self.format,
                               "module_mm": self.module_mm, "module_px": [], "in_view": []}
        for key, camera, T in (("corners_cam1", rig.cam1, np.eye(4)),
                               ("corners_cam2", rig.cam2, rig.T_cam2_cam1)):
            T_cam_model = T @ np.asarray(T_cam1_model, dtype=np.float64)
            corners = self.corners_px(camera, T_cam_model)
            out["module_px"].append(self.module_px(camera, T_cam_model))
            out[key] = corners.tolist()
            out["in_view"].append(bool(
                np.all(np.isfinite(corners)) and np.all(corners >= -0.5)
                and np.all(corners[:, 0] <= camera.width_px - 0.5)
                and np.all(corners[:, 1] <= camera.height_px - 0.5)))
        return out


def article_code(name: str, seed: int = 0, format: str = "QRCode") -> str:
    """The simulated article code of garment ``name`` in a dataset of ``seed``.

    ``PM-<name>-<4 digits>`` (``"PM-No.5-0417"``) for a 2D code; 10 digits for a linear
    one (``"Code128"``: 106 modules with its quiet zones where the long form needs about
    170, which no garment of the paper's size holds at readable module widths). The digits
    come from both the name and the seed.
    """
    key = zlib.crc32(f"{int(seed)}:{name}".encode())
    if format in LINEAR_FORMATS:
        wide = (key << 32) | zlib.crc32(f"{name}:{int(seed)}".encode())
        return f"{wide % 10**10:010d}"
    return f"PM-{name}-{key % 10_000:04d}"


def _label(text: str, fmt: str, modules: NDArray[np.bool_], module_mm: float,
           centre: NDArray[np.float64], angle_deg: float) -> GarmentLabel:
    cols = modules.shape[1]
    rows = max(BAR_HEIGHT * cols, 10.0) if modules.shape[0] == 1 else modules.shape[0]
    height = rows * module_mm
    return GarmentLabel(text, fmt, modules, float(module_mm),
                        (float(centre[0]), float(centre[1])), float(angle_deg), float(height),
                        QUIET_MODULES.get(fmt, 4))


def _fits(label: GarmentLabel, texture: PlaneTexture, interior: NDArray[np.uint8]) -> bool:
    """Whether the sticker lies wholly on garment interior pixels."""
    poly = texture.px_from_mm(label.sticker_corners_mm())
    lo = np.floor(poly.min(axis=0)).astype(int) - 1
    hi = np.ceil(poly.max(axis=0)).astype(int) + 2
    h, w = interior.shape
    if lo[0] < 0 or lo[1] < 0 or hi[0] > w or hi[1] > h:
        return False
    mask = np.zeros((hi[1] - lo[1], hi[0] - lo[0]), np.uint8)
    cv2.fillPoly(mask, [np.rint((poly - lo) * 16).astype(np.int32).reshape(-1, 1, 2)], 1,
                 lineType=cv2.LINE_8, shift=4)
    mask = cv2.dilate(mask, np.ones((3, 3), np.uint8))
    return bool(np.all(interior[lo[1]:hi[1], lo[0]:hi[0]][mask > 0]))


def _paste(texture: PlaneTexture, label: GarmentLabel) -> PlaneTexture:
    """``texture`` with the sticker printed into it (4 x 4 sub-samples per pixel)."""
    poly = texture.px_from_mm(label.sticker_corners_mm())
    lo = np.floor(poly.min(axis=0)).astype(int) - 1
    hi = np.ceil(poly.max(axis=0)).astype(int) + 2
    offsets = (np.arange(_AA) + 0.5) / _AA - 0.5
    vv, uu = np.mgrid[lo[1]:hi[1], lo[0]:hi[0]].astype(np.float64)
    u = (uu[..., None, None] + offsets[None, None, None, :]).reshape(*uu.shape, -1)
    v = (vv[..., None, None] + offsets[None, None, :, None]).reshape(*vv.shape, -1)
    xy = texture.mm_from_px(np.stack([u, v], axis=-1)) - np.asarray(label.centre_mm)
    ex, ey = label._axes()
    w, h = label.size_mm
    col = (xy @ ex + w / 2) / label.module_mm          # module coordinates in the symbol
    row = (xy @ ey + h / 2) / (label.height_mm if label.linear else label.module_mm)
    q = label.quiet_modules
    margin_rows = q * label.module_mm / (label.height_mm if label.linear else label.module_mm)
    rows, cols = label.modules.shape
    sticker = (col >= -q) & (col < cols + q) & (row >= -margin_rows) & (row < rows + margin_rows)
    inside = (col >= 0) & (col < cols) & (row >= 0) & (row < rows)
    ci = np.clip(col.astype(np.int64), 0, cols - 1)
    ri = np.clip(row.astype(np.int64), 0, rows - 1)
    dark = inside & label.modules[ri, ci]
    paper = (sticker & ~dark).mean(axis=-1)[..., None]
    ink = dark.mean(axis=-1)[..., None]
    image = texture.image_bgr.copy()
    patch = image[lo[1]:hi[1], lo[0]:hi[0]].astype(np.float64)
    patch = patch * (1.0 - paper - ink) + paper * _PAPER_BGR + ink * _INK_BGR
    image[lo[1]:hi[1], lo[0]:hi[0]] = np.clip(np.rint(patch), 0, 255).astype(np.uint8)
    return PlaneTexture(image, texture.alpha, texture.mm_per_px, texture.origin_px)


def _place(texture: PlaneTexture, interior: NDArray[np.uint8], text: str, fmt: str,
           modules: NDArray[np.bool_], module_mm: float, where: tuple[float, float] | None,
           angle_deg: float | None, gen: np.random.Generator) -> GarmentLabel | None:
    """A label of this size at a random place and angle (or the given ones) that fits, or
    None after :data:`_FIT_TRIES` tries."""
    probe = _label(text, fmt, modules, module_mm, np.zeros(2), 0.0)
    half_min_px = min(probe.sticker_mm) / 2 / texture.mm_per_px
    if where is None:
        dist = cv2.distanceTransform(interior, cv2.DIST_L2, 5)
        vs, us = np.nonzero(dist >= half_min_px)
        if len(us) == 0:
            return None
    for _ in range(_FIT_TRIES):
        if where is None:
            k = int(gen.integers(len(us)))
            centre = texture.mm_from_px(np.array([us[k], vs[k]], dtype=np.float64))
        else:
            centre = np.asarray(where, dtype=np.float64)
        angle = float(gen.uniform(-180.0, 180.0)) if angle_deg is None else float(angle_deg)
        label = _label(text, fmt, modules, module_mm, centre, angle)
        if _fits(label, texture, interior):
            return label
        if where is not None and angle_deg is not None:
            return None
    return None


def labelled_garment(
    garment: Garment,
    code: str,
    format: str | None = None,
    module_mm: float | None = None,
    where: tuple[float, float] | None = None,
    rng: RngLike = None,
    *,
    angle_deg: float | None = None,
) -> Garment:
    """``garment`` with a printed label pasted into its texture (:attr:`Garment.label`).

    Parameters
    ----------
    garment : Garment
        Without a label (a garment carries one at most).
    code : str
        What the label encodes (e.g. :func:`article_code`).
    format : str, optional
        ``"QRCode"``, ``"DataMatrix"``, ``"Code128"`` (:data:`LABEL_FORMATS`) or another
        format zxing-cpp prints; default: drawn from ``rng`` among those that fit.
    module_mm : float, optional
        Module width on the garment, mm; default: drawn log-uniformly so that the module is
        :data:`MODULE_PX_RANGE` px wide in the hand cameras at the working distance, shrunk
        (down to the range's low end) until the sticker fits.
    where : (float, float), optional
        The symbol's centre in the garment frame, mm; default: drawn among the places where
        the sticker lies wholly inside the silhouette.
    rng : int or Generator, optional
        Seed or generator of what is drawn.
    angle_deg : float, optional
        In-plane angle of the symbol (see :class:`GarmentLabel`); default: drawn.

    Returns
    -------
    Garment
        A copy; its model photos and scenes show the label.

    Raises
    ------
    InputError
        zxing-cpp is not installed.
    ValueError
        A garment that already carries a label, a non-positive ``module_mm``, text the
        format cannot encode, or a label that fits nowhere (or not at ``where``) on the
        garment.
    """
    if garment.label is not None:
        raise ValueError(f"garment: {garment.name} already carries a label "
                         f"({garment.label.text!r})")
    if module_mm is not None and not (np.isfinite(module_mm) and module_mm > 0):
        raise ValueError(f"module_mm: expected a positive size, got {module_mm}")
    gen = np.random.default_rng(rng)
    texture = garment.texture
    interior = (texture.alpha >= _INSIDE).astype(np.uint8)
    formats = [format] if format is not None else [
        LABEL_FORMATS[int(i)] for i in gen.permutation(len(LABEL_FORMATS))]
    lo_mm, hi_mm = (px / NOMINAL_PX_PER_MM for px in MODULE_PX_RANGE)
    drawn = float(np.exp(gen.uniform(np.log(lo_mm), np.log(hi_mm))))
    for fmt in formats:
        modules = barcode_modules(code, fmt)
        size = drawn if module_mm is None else float(module_mm)
        while True:
            label = _place(texture, interior, code, fmt, modules, size, where, angle_deg, gen)
            if label is not None:
                return replace(garment, texture=_paste(texture, label), label=label)
            if module_mm is not None or size * _SHRINK < lo_mm:
                break
            size *= _SHRINK
    sizes = f"{module_mm:g} mm modules" if module_mm is not None else \
        f"modules of {lo_mm:.2f} mm or more"
    at = "" if where is None else f" at ({where[0]:g}, {where[1]:g}) mm"
    raise ValueError(f"label: a {'/'.join(formats)} label of {sizes} does not fit on "
                     f"{garment.name}{at}")


def random_label(garment: Garment, name: str, seed: int, rng: RngLike = None, *,
                 formats: tuple[str, ...] = LABEL_FORMATS) -> Garment:
    """``garment`` with a label of a format drawn from ``formats`` (the next when it fits
    nowhere), encoding ``article_code(name, seed, format)``, its size and place drawn
    (:func:`labelled_garment`): what ``photomodel simulate --labels`` sticks on a garment.

    Raises
    ------
    ValueError
        No format fits on the garment.
    """
    gen = np.random.default_rng(rng)
    order = [formats[int(i)] for i in gen.permutation(len(formats))]
    for fmt in order:
        try:
            return labelled_garment(garment, article_code(name, seed, fmt), fmt, rng=gen)
        except ValueError as exc:
            if "does not fit" not in str(exc):
                raise
    raise ValueError(f"label: no {'/'.join(order)} label of readable size fits on "
                     f"{garment.name}")
