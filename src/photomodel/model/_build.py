"""Photo-model generation (paper sec. 2.2): background hue, garment mask, S_in and S_out.

Steps, as in the paper, with the choices it leaves open written down:

1. Both photos are smoothed (Gaussian, ``smooth_sigma_px``) and converted to HSV (hue in deg).
2. The plane's *average hue* is the circular mean of the background photo's hue, weighted by
   saturation (hue is meaningless for grey pixels).
3. Per pixel of the garment photo, the *hue error* against that average. A pixel is garment
   when the error exceeds ``hue_threshold_deg``. Hue alone cannot see white, grey or black
   fabric, whose hue is undefined, so a pixel is also garment when its saturation is below
   ``achromatic_fraction`` of the plane's median saturation or its value is below
   ``dark_fraction`` of the plane's median value (the plane is a saturated, lit green, so
   neither can be the plane).
   The *per-pixel rule* (``background_compare``, :func:`_differs_from_plane`) also compares
   each pixel with the same pixel of the background photo in the log-opponent space of
   ``image/_features.py`` (lightness, red-green, yellow-blue of log(channel + 8)): the pixel is
   garment when its chromaticity differs by more than ``chroma_threshold``, when it is lighter
   by more than ``lighter_fraction``, or darker than ``shadow_fraction`` of the plane there.
   A shadow on the plane (darker, same chromaticity, above ``shadow_fraction``) stays plane.
   A global exposure or white-balance change between the two photos is removed first (the
   median difference over the photo's border, where the garment may not lie). A pixel is
   garment when either rule says so (the per-pixel rule adding only regions at least
   ``ADDED_MIN_PX`` wide); on a plane without hue (grey, white, black) it works alone.
4. The mask is cleaned (opening 3x3, closing 5x5), reduced to its largest connected component
   and its holes are filled.
   Its outline is then moved to where the photo is half garment, half plane (``mixing_edge``;
   :func:`_mixing_edge`): the thresholds put a grey or dark garment's edge where the mix of
   garment and green is past half garment, so the model would come out a fraction of a pixel
   too small on every side (and be located too near). With the per-pixel rule the plane's
   colour there is first scaled to the photo's lightness just outside the mask (a shadow).
5. Pixels become millimetres on the plane through the model camera's intrinsics *and
   distortion* (exact inverse) and the camera-to-plane distance; the model frame's origin is the
   silhouette's area centroid on the plane (each pixel weighted by its area on the plane).
6. S_in: a square grid of pitch ``step_mm`` over the silhouette, plus a ring of points every
   ``step_mm`` along the outline inset by ``edge_inset_mm``, so that the outline is sampled as
   finely as the inside; each point keeps the hue, saturation and value of the photo there.
7. S_out: rings every ``step_mm`` along the outline offset outwards by ``band_gap_mm``,
   ``band_gap_mm + step_mm``, ... up to ``band_gap_mm + band_width_mm``: the band that
   envelops the outline.

The build reports how much of the silhouette has a colour close to the plane's
(:class:`BuildQuality`) and warns (:class:`~photomodel.errors.InputWarning`) when that share
exceeds ``plane_share_warning``: such a model stands on the per-pixel rule alone, and a
change of light or camera between the two photos would move it.

Defaults (reasoning in docs/method/build.md). The hand cameras see the table at about
1.2 px/mm, so ``step_mm = 3`` puts neighbouring samples about 3.5 px apart (2000-4000 S_in
points for a mid-size garment). The outline ring is inset, and the band starts, 1.5 mm (about
2 px) from the outline, to stay on the right side of it through the scene's blur; the band's
6 mm width is about as wide as the pose errors the search must still correct at the end.
"""

from __future__ import annotations

import datetime as _dt
import os
import warnings
from dataclasses import asdict, dataclass
from pathlib import Path

import cv2
import numpy as np
from numpy.typing import NDArray

from photomodel._limits import MAX_DISTANCE_MM
from photomodel.camera import PinholeCamera
from photomodel.errors import InputError, InputWarning, NoGarmentError
from photomodel.image import bgr_to_hsv, circular_mean_hue_deg, hue_distance_deg, sample_bilinear
from photomodel.model._config import DEFAULT_STATION_DISTANCE_MM, BuildConfig
from photomodel.model._photomodel import PhotoModel

__all__ = ["BuildConfig", "BuildQuality", "BuildResult", "build_model", "build_photo_model"]

MIN_POINTS = 8
"""Fewest S_in and S_out points a model needs (``step_mm`` too large for a garment leaves
fewer)."""
LOG_OFFSET = 8.0
"""Grey levels added before the logarithm (as in ``image/_features.py``'s log-opponent space)."""
CLOSE_CHROMA = 0.5
"""Log-chromaticity distance from the plane's median colour under which a pixel's colour is
*close to the plane's* (the dark-green hem and the leaf-green ground of the catalogue lie at
0.3-0.35; the paper's garments at 0.8 and beyond)."""
CLOSE_LIGHTNESS = float(np.log(2.0))
"""Log-lightness distance (a factor 2) under which a pixel's colour is close to the plane's."""
ADDED_MIN_PX = 5
"""Narrowest region (px) the per-pixel rule adds to the hue rule's garment pixels."""
SHADING_MIN = 0.03
"""Smallest lightness change of the plane beside the garment (photo over background photo)
that the mixing edge takes for a shadow; the two photos' noise gives under 1 %."""
BORDER_PX = 16
NOISE_SIGMAS = 6.0
"""The per-pixel rule's thresholds are at least this many noise std of the two photos'
difference: on the simulated green plane 0.04 in lightness and 0.08 in chromaticity (under
the defaults), on the black plane 0.09 and 0.17 (above them)."""
"""Width of the photo's border band from which the exposure and colour change between the two
photos is estimated."""


@dataclass(frozen=True)
class BuildQuality:
    """How far the silhouette can be trusted.

    Parameters
    ----------
    plane_colour_share : float
        Share (0-1) of the silhouette's pixels (2 px clear of its outline, where no pixel
        blends garment and plane) whose colour is close to the plane's median colour
        (log-chromaticity distance under :data:`CLOSE_CHROMA`, lightness within a factor 2):
        the part of the garment that only the per-pixel comparison with the background photo
        separates from the plane.
    hue_rule_shift_mm : float or None
        How far the paper's average-hue rule alone would have put the model's origin from this
        model's, mm (None on a plane without hue, when that rule finds no garment, or when it
        built the model alone: ``background_compare`` off).
    hue_rule_area_ratio : float or None
        Area of the hue rule's silhouette over this model's (None likewise).
    warning : str or None
        The warning issued (``plane_colour_share`` over ``plane_share_warning``), or None.
    """

    plane_colour_share: float
    hue_rule_shift_mm: float | None
    hue_rule_area_ratio: float | None
    warning: str | None = None

    def summary(self) -> str:
        """One line: ``plane colour 12.3 % of the silhouette (hue rule alone: 4.1 mm off)``."""
        text = f"plane colour {100 * self.plane_colour_share:.1f} % of the silhouette"
        if self.hue_rule_shift_mm is not None:
            text += f" (hue rule alone: {self.hue_rule_shift_mm:.1f} mm off)"
        return text


@dataclass(frozen=True)
class BuildResult:
    """A built model, its quality report, and what a preview needs: the full-size mask and
    sample pixels."""

    model: PhotoModel
    mask: NDArray[np.bool_]
    uv_in: NDArray[np.float64]
    uv_out: NDArray[np.float64]
    uv_outline: NDArray[np.float64]
    quality: BuildQuality | None = None


def build_photo_model(
    photo_bgr: NDArray[np.uint8],
    background_bgr: NDArray[np.uint8],
    camera: PinholeCamera,
    distance_mm: float = DEFAULT_STATION_DISTANCE_MM,
    *,
    name: str = "garment",
    config: BuildConfig | None = None,
    photo_source: str | os.PathLike[str] = "photo",
    background_source: str | os.PathLike[str] = "background",
) -> BuildResult:
    """Build a photo-model from a garment photo and a photo of the empty plane.

    Parameters
    ----------
    photo_bgr, background_bgr : ndarray (H, W, 3) uint8
        The garment on the plane, and the plane alone, from the same fixed camera.
    camera : PinholeCamera
        The model camera (intrinsics and distortion are both used).
    distance_mm : float
        Distance from the camera centre to the plane along the optical axis.
    name : str
        The model's name.
    config : BuildConfig, optional
        Thresholds and sampling; defaults as documented.
    photo_source, background_source : str or path-like
        Names used in error messages (the files the images came from).

    Returns
    -------
    BuildResult

    Raises
    ------
    InputError
        Sizes differ, the plane has no hue (only without ``background_compare``), or the
        garment touches the photo border.
    NoGarmentError
        Nothing in the photo differs from the plane.

    Warns
    -----
    InputWarning
        More than ``plane_share_warning`` of the silhouette has the plane's colour.
    """
    cfg = config or BuildConfig()
    _check_inputs(photo_bgr, background_bgr, camera, distance_mm, photo_source,
                  background_source)
    photos = _Photos.smoothed(photo_bgr, background_bgr, cfg, background_source)
    mask, hue_mask, features = _silhouette(photos, cfg)
    area_mm2 = _check_silhouette(mask, camera, distance_mm, photos.plane_hue_deg, cfg,
                                 photo_source)
    centroid, area = _area_centroid(mask, camera, distance_mm)
    quality = _warn_on_plane_colour(
        _quality(mask, hue_mask, features, photos, camera, distance_mm, centroid, area),
        cfg, photo_source)
    points_in, points_out, uv_in, uv_out, outline_uv, outline = _sample(
        mask, camera, distance_mm, centroid, cfg)
    meta = _meta(photos, camera, distance_mm, centroid, area_mm2, quality, cfg, photo_source,
                 background_source)
    photo_crop, mask_crop, crop_origin = _crop(photo_bgr, mask, cfg.crop_margin_px)
    model = PhotoModel(name=name, points_in_mm=points_in,
                       hsv_in=bgr_to_hsv(sample_bilinear(photos.photo, uv_in)),
                       points_out_mm=points_out, outline_mm=outline, photo_bgr=photo_crop,
                       mask=mask_crop, crop_origin_px=crop_origin, meta=meta)
    return BuildResult(model, mask.astype(bool), uv_in, uv_out, outline_uv, quality)


def _check_inputs(photo_bgr: NDArray[np.uint8], background_bgr: NDArray[np.uint8],
                  camera: PinholeCamera, distance_mm: float,
                  photo_source: str | os.PathLike[str],
                  background_source: str | os.PathLike[str]) -> None:
    """Raise where the photos' sizes (H, W, 3) differ, the camera's calibrated size is not
    the photo's, or ``distance_mm`` is not in (0, :data:`MAX_DISTANCE_MM`]."""
    if photo_bgr.shape != background_bgr.shape:
        raise InputError(background_source, f"size {background_bgr.shape[1]}x"
                         f"{background_bgr.shape[0]} differs from the photo's "
                         f"{photo_bgr.shape[1]}x{photo_bgr.shape[0]}")
    camera.check_image(photo_bgr, str(photo_source))
    if not (np.isfinite(distance_mm) and 0 < distance_mm <= MAX_DISTANCE_MM):
        raise ValueError(f"distance_mm: expected a distance above 0 to {MAX_DISTANCE_MM:g} mm, "
                         f"got {distance_mm:g}")


@dataclass(frozen=True)
class _Photos:
    """Steps 1-2 of the module docstring: both photos smoothed (H, W, 3) uint8, the garment
    photo's HSV (H, W, 3) (hue in deg, saturation and value 0-1) and the plane's colour (the
    background photo's median saturation and value, 0-1, and its saturation-weighted circular
    mean hue in deg, None on a plane without hue)."""

    photo: NDArray[np.uint8]
    background: NDArray[np.uint8]
    hsv: NDArray[np.float32]
    plane_sat: float
    plane_val: float
    plane_hue_deg: float | None

    @classmethod
    def smoothed(cls, photo_bgr: NDArray[np.uint8], background_bgr: NDArray[np.uint8],
                 cfg: BuildConfig, background_source: str | os.PathLike[str]) -> _Photos:
        """Smooth and convert both photos; raise ``InputError`` where the plane has no hue
        and the hue rule must work alone (``background_compare`` off)."""
        smooth_background = _smooth(background_bgr, cfg.smooth_sigma_px)
        hsv_bg = bgr_to_hsv(smooth_background)
        smooth_photo = _smooth(photo_bgr, cfg.smooth_sigma_px)
        hsv = bgr_to_hsv(smooth_photo)
        bg_sat = float(np.median(hsv_bg[..., 1]))
        bg_val = float(np.median(hsv_bg[..., 2]))
        chromatic_plane = bg_sat >= 0.15
        if not chromatic_plane and not cfg.background_compare:
            raise InputError(background_source, f"the plane has no clear hue (median "
                             f"saturation {bg_sat:.2f}); the hue rule alone needs a coloured "
                             f"(green) plane: compare with the background photo (drop "
                             f"--hue-only)")
        bg_hue = (circular_mean_hue_deg(hsv_bg[..., 0], weights=hsv_bg[..., 1])
                  if chromatic_plane else None)
        return cls(smooth_photo, smooth_background, hsv, bg_sat, bg_val, bg_hue)


def _hue_rule(photos: _Photos, cfg: BuildConfig) -> NDArray[np.uint8]:
    """The paper's rule (step 3): 1 (H, W) where the garment photo's hue is far from the
    plane's, or it is achromatic or dark against the plane; all 0 on a plane without hue."""
    if photos.plane_hue_deg is None:
        return np.zeros(photos.photo.shape[:2], np.uint8)
    hsv = photos.hsv
    return (
        (hue_distance_deg(hsv[..., 0], photos.plane_hue_deg) > cfg.hue_threshold_deg)
        | (hsv[..., 1] < cfg.achromatic_fraction * photos.plane_sat)
        | (hsv[..., 2] < cfg.dark_fraction * photos.plane_val)
    ).astype(np.uint8)


_Features = tuple[NDArray[np.float32], NDArray[np.float32]]
"""Log-opponent colours (H, W, 3) of the smoothed photo and background photo."""


def _silhouette(photos: _Photos, cfg: BuildConfig
                ) -> tuple[NDArray[np.uint8], NDArray[np.uint8] | None, _Features | None]:
    """Steps 3-4: the garment mask (H, W) of 0 and 1, what the hue rule alone gives (None on
    a plane without hue; the mask itself where the per-pixel rule adds nothing), and both
    photos' log-opponent colours (None when the hue rule works alone)."""
    by_hue = _hue_rule(photos, cfg)

    def outline(garment: NDArray[np.uint8], shading: bool = False) -> NDArray[np.uint8]:
        m = _clean_mask(garment)
        if cfg.mixing_edge and m.any():
            m = _mixing_edge(m, photos.photo, photos.background,
                             min_contrast=cfg.mixing_min_contrast, shading=shading)
        return m

    if not cfg.background_compare:   # the paper's rule alone (the plane has a hue: see above)
        mask = outline(by_hue)
        return mask, mask, None
    feat_photo, feat_bg = _log_opponent(photos.photo), _log_opponent(photos.background)
    # Only regions the hue rule misses, at least ADDED_MIN_PX wide: the thin halo the
    # per-pixel rule sees around every garment (its blurred edge, a tenth garment and
    # more) would otherwise move the outline outwards and bias the mixing edge.
    added = _differs_from_plane(feat_photo, feat_bg, cfg) & (1 - by_hue)
    added = cv2.morphologyEx(added, cv2.MORPH_OPEN, cv2.getStructuringElement(
        cv2.MORPH_ELLIPSE, (ADDED_MIN_PX, ADDED_MIN_PX)))
    mask = outline(by_hue | added, shading=True)
    # What the hue rule alone gives, for the quality report: the same regions when the
    # per-pixel rule adds none.
    hue_mask = None if photos.plane_hue_deg is None else outline(by_hue) if added.any() else mask
    return mask, hue_mask, (feat_photo, feat_bg)


def _check_silhouette(mask: NDArray[np.uint8], camera: PinholeCamera, distance_mm: float,
                      plane_hue_deg: float | None, cfg: BuildConfig,
                      photo_source: str | os.PathLike[str]) -> float:
    """The silhouette's area, mm^2 (pixels at the mean scale of the plane); raise
    ``NoGarmentError`` under ``cfg.min_area_mm2`` and ``InputError`` where ``mask`` (H, W)
    touches the photo's border."""
    px_per_mm = float(np.sqrt(camera.K[0, 0] * camera.K[1, 1])) / distance_mm
    area_mm2 = mask.sum() / px_per_mm**2
    if area_mm2 < cfg.min_area_mm2:
        plane = (f"the plane's hue ({plane_hue_deg:.0f} deg)" if plane_hue_deg is not None
                 else "the plane (it has no hue)")
        raise NoGarmentError(photo_source, f"no garment found: nothing larger than "
                             f"{cfg.min_area_mm2:.0f} mm^2 differs from {plane}")
    border = np.concatenate([mask[0], mask[-1], mask[:, 0], mask[:, -1]])
    if border.sum() > 2:
        raise InputError(photo_source, "the garment touches the photo's border, so its outline "
                         "is cut; centre it or raise the camera")
    return area_mm2


def _area_centroid(mask: NDArray[np.uint8], camera: PinholeCamera, distance_mm: float
                   ) -> tuple[NDArray[np.float64], float]:
    """The area-weighted centroid (2,) of silhouette ``mask`` (H, W) on the plane (mm, model
    camera's frame; each pixel weighted by its area on the plane) and its area, mm^2."""
    vv, uu = np.nonzero(mask)
    uv_mask = np.stack([uu, vv], axis=-1).astype(np.float64)
    xy_mask = camera.undistort_pixels(uv_mask) * distance_mm
    pixel_area = _pixel_area_mm2(camera, uv_mask, distance_mm)
    return (xy_mask * pixel_area[:, None]).sum(axis=0) / pixel_area.sum(), pixel_area.sum()


def _warn_on_plane_colour(quality: BuildQuality, cfg: BuildConfig,
                          photo_source: str | os.PathLike[str]) -> BuildQuality:
    """``quality``, with its warning issued (:class:`~photomodel.errors.InputWarning`, to
    :func:`build_photo_model`'s caller) where over ``cfg.plane_share_warning`` of the
    silhouette has the plane's colour."""
    if quality.plane_colour_share <= cfg.plane_share_warning:
        return quality
    moved = ("" if quality.hue_rule_shift_mm is None else
             f", the hue rule alone would move it {quality.hue_rule_shift_mm:.1f} mm")
    problem = (f"{100 * quality.plane_colour_share:.0f} % of the garment has the plane's "
               f"colour: only the comparison with the background photo finds it{moved}; "
               f"keep light and camera fixed between the two photos, or use a plane of "
               f"another colour")
    warnings.warn(InputWarning(photo_source, problem), stacklevel=3)
    return BuildQuality(quality.plane_colour_share, quality.hue_rule_shift_mm,
                        quality.hue_rule_area_ratio, f"{Path(photo_source).name}: {problem}")


def _meta(photos: _Photos, camera: PinholeCamera, distance_mm: float,
          centroid: NDArray[np.float64], area_mm2: float, quality: BuildQuality,
          cfg: BuildConfig, photo_source: str | os.PathLike[str],
          background_source: str | os.PathLike[str]) -> dict[str, object]:
    """The model's metadata: when and from what it was built (``centroid`` (2,), mm, in the
    model camera's frame), its area (mm^2), its quality and its settings."""
    h, w = photos.photo.shape[:2]
    return {
        "created_utc": _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds"),
        "photo": Path(photo_source).name,
        "background": Path(background_source).name,
        "distance_mm": float(distance_mm),
        "camera_K": camera.K.tolist(),
        "camera_dist": camera.dist.tolist(),
        "photo_size_px": [w, h],
        "background_hue_deg": photos.plane_hue_deg,
        "centroid_in_camera_mm": [float(centroid[0]), float(centroid[1]), float(distance_mm)],
        "area_mm2": float(area_mm2),
        "plane_colour_share": quality.plane_colour_share,
        "hue_rule_shift_mm": quality.hue_rule_shift_mm,
        "hue_rule_area_ratio": quality.hue_rule_area_ratio,
        "build_config": asdict(cfg),
    }


def _crop(photo_bgr: NDArray[np.uint8], mask: NDArray[np.uint8], margin_px: int
          ) -> tuple[NDArray[np.uint8], NDArray[np.uint8], NDArray[np.int64]]:
    """The photo (h, w, 3) and mask (h, w) cropped to the silhouette with ``margin_px``
    around it (within the photo), and the crop's top-left pixel (2,) (u, v)."""
    h, w = mask.shape
    vv, uu = np.nonzero(mask)
    x0, y0 = max(uu.min() - margin_px, 0), max(vv.min() - margin_px, 0)
    x1, y1 = min(uu.max() + margin_px + 1, w), min(vv.max() + margin_px + 1, h)
    return (np.ascontiguousarray(photo_bgr[y0:y1, x0:x1]),
            np.ascontiguousarray(mask[y0:y1, x0:x1]), np.array([x0, y0], dtype=np.int64))


def _sample(mask: NDArray[np.uint8], camera: PinholeCamera, distance_mm: float,
            centroid: NDArray[np.float64], cfg: BuildConfig
            ) -> tuple[NDArray[np.float64], ...]:
    """S_in, S_out and the outline of a silhouette (steps 5-7 of the module docstring):
    ``points_in``, ``points_out`` (model frame, mm), their pixels ``uv_in``, ``uv_out``,
    the outline's pixels and its model points. ``centroid`` (2,): the model origin on the
    plane in the camera frame, mm."""
    px_per_mm = float(np.sqrt(camera.K[0, 0] * camera.K[1, 1])) / distance_mm

    def to_model(uv: NDArray[np.float64]) -> NDArray[np.float64]:
        xy = camera.undistort_pixels(uv) * distance_mm - centroid
        return np.column_stack([xy, np.zeros(len(xy))])

    def to_pixels(xy_model: NDArray[np.float64]) -> NDArray[np.float64]:
        pts = np.column_stack([xy_model[:, :2] + centroid, np.full(len(xy_model), distance_mm)])
        return camera.project(pts)

    step_px = cfg.step_mm * px_per_mm
    dist_in = cv2.distanceTransform(mask, cv2.DIST_L2, cv2.DIST_MASK_PRECISE)
    dist_out = cv2.distanceTransform(1 - mask, cv2.DIST_L2, cv2.DIST_MASK_PRECISE)

    # S_in: grid inside, clear of the outline ring, plus the ring itself.
    inset_px = cfg.edge_inset_mm * px_per_mm + 0.5
    ring_in = _rings(dist_in >= inset_px, to_model, cfg.step_mm)
    vv, uu = np.nonzero(mask)
    xy_model = to_model(np.stack([uu, vv], axis=-1).astype(np.float64))[:, :2]
    lo = (xy_model.min(axis=0) // cfg.step_mm) * cfg.step_mm
    hi = xy_model.max(axis=0)
    gx, gy = np.meshgrid(np.arange(lo[0], hi[0] + cfg.step_mm, cfg.step_mm),
                         np.arange(lo[1], hi[1] + cfg.step_mm, cfg.step_mm))
    grid = np.column_stack([gx.ravel(), gy.ravel(), np.zeros(gx.size)])
    uv_grid = to_pixels(grid)
    keep = _lookup(dist_in, uv_grid) >= inset_px + 0.5 * step_px
    points_in = np.concatenate([grid[keep], ring_in])
    uv_in = to_pixels(points_in)

    # S_out: offset rings in the band outside the outline.
    radii_mm = cfg.band_gap_mm + np.arange(0.0, cfg.band_width_mm + 1e-9, cfg.step_mm)
    rings_out = [_rings(dist_out <= r * px_per_mm + 0.5, to_model, cfg.step_mm, outer=True)
                 for r in radii_mm]
    points_out = np.concatenate(rings_out) if rings_out else np.zeros((0, 3))
    if min(len(points_in), len(points_out)) < MIN_POINTS:
        raise ValueError(f"step_mm: a pitch of {cfg.step_mm:g} mm leaves {len(points_in)} points "
                         f"inside and {len(points_out)} around this garment (at least "
                         f"{MIN_POINTS} each are needed); choose a smaller pitch")
    uv_out = to_pixels(points_out)
    outline_uv = _largest_contour(mask)
    return points_in, points_out, uv_in, uv_out, outline_uv, to_model(outline_uv)


def surface_photo(image: NDArray[np.uint8], border_px: int = BORDER_PX) -> NDArray[np.uint8]:
    """A photo of ``image``'s size in the median colour of its border band (at most a quarter
    of its sides wide): the plain surface a garment lies on, where no photo of it alone was
    taken."""
    b = max(1, min(border_px, image.shape[0] // 4, image.shape[1] // 4))
    band = np.concatenate([image[:b].reshape(-1, 3), image[-b:].reshape(-1, 3),
                           image[:, :b].reshape(-1, 3), image[:, -b:].reshape(-1, 3)])
    return np.broadcast_to(np.median(band, axis=0).astype(np.uint8), image.shape).copy()


def _log_opponent(image: NDArray[np.uint8]) -> NDArray[np.float32]:
    """Log-opponent colour (H, W, 3) = (lightness, red-green, yellow-blue) in float, as
    ``image/_features.py`` defines it (without its rounding)."""
    logs = np.log(image.astype(np.float32) + np.float32(LOG_OFFSET))  # ln B, ln G, ln R
    lb, lg, lr = logs[..., 0], logs[..., 1], logs[..., 2]
    return np.stack([(lb + lg + lr) / 3, lr - lg, 0.5 * (lr + lg) - lb], axis=-1)


def _differs_from_plane(feat_photo: NDArray[np.float32], feat_bg: NDArray[np.float32],
                        cfg: BuildConfig) -> NDArray[np.uint8]:
    """The per-pixel rule: 1 where the photo's colour differs from the background photo's
    at the same pixel (chromaticity, or lightness beyond a shadow), else 0.

    The median difference over the photo's border band (:data:`BORDER_PX`), where the garment
    may not lie, is taken off first: a change of exposure or white balance between the two
    photos is not garment. The thresholds rise to :data:`NOISE_SIGMAS` times the noise of
    that difference in the band (robust estimates), where the photos are that noisy (a dark
    plane's logarithms are).
    """
    diff = feat_photo - feat_bg
    border = np.ones(diff.shape[:2], bool)
    border[BORDER_PX:-BORDER_PX, BORDER_PX:-BORDER_PX] = False
    diff = diff - np.median(diff[border], axis=0)
    chroma = np.hypot(diff[..., 1], diff[..., 2])
    light = diff[..., 0]
    # Noise std: lightness from its median absolute deviation, chromaticity from the median
    # of its (Rayleigh-distributed) magnitude.
    sigma_light = 1.4826 * float(np.median(np.abs(light[border])))
    sigma_chroma = float(np.median(chroma[border])) / 1.1774
    chroma_min = max(cfg.chroma_threshold, NOISE_SIGMAS * sigma_chroma)
    lighter = max(float(np.log1p(cfg.lighter_fraction)), NOISE_SIGMAS * sigma_light)
    darker = min(float(np.log(max(cfg.shadow_fraction, 1e-6))), -NOISE_SIGMAS * sigma_light)
    return ((chroma > chroma_min) | (light > lighter) | (light < darker)).astype(np.uint8)


def _quality(mask: NDArray[np.uint8], hue_mask: NDArray[np.uint8] | None,
             features: _Features | None, photos: _Photos, camera: PinholeCamera,
             distance_mm: float, centroid: NDArray[np.float64], area: float) -> BuildQuality:
    """The build's :class:`BuildQuality` (see there) of silhouette ``mask`` (H, W) with
    centroid (2,) (mm) and area (mm^2); ``features`` None: the hue rule built the model alone
    (nothing to compare it with)."""
    photo_feat, bg_feat = (features if features is not None else
                           (_log_opponent(photos.photo), _log_opponent(photos.background)))
    plane = np.median(bg_feat.reshape(-1, 3), axis=0)
    interior = cv2.erode(mask, cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (5, 5)))
    inside = photo_feat[interior > 0] - plane
    close = ((np.hypot(inside[:, 1], inside[:, 2]) < CLOSE_CHROMA)
             & (np.abs(inside[:, 0]) < CLOSE_LIGHTNESS))
    share = float(close.mean()) if len(close) else 0.0
    if hue_mask is None or features is None:   # no hue rule, or nothing but the hue rule
        return BuildQuality(share, None, None)
    if hue_mask is mask:   # the per-pixel rule added nothing
        return BuildQuality(share, 0.0, 1.0)
    if not hue_mask.any():
        return BuildQuality(share, None, 0.0)
    hue_centroid, hue_area = _area_centroid(hue_mask, camera, distance_mm)
    return BuildQuality(share, float(np.linalg.norm(hue_centroid - centroid)),
                        float(hue_area / area))


def _smooth(image: NDArray[np.uint8], sigma_px: float) -> NDArray[np.uint8]:
    return cv2.GaussianBlur(image, (0, 0), sigma_px) if sigma_px > 0 else image


def _mixing_edge(mask: NDArray[np.uint8], photo: NDArray[np.uint8],
                 background: NDArray[np.uint8], reach_px: float = 3.0,
                 min_contrast: float = 30.0, shading: bool = False) -> NDArray[np.uint8]:
    """``mask`` with its outline moved to where the photo is half garment, half plane.

    Near the outline (within ``reach_px``) each pixel's garment fraction is the projection
    of (photo - plane) on (garment - plane): the plane's colour is the background photo's
    at that pixel, the garment's the mean of the mask's pixels 2.5-6 px inside around it
    (both smoothed alike, so a symmetric blur keeps the half-way point on the true edge).
    Pixels where the two colours differ by less than ``min_contrast`` grey levels keep the
    thresholds' answer. The hue and saturation thresholds put a grey sock's edge where the
    mix is about 60 % sock (a grey-green mix keeps the plane's hue and saturation longer),
    which makes the model too small and places it too near.

    With ``shading`` the background photo's colour is scaled by the lightness ratio of the
    photo to the background photo 3.5-7 px outside the mask (clear of the garment's blur)
    where that ratio differs from 1
    by :data:`SHADING_MIN` or more (a shadow the garment casts on the plane darkens the plane
    next to its edge; unscaled, a dark garment's edge would move out into its shadow). Below
    that, sensor noise, the background photo's colour is taken as it is.
    """
    dist_in = cv2.distanceTransform(mask, cv2.DIST_L2, cv2.DIST_MASK_PRECISE)
    dist_out = cv2.distanceTransform(1 - mask, cv2.DIST_L2, cv2.DIST_MASK_PRECISE)
    core = ((dist_in >= 2.5) & (dist_in <= 6.0)).astype(np.float32)
    img = photo.astype(np.float32)
    plane = background.astype(np.float32)
    if shading:
        outer = ((dist_out >= 3.5) & (dist_out <= 7.0)).astype(np.float32)
        ratio = (img.sum(axis=-1) + 3 * LOG_OFFSET) / (plane.sum(axis=-1) + 3 * LOG_OFFSET)
        outer_weight = cv2.GaussianBlur(outer, (0, 0), 3.0)
        gain = cv2.GaussianBlur(ratio * outer, (0, 0), 3.0) / np.maximum(outer_weight, 1e-6)
        shaded = (outer_weight > 1e-3) & (np.abs(gain - 1.0) >= SHADING_MIN)
        plane = plane * np.where(shaded, gain, 1.0)[..., None]
    weight = cv2.GaussianBlur(core, (0, 0), 3.0)
    garment = cv2.GaussianBlur(img * core[..., None], (0, 0), 3.0) / np.maximum(
        weight, 1e-6)[..., None]
    contrast = garment - plane
    norm2 = np.sum(contrast**2, axis=-1)
    fraction = np.sum((img - plane) * contrast, axis=-1) / np.maximum(norm2, 1e-6)
    near = ((dist_in <= reach_px) & (mask > 0)) | ((dist_out <= reach_px) & (mask == 0))
    sure = near & (weight > 1e-3) & (norm2 >= min_contrast**2)
    out = mask.copy()
    out[sure] = fraction[sure] >= 0.5
    return _clean_mask(out)


def _clean_mask(garment: NDArray[np.uint8]) -> NDArray[np.uint8]:
    """Open, close, keep the largest component and fill its holes."""
    m = cv2.morphologyEx(garment, cv2.MORPH_OPEN, np.ones((3, 3), np.uint8))
    m = cv2.morphologyEx(m, cv2.MORPH_CLOSE, cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (5, 5)))
    n, labels, stats, _ = cv2.connectedComponentsWithStats(m, connectivity=8)
    if n <= 1:
        return np.zeros_like(m)
    largest = 1 + int(np.argmax(stats[1:, cv2.CC_STAT_AREA]))
    m = (labels == largest).astype(np.uint8)
    contours, _ = cv2.findContours(m, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)
    filled = np.zeros_like(m)
    cv2.drawContours(filled, contours, -1, 1, thickness=cv2.FILLED)
    return filled


def _pixel_area_mm2(camera: PinholeCamera, uv: NDArray[np.float64],
                    distance_mm: float) -> NDArray[np.float64]:
    """Area on the plane of each pixel (|det| of the pixel->plane Jacobian), mm^2."""
    h = 0.5
    c = camera.undistort_pixels(np.concatenate([uv + [h, 0], uv - [h, 0], uv + [0, h],
                                                uv - [0, h]])) * distance_mm
    n = len(uv)
    du = (c[:n] - c[n:2 * n]) / (2 * h)
    dv = (c[2 * n:3 * n] - c[3 * n:]) / (2 * h)
    return np.abs(du[:, 0] * dv[:, 1] - du[:, 1] * dv[:, 0])


def _lookup(image: NDArray, uv: NDArray[np.float64]) -> NDArray:
    """Nearest-pixel values at (u, v); -inf outside the image."""
    h, w = image.shape[:2]
    u = np.rint(uv[:, 0]).astype(np.int64)
    v = np.rint(uv[:, 1]).astype(np.int64)
    inside = (u >= 0) & (u < w) & (v >= 0) & (v < h)
    out = np.full(len(uv), -np.inf)
    out[inside] = image[v[inside], u[inside]]
    return out


def _largest_contour(mask: NDArray[np.uint8]) -> NDArray[np.float64]:
    contours, _ = cv2.findContours(mask.astype(np.uint8), cv2.RETR_EXTERNAL,
                                   cv2.CHAIN_APPROX_NONE)
    c = max(contours, key=cv2.contourArea)
    return c.reshape(-1, 2).astype(np.float64)


def _rings(region: NDArray[np.bool_], to_model, step_mm: float, outer: bool = False
           ) -> NDArray[np.float64]:
    """Points every ``step_mm`` along the outer contours of ``region``, model frame (K, 3)."""
    contours, _ = cv2.findContours(region.astype(np.uint8), cv2.RETR_EXTERNAL,
                                   cv2.CHAIN_APPROX_NONE)
    if outer and contours:
        contours = [max(contours, key=cv2.contourArea)]
    out = [_resample_closed(to_model(c.reshape(-1, 2).astype(np.float64)), step_mm)
           for c in contours if len(c) >= 3]
    out = [o for o in out if len(o)]
    return np.concatenate(out) if out else np.zeros((0, 3))


def _resample_closed(points: NDArray[np.float64], step: float) -> NDArray[np.float64]:
    """Equally spaced points (arc length ``step``) along a closed polyline (K, 3)."""
    closed = np.concatenate([points, points[:1]])
    seg = np.linalg.norm(np.diff(closed, axis=0), axis=1)
    s = np.concatenate([[0.0], np.cumsum(seg)])
    total = s[-1]
    if total < step:
        return np.zeros((0, 3))
    n = int(np.floor(total / step))
    targets = np.arange(n) * (total / n)
    return np.column_stack([np.interp(targets, s, closed[:, k]) for k in range(3)])


def build_model(
    photo_bgr: NDArray[np.uint8],
    background_bgr: NDArray[np.uint8],
    camera: PinholeCamera,
    distance_mm: float = DEFAULT_STATION_DISTANCE_MM,
    *,
    name: str = "garment",
    config: BuildConfig | None = None,
) -> PhotoModel:
    """The photo-model of :func:`build_photo_model` (without its build diagnostics).

    Parameters
    ----------
    photo_bgr, background_bgr : ndarray (H, W, 3) uint8
        The garment on the plane, and the plane alone, from the same fixed camera (BGR).
    camera : PinholeCamera
        The model station's camera (:func:`~photomodel.load_camera`).
    distance_mm : float
        Distance from the camera centre to the plane along the optical axis, mm.
    name : str
    config : BuildConfig, optional

    Returns
    -------
    PhotoModel
    """
    return build_photo_model(photo_bgr, background_bgr, camera, distance_mm, name=name,
                             config=config).model
