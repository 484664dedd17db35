"""In-place registration: a photo-model from the hand cameras' stereo pair of the garment where
it lies, with no model station.

1. **Rough garment**: camera 1's pixels that differ from the empty table's image (or, with no
   empty pair, from the table's colour, the median of the image's border band), by the
   station build's per-pixel rule (:func:`~photomodel.model._build._differs_from_plane`).
2. **The garment's plane by stereo** (:func:`measure_plane`): both views rectified
   (``cv2.stereoRectify``), semi-global matching (``cv2.StereoSGBM``) over the disparities of
   the search box's depths, every matched pixel of the rough garment (eroded clear of its
   outline) where the image has texture (:data:`MIN_TEXTURE`) triangulated in camera 1's
   frame, a plane fitted by RANSAC and least squares on its inliers, then refined to the
   subpixel on the grey levels. A garment with too little texture for
   :data:`MIN_PLANE_POINTS` such pixels takes a band of table around it too (the outline's
   edges match well).
3. **Orthophoto**: a virtual camera at camera 1's centre, looking along the plane's normal with
   camera 1's focal length (so one pixel is about what camera 1 resolves there), sees the
   plane as a fronto-parallel photo; camera 1's image is resampled into it through the lens
   (:func:`orthophoto`), over the largest rectangle of the plane that camera 1 sees.
4. **The build**: the station build (:func:`~photomodel.model.build_photo_model`) on the
   orthophoto against the empty table's orthophoto (or a photo of the table's colour), with
   the virtual camera and the plane's distance: the same model file, the same quality report.
   A garment cut by camera 1's image border touches the rectangle's edge and is refused.

The model's frame lies in the garment's plane at its silhouette's centroid, its axes those of
the virtual camera (z along the plane's normal, away from the cameras);
:attr:`InPlaceBuild.T_cam1_model` says where it lies in the pair it was built from.
"""

from __future__ import annotations

import os
from dataclasses import dataclass

import cv2
import numpy as np
from numpy.typing import NDArray
from scipy.ndimage import map_coordinates

from photomodel.camera import PinholeCamera, StereoRig
from photomodel.errors import InputError, NoGarmentError
from photomodel.model._build import (
    BuildResult,
    _clean_mask,
    _differs_from_plane,
    _log_opponent,
    _smooth,
    build_photo_model,
    surface_photo,
)
from photomodel.model._config import BuildConfig

__all__ = ["InPlaceBuild", "TablePlane", "build_in_place", "measure_plane", "orthophoto"]

DEPTH_RANGE_MM = (400.0, 1200.0)
"""Depths of the table the stereo matching covers (the search box's 500-900 mm and a margin)."""
MIN_PLANE_POINTS = 2000
"""Fewest matched, textured pixels of the garment itself a plane is fitted to (else a band of
table around it joins them)."""
MIN_TEXTURE = 3.0
"""Least horizontal grey-level gradient (levels a pixel, after a 1 px blur) of a pixel whose
match counts: inside a plain garment, semi-global matching's disparities are its smoothness
term's guesses, and the photometric refinement has nothing to hold on to."""
RANSAC_TOLERANCE_MM = 2.0
RANSAC_ITERATIONS = 200
BAND_PX = 12
"""Width of the table band around the garment a textureless garment's plane fit adds."""
MAX_TILT_DEG = 30.0
"""Largest angle between the measured plane and a plane facing the rig that is taken for the
table (a garment on a table the rig looks down on lies within a few degrees of it)."""


@dataclass(frozen=True)
class TablePlane:
    """A plane in camera 1's frame: points ``X`` with ``normal_cam1 @ X == distance_mm``.

    Attributes
    ----------
    normal_cam1 : ndarray (3,)
        Unit normal, pointing away from the cameras.
    distance_mm : float
        Distance of camera 1's centre from the plane, mm.
    rms_mm : float
        Root mean square distance of the inliers from the plane, mm.
    points : int
        Matched pixels (inliers) the plane was fitted to.
    band : bool
        Whether a band of table around the garment joined its pixels (too little texture).
    """

    normal_cam1: NDArray[np.float64]
    distance_mm: float
    rms_mm: float
    points: int
    band: bool = False

    def R_cam1_plane(self) -> NDArray[np.float64]:
        """(3, 3) frame of the plane in camera 1: z the normal, x camera 1's x projected
        onto the plane, y = z x x."""
        z = self.normal_cam1
        x = np.array([1.0, 0.0, 0.0]) - z[0] * z
        x /= np.linalg.norm(x)
        return np.stack([x, np.cross(z, x), z], axis=-1)


@dataclass(frozen=True)
class InPlaceBuild:
    """A model built in place (:func:`build_in_place`).

    Attributes
    ----------
    built : BuildResult
        The station build's result on the orthophoto (model, mask, quality report).
    plane : TablePlane
    T_cam1_model : ndarray (4, 4)
        Where the new model lies in the pair it was built from, mm.
    mm_per_px : float
        The orthophoto's (and the model photo's) resolution on the plane.
    orthophoto_bgr : ndarray (H, W, 3) uint8
        Camera 1's view resampled onto the plane (the model photo before cropping).
    """

    built: BuildResult
    plane: TablePlane
    T_cam1_model: NDArray[np.float64]
    mm_per_px: float
    orthophoto_bgr: NDArray[np.uint8]


# ----------------------------------------------------------------------------- stereo

_RECTIFY: dict[tuple[object, ...], tuple[NDArray[np.float32], ...]] = {}


def _rectification(rig: StereoRig, size: tuple[int, int]) -> tuple[NDArray[np.float32], ...]:
    """Both cameras' rectification maps for images of ``size`` (w, h), camera 1's
    rectifying rotation ``R1``, its projection ``P1`` and the baseline term ``f Tx``
    (disparity = f Tx / depth); once per rig and size."""
    key = (*rig.calibration_key, size)
    if key not in _RECTIFY:
        R1, R2, P1, P2, *_ = cv2.stereoRectify(rig.cam1.K, rig.cam1.dist, rig.cam2.K,
                                               rig.cam2.dist, size, rig.R, rig.T.reshape(3, 1),
                                               flags=cv2.CALIB_ZERO_DISPARITY, alpha=0)
        maps = [cv2.initUndistortRectifyMap(cam.K, cam.dist, Rr, P, size, cv2.CV_32FC1)
                for cam, Rr, P in ((rig.cam1, R1, P1), (rig.cam2, R2, P2))]
        if len(_RECTIFY) > 4:
            _RECTIFY.pop(next(iter(_RECTIFY)))
        _RECTIFY[key] = (*maps[0], *maps[1], R1, P1, np.array([P2[0, 3]]))
    return _RECTIFY[key]


def _rectified(rig: StereoRig, right_bgr: NDArray[np.uint8], left_bgr: NDArray[np.uint8]
               ) -> tuple[NDArray[np.uint8], NDArray[np.uint8]]:
    """Both views rectified, in grey."""
    m1x, m1y, m2x, m2y = _rectification(rig, _size(right_bgr))[:4]
    g1 = cv2.remap(cv2.cvtColor(right_bgr, cv2.COLOR_BGR2GRAY), m1x, m1y, cv2.INTER_LINEAR)
    g2 = cv2.remap(cv2.cvtColor(left_bgr, cv2.COLOR_BGR2GRAY), m2x, m2y, cv2.INTER_LINEAR)
    return g1, g2


def _disparity(g1: NDArray[np.uint8], g2: NDArray[np.uint8], f_tx: float,
               depth_mm: tuple[float, float]) -> NDArray[np.float32]:
    """Camera 1's rectified disparity (H, W) (``x2 - x1``, NaN where unmatched) by
    semi-global matching over the disparities of ``depth_mm`` (disparity = f Tx / depth)."""
    lo = int(np.floor(f_tx / depth_mm[1]))
    count = int(np.ceil((f_tx / depth_mm[0] - lo) / 16.0)) * 16
    block = 5
    sgbm = cv2.StereoSGBM_create(minDisparity=lo, numDisparities=count, blockSize=block,
                                 P1=8 * block**2, P2=32 * block**2, uniquenessRatio=10,
                                 speckleWindowSize=100, speckleRange=2, disp12MaxDiff=1)
    # camera 2 is the left camera: flipping both makes camera 1 the left image, so the
    # disparity comes in camera 1's pixels
    raw = sgbm.compute(np.ascontiguousarray(g1[:, ::-1]), np.ascontiguousarray(g2[:, ::-1]))
    disp = raw[:, ::-1].astype(np.float32) / 16.0
    disp[disp < lo] = np.nan
    return disp


def _refine_disparity_plane(g1: NDArray[np.uint8], g2: NDArray[np.uint8],
                            use: NDArray[np.bool_], abc: NDArray[np.float64],
                            iterations: int = 12, max_change_px: float = 1.0
                            ) -> NDArray[np.float64]:
    """The plane's disparity ``d = a u + b v + c`` (rectified camera 1 pixels; a plane's
    disparity is affine there) refined to the subpixel by Gauss-Newton on the grey levels of
    the ``use`` pixels: ``gain g2(u + d, v) + offset = g1(u, v)``, Huber-weighted, a step kept
    only when it lowers the cost (halved up to four times otherwise). Semi-global matching's
    subpixel disparities lean towards whole pixels; this does not. A refinement that moves the
    disparity by more than ``max_change_px`` anywhere in the region (a periodic print can lead
    it a period astray) is dropped: ``abc`` comes back unchanged."""
    f1 = cv2.GaussianBlur(g1.astype(np.float32), (0, 0), 1.0).astype(np.float64)
    f2 = cv2.GaussianBlur(g2.astype(np.float32), (0, 0), 1.0).astype(np.float64)
    gx2 = cv2.Sobel(f2, cv2.CV_64F, 1, 0, ksize=3) / 8.0
    v, u = np.nonzero(use)
    step = max(1, len(u) // 40000)
    u, v = u[::step].astype(np.float64), v[::step].astype(np.float64)
    target = f1[v.astype(int), u.astype(int)]
    u0, v0 = float(u.mean()), float(v.mean())
    du, dv = u - u0, v - v0                   # centred: a, b and c apart in the normal matrix

    def residual(p: NDArray[np.float64]) -> tuple[NDArray[np.float64], ...]:
        at = np.stack([v, u + p[0] * du + p[1] * dv + p[2]])
        i2 = map_coordinates(f2, at, order=1, mode="nearest")
        return p[3] * i2 + p[4] - target, i2, at

    start = np.array([abc[0], abc[1], abc[0] * u0 + abc[1] * v0 + abc[2], 1.0, 0.0])
    params = start.copy()
    r, i2, at = residual(params)
    scale = 1.4826 * float(np.median(np.abs(r))) + 1e-6

    def cost(res: NDArray[np.float64]) -> float:
        a = np.abs(res)
        return float(np.where(a <= 1.5 * scale, 0.5 * a**2, 1.5 * scale * (a - 0.75 * scale))
                     .sum())

    current = cost(r)
    for _ in range(iterations):
        gx = map_coordinates(gx2, at, order=1, mode="nearest")
        J = np.column_stack([params[3] * gx * du, params[3] * gx * dv, params[3] * gx, i2,
                             np.ones_like(u)])
        w = np.minimum(1.0, 1.5 * scale / np.maximum(np.abs(r), 1e-9))
        delta = np.linalg.lstsq(J * w[:, None] ** 0.5, -r * w**0.5, rcond=None)[0]
        for _ in range(5):
            trial = params + delta
            r_t, i2_t, at_t = residual(trial)
            if cost(r_t) < current:
                break
            delta = 0.5 * delta
        else:
            break
        params, r, i2, at, current = trial, r_t, i2_t, at_t, cost(r_t)
        if np.abs(delta[:3] * [np.abs(du).max(), np.abs(dv).max(), 1.0]).max() < 1e-3:
            break
    change = (params - start)[:3]
    corners = np.array([[du.min(), dv.min(), 1.0], [du.max(), dv.max(), 1.0],
                        [du.min(), dv.max(), 1.0], [du.max(), dv.min(), 1.0]])
    if np.abs(corners @ change).max() > max_change_px:
        return np.asarray(abc, dtype=np.float64)
    a, b, c = params[:3]
    return np.array([a, b, c - a * u0 - b * v0])


def measure_plane(rig: StereoRig, right_bgr: NDArray[np.uint8], left_bgr: NDArray[np.uint8],
                  mask_cam1: NDArray[np.bool_], *,
                  depth_mm: tuple[float, float] = DEPTH_RANGE_MM,
                  rng: int | np.random.Generator | None = 0) -> TablePlane:
    """The plane of a garment lying flat, by stereo (module docstring, step 2).

    Parameters
    ----------
    rig : StereoRig
    right_bgr, left_bgr : ndarray (H, W, 3) uint8
        Camera 1's and camera 2's images.
    mask_cam1 : ndarray (H, W) bool
        The garment's pixels in camera 1 (roughly).
    depth_mm : (float, float)
        Nearest and farthest depth matched.
    rng : int, Generator or None
        Seed of RANSAC's samples.

    Returns
    -------
    TablePlane

    Raises
    ------
    NoGarmentError
        Too few matched pixels for a plane.
    """
    m1x, m1y, _, _, R1, P1, ftx = _rectification(rig, _size(right_bgr))
    f_tx = abs(float(ftx[0]))
    g1, g2 = _rectified(rig, right_bgr, left_bgr)
    disp = _disparity(g1, g2, f_tx, depth_mm)
    garment = cv2.remap(mask_cam1.astype(np.uint8), m1x, m1y, cv2.INTER_NEAREST) > 0
    inner = cv2.erode(garment.astype(np.uint8), np.ones((5, 5), np.uint8), iterations=2) > 0
    smooth = cv2.GaussianBlur(g1.astype(np.float32), (0, 0), 1.0)
    textured = np.abs(cv2.Sobel(smooth, cv2.CV_32F, 1, 0, ksize=3) / 8.0) >= MIN_TEXTURE
    band = False
    use = inner & np.isfinite(disp) & textured
    if np.count_nonzero(use) < MIN_PLANE_POINTS:
        band = True
        grown = cv2.dilate(garment.astype(np.uint8), np.ones((3, 3), np.uint8),
                           iterations=BAND_PX) > 0
        use = grown & np.isfinite(disp) & textured
    if np.count_nonzero(use) < 50:
        raise NoGarmentError("stereo", f"too few pixels of the garment match between the two "
                                       f"views for its plane ({np.count_nonzero(use)})")
    v, u = np.nonzero(use)
    z = f_tx / disp[v, u].astype(np.float64)
    f, cx, cy = P1[0, 0], P1[0, 2], P1[1, 2]
    rect = np.column_stack([(u - cx) * z / f, (v - cy) * z / f, z])
    normal_r, distance_r, inliers = _fit_plane(rect, np.random.default_rng(rng))
    # the plane's disparity in rectified pixels: d = f Tx / Z, affine in (u, v)
    n = normal_r / distance_r
    abc = f_tx * np.array([n[0] / f, n[1] / f, n[2] - (n[0] * cx + n[1] * cy) / f])
    keep = np.zeros_like(use)
    keep[v[inliers], u[inliers]] = True
    a, b, c = _refine_disparity_plane(g1, g2, keep, abc)
    normal_r = np.array([a * f, b * f, a * cx + b * cy + c])
    distance_r = f_tx / np.linalg.norm(normal_r)
    normal_r /= np.linalg.norm(normal_r)
    residual = rect[inliers] @ normal_r - distance_r
    return TablePlane(normal_r @ R1, float(distance_r), float(np.sqrt(np.mean(residual**2))),
                      int(np.count_nonzero(inliers)), band)


def _fit_plane(points: NDArray[np.float64], gen: np.random.Generator
               ) -> tuple[NDArray[np.float64], float, NDArray[np.bool_]]:
    """RANSAC plane through ``points`` (N, 3), refined by least squares on the inliers: unit
    normal (away from the origin), distance, inlier mask."""
    n = len(points)
    best = np.zeros(n, bool)
    for _ in range(RANSAC_ITERATIONS):
        a, b, c = points[gen.choice(n, 3, replace=False)]
        normal = np.cross(b - a, c - a)
        norm = np.linalg.norm(normal)
        if norm < 1e-9:
            continue
        normal /= norm
        inliers = np.abs(points @ normal - a @ normal) < RANSAC_TOLERANCE_MM
        if np.count_nonzero(inliers) > np.count_nonzero(best):
            best = inliers
    for _ in range(2):
        centre = points[best].mean(axis=0)
        normal = np.linalg.svd(points[best] - centre, full_matrices=False)[2][2]
        distance = float(centre @ normal)
        if distance < 0:
            normal, distance = -normal, -distance
        residual = points @ normal - distance
        sigma = float(np.sqrt(np.mean(residual[best] ** 2)))
        best = np.abs(residual) < max(3.0 * sigma, 0.5)
    return normal, distance, best


# ----------------------------------------------------------------------------- orthophoto

@dataclass(frozen=True)
class Orthophoto:
    """Camera 1's view of a plane resampled as a fronto-parallel photo.

    Attributes
    ----------
    maps : (ndarray (h, w) float32, ndarray (h, w) float32)
        Camera 1's pixel of each orthophoto pixel (for ``cv2.remap``).
    camera : PinholeCamera
        The virtual camera (no distortion) that sees the orthophoto.
    R_cam1_virtual : ndarray (3, 3)
        Its orientation in camera 1 (same centre).
    distance_mm : float
        Its distance from the plane.
    mm_per_px : float
    """

    maps: tuple[NDArray[np.float32], NDArray[np.float32]]
    camera: PinholeCamera
    R_cam1_virtual: NDArray[np.float64]
    distance_mm: float
    mm_per_px: float

    def resample(self, image: NDArray[np.uint8]) -> NDArray[np.uint8]:
        """``image`` (camera 1's) in the orthophoto's pixels."""
        return cv2.remap(image, *self.maps, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)


def _size(image: NDArray[np.uint8]) -> tuple[int, int]:
    return int(image.shape[1]), int(image.shape[0])


def orthophoto(camera: PinholeCamera, plane: TablePlane, margin_px: int = 2,
               size: tuple[int, int] | None = None) -> Orthophoto:
    """The orthophoto of ``plane`` (in ``camera``'s frame) over the largest rectangle of it
    that ``camera`` sees in its images of ``size`` (w, h; default the calibration's),
    ``margin_px`` inside them (module docstring, step 3)."""
    R = plane.R_cam1_plane()
    d = plane.distance_mm
    f = float(np.sqrt(camera.K[0, 0] * camera.K[1, 1]))
    s = d / f
    w, h = size or (camera.width_px or 0, camera.height_px or 0)
    edge = np.concatenate([np.column_stack([np.linspace(0, w - 1, 64), np.full(64, y)])
                           for y in (0, h - 1)]
                          + [np.column_stack([np.full(64, x), np.linspace(0, h - 1, 64)])
                             for x in (0, w - 1)])
    rays = np.column_stack([camera.undistort_pixels(edge), np.ones(len(edge))])
    on_plane = rays * (d / (rays @ plane.normal_cam1))[:, None]
    xy = (on_plane @ R)[:, :2] / s                         # virtual pixels about the foot
    lo, hi = np.floor(xy.min(axis=0)).astype(int), np.ceil(xy.max(axis=0)).astype(int)
    size = hi - lo + 1
    u, v = np.meshgrid(np.arange(size[0], dtype=np.float64) + lo[0],
                       np.arange(size[1], dtype=np.float64) + lo[1])
    virtual = np.stack([u * s, v * s, np.full_like(u, d)], axis=-1)
    uv = camera.project(virtual @ R.T)
    seen = ((uv[..., 0] >= margin_px) & (uv[..., 0] <= w - 1 - margin_px)
            & (uv[..., 1] >= margin_px) & (uv[..., 1] <= h - 1 - margin_px))
    r0, r1, c0, c1 = _inscribed(seen)
    uv = uv[r0:r1, c0:c1]
    K = np.array([[f, 0.0, -(lo[0] + c0)], [0.0, f, -(lo[1] + r0)], [0.0, 0.0, 1.0]])
    virtual_camera = PinholeCamera(K, np.zeros(5), c1 - c0, r1 - r0)
    maps = (np.ascontiguousarray(uv[..., 0], dtype=np.float32),
            np.ascontiguousarray(uv[..., 1], dtype=np.float32))
    return Orthophoto(maps, virtual_camera, R, d, s)


def _inscribed(seen: NDArray[np.bool_]) -> tuple[int, int, int, int]:
    """Rows ``r0:r1`` and columns ``c0:c1`` of a large rectangle of ``seen`` pixels only: the
    bounding box, its side with the most unseen pixels moved in until none is left."""
    r0, r1, c0, c1 = 0, seen.shape[0], 0, seen.shape[1]
    while r1 - r0 > 2 and c1 - c0 > 2:
        box = seen[r0:r1, c0:c1]
        sides = [np.count_nonzero(~box[0]), np.count_nonzero(~box[-1]),
                 np.count_nonzero(~box[:, 0]), np.count_nonzero(~box[:, -1])]
        k = int(np.argmax(sides))
        if sides[k] == 0:
            break
        if k == 0:
            r0 += 1
        elif k == 1:
            r1 -= 1
        elif k == 2:
            c0 += 1
        else:
            c1 -= 1
    return r0, r1, c0, c1


# ----------------------------------------------------------------------------- the build

def _rough_garment(right: NDArray[np.uint8], empty: NDArray[np.uint8],
                   config: BuildConfig) -> NDArray[np.bool_]:
    """Camera 1's pixels unlike the empty table (step 1), cleaned to the largest part."""
    photo = _smooth(right, config.smooth_sigma_px)
    table = _smooth(empty, config.smooth_sigma_px)
    differs = _differs_from_plane(_log_opponent(photo), _log_opponent(table), config)
    return _clean_mask(differs) > 0


_CUT = ("the garment is cut by camera 1's image border (not wholly in view): move the hand or "
        "the garment so that all of it shows")


def _check_views(rig: StereoRig, views: tuple[NDArray[np.uint8] | None, ...],
                 names: list[str]) -> None:
    """The four views' sizes against the calibration and each other, and the empty pair
    whole or absent (InputError naming the view)."""
    right, left, empty_right, empty_left = views
    assert right is not None and left is not None
    rig.cam1.check_image(right, names[0])
    rig.cam2.check_image(left, names[1])
    for image, source in ((left, names[1]), (empty_right, names[2]), (empty_left, names[3])):
        if image is not None and image.shape != right.shape:
            raise InputError(source, f"size {image.shape[1]}x{image.shape[0]} differs from "
                                     f"{names[0]}'s {right.shape[1]}x{right.shape[0]}")
    if (empty_right is None) != (empty_left is None):
        missing = names[3] if empty_left is None else names[2]
        raise InputError(missing, "give both views of the empty table, or neither")
    if empty_right is not None and empty_left is not None:
        rig.cam1.check_image(empty_right, names[2])
        rig.cam2.check_image(empty_left, names[3])


def build_in_place(
    rig: StereoRig,
    right_bgr: NDArray[np.uint8],
    left_bgr: NDArray[np.uint8],
    *,
    empty_right_bgr: NDArray[np.uint8] | None = None,
    empty_left_bgr: NDArray[np.uint8] | None = None,
    name: str = "garment",
    config: BuildConfig | None = None,
    sources: tuple[str | os.PathLike[str], ...] = ("right", "left", "empty-right",
                                                   "empty-left"),
) -> InPlaceBuild:
    """Build a photo-model from the hand cameras' view of a garment lying on the table.

    Parameters
    ----------
    rig : StereoRig
        The hand cameras' calibration (camera 1 the reference).
    right_bgr, left_bgr : ndarray (H, W, 3) uint8
        Camera 1's and camera 2's images of the garment on the table.
    empty_right_bgr, empty_left_bgr : ndarray (H, W, 3) uint8, optional
        The same views of the table without the garment (both or neither); without them the
        garment is told from the table's colour.
    name : str
    config : BuildConfig, optional
        The station build's settings.
    sources : tuple of str
        Names of the four images in error messages (the files they came from).

    Returns
    -------
    InPlaceBuild

    Raises
    ------
    InputError
        A view's size differs from the calibration, one empty view without the other, or the
        garment is cut by camera 1's image border.
    NoGarmentError
        Nothing differs from the empty table (or its colour), or too little matches between
        the views for the garment's plane.
    """
    cfg = config or BuildConfig()
    names = [str(s) for s in sources]
    _check_views(rig, (right_bgr, left_bgr, empty_right_bgr, empty_left_bgr), names)
    empty = empty_right_bgr is not None
    rough = _rough_garment(right_bgr, empty_right_bgr if empty_right_bgr is not None
                           else surface_photo(right_bgr), cfg)
    if np.count_nonzero(rough) < 50:
        where = f"{names[2]} (is the garment in the empty pair too?)" if empty else \
            "the table's colour"
        raise NoGarmentError(names[0], f"no garment found: nothing differs from {where}")
    if np.count_nonzero(np.concatenate([rough[0], rough[-1], rough[:, 0], rough[:, -1]])) > 2:
        raise InputError(names[0], _CUT)
    plane = measure_plane(rig, right_bgr, left_bgr, rough)
    tilt = float(np.degrees(np.arccos(np.clip(plane.normal_cam1 @ rig.R_cam1_facing[:, 2],
                                              -1.0, 1.0))))
    if not (tilt <= MAX_TILT_DEG and DEPTH_RANGE_MM[0] <= plane.distance_mm
            <= DEPTH_RANGE_MM[1]):
        raise InputError(names[0], f"the stereo pair gives no table plane under the garment "
                                   f"({tilt:.0f} deg from facing the rig, "
                                   f"{plane.distance_mm:.0f} mm away): is the garment flat "
                                   f"on the table, wholly in both views?")
    ortho = orthophoto(rig.cam1, plane, size=_size(right_bgr))
    photo = ortho.resample(right_bgr)
    background = (ortho.resample(empty_right_bgr) if empty_right_bgr is not None
                  else surface_photo(photo))
    try:
        built = build_photo_model(photo, background, ortho.camera, ortho.distance_mm,
                                  name=name, config=cfg, photo_source=names[0],
                                  background_source=names[2] if empty else "the table's colour")
    except InputError as exc:
        if "border" in str(exc):
            raise InputError(names[0], _CUT) from None
        raise
    centroid = np.asarray(built.model.meta["centroid_in_camera_mm"], dtype=np.float64)
    T_cam1_model = np.eye(4)
    T_cam1_model[:3, :3] = ortho.R_cam1_virtual
    T_cam1_model[:3, 3] = ortho.R_cam1_virtual @ centroid
    built.model.meta["in_place"] = {
        "plane_normal_cam1": [float(x) for x in plane.normal_cam1],
        "plane_distance_mm": plane.distance_mm, "plane_rms_mm": plane.rms_mm,
        "plane_points": plane.points, "plane_band": plane.band,
        "mm_per_px": ortho.mm_per_px, "empty_pair": empty, "T_cam1_model": T_cam1_model.tolist()}
    return InPlaceBuild(built, plane, T_cam1_model, ortho.mm_per_px, photo)
