"""Model samples for the ``soft`` fitness: points inside the garment and rings around its edge.

The stored photo-model keeps its photo crop and silhouette mask, so the samples of each
pyramid level are drawn here from the photo instead of the fixed S_in / S_out of the file:

* the **edge** is the 0.5 iso-line of the mask smoothed by one pixel
  (:func:`skimage.measure.find_contours`, sub-pixel), resampled every ``ring_step_mm`` and
  carried into the model frame (mm) through the model camera;
* the **inner ring** lies ``ring_mm`` inside the edge along its normals, the **outer rings**
  (the S_out band) ``ring_mm``, ``ring_mm + band_step_mm``, ... outside it. Inner and outer
  rings at the same distance make the fitness peak where the garment's blurred edge lies
  halfway between them, with no plateau;
* the **interior** is a grid every ``grid_mm`` clear of the inner ring;
* every inner point keeps the model photo's log-opponent colour there
  (:func:`photomodel.image.log_opponent`), and every band point the colour of the nearest
  inner-ring point: the garment colour a band point must *not* see.
* the photo is blurred as the scene images are before the colours are read: by the hand
  camera's optics in grey levels (``optics_blur_mm``, estimated per scene by the search, since
  a print's colours mix in the sensor's values, not in their logarithms), then by the
  feature smoothing and the pyramid in the log-opponent features (``blur_mm``).

The point geometry does not depend on the blurs: it is computed once per model and spacing,
the colours once per blur.

Offset points that land on the wrong side of the edge (at concave corners, in narrow gaps)
are dropped by a distance-transform check.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from functools import cached_property

import cv2
import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree
from skimage.measure import find_contours

from photomodel.camera import PinholeCamera
from photomodel.fitness._prepared import Kept, PreparedModel, as_prepared
from photomodel.image._features import linear_intensity, log_opponent
from photomodel.image._sample import sample_bilinear
from photomodel.model import PhotoModel

__all__ = ["ModelSamples", "SampleSpacing", "model_samples"]


@dataclass(frozen=True)
class SampleSpacing:
    """Spacing of the samples of one pyramid level, mm on the garment.

    Attributes
    ----------
    grid_mm : float
        Interior grid step.
    ring_mm : float
        Distance of the inner and the first outer ring from the edge.
    ring_step_mm : float
        Step along the rings.
    band_rings : int
        Outer rings (the band), ``band_step_mm`` apart.
    band_step_mm : float
    band_gap_mm : float
        Extra distance of the outer rings beyond ``ring_mm`` (default 0). The first outer
        ring sees a share of the garment's blurred edge, so its vote against the garment
        falls as the model grows: it pulls a low-contrast garment's model larger, i.e.
        nearer. A gap corrects that in sharp images but moves blurred scenes' depths
        further off, so it is not the default.
    blur_mm : float
        Gaussian blur of the model photo's log-opponent features before its colours are
        sampled, mm on the garment: as much as the scene's feature images of that level
        have (smoothing and pyramid), so a fine print averages to the same colour in both.
    optics_blur_mm : float
        Gaussian blur of the model photo's grey levels before that, mm on the garment: the
        hand camera's optical blur (focus, motion), applied where the camera applies it.
    """

    grid_mm: float = 4.0
    ring_mm: float = 1.0
    ring_step_mm: float = 1.5
    band_rings: int = 3
    band_step_mm: float = 2.0
    band_gap_mm: float = 0.0
    blur_mm: float = 0.6
    optics_blur_mm: float = 0.0

    def scaled(self, factor: float, blur_mm: float | None = None) -> SampleSpacing:
        """Every distance multiplied by ``factor`` (a coarser pyramid level), a new blur."""
        return replace(self, grid_mm=self.grid_mm * factor, ring_mm=self.ring_mm * factor,
                       ring_step_mm=self.ring_step_mm * factor,
                       band_step_mm=self.band_step_mm * factor,
                       band_gap_mm=self.band_gap_mm * factor,
                       blur_mm=self.blur_mm * factor if blur_mm is None else blur_mm)

    @property
    def geometry(self) -> SampleSpacing:
        """This spacing without its blurs: what the sample points depend on."""
        return replace(self, blur_mm=0.0, optics_blur_mm=0.0)


@dataclass(frozen=True)
class ModelSamples:
    """Model-frame sample points (mm, z = 0) and their colours (log-opponent l, a, b).

    ``p_in`` (N, 3), ``f_in`` (N, 3): inner ring and interior; ``p_out`` (M, 3),
    ``f_out`` (M, 3): the band and the garment colour next to each band point;
    ``palette`` (K, 3): the garment's main colours (k-means of ``f_in``, K <= 6, computed
    on first use); ``table_out`` (N,): for each inner-ring point the band point of the
    outermost ring beside it (what the table looks like there), -1 for interior points;
    ``lin_in`` (N, 3): ``f_in`` as linear intensities (computed on first use);
    ``kept``: what the fitness and scan kernels derive from these samples, kept with them.
    """

    p_in: NDArray[np.float64]
    f_in: NDArray[np.float64]
    p_out: NDArray[np.float64]
    f_out: NDArray[np.float64]
    table_out: NDArray[np.intp] | None = None
    kept: Kept = field(default_factory=Kept, init=False, repr=False, compare=False)

    @cached_property
    def palette(self) -> NDArray[np.float64]:
        return _palette(self.f_in)

    @cached_property
    def lin_in(self) -> NDArray[np.float64]:
        """The inner colours as linear intensities (N, 3) (:func:`linear_intensity`), for
        the edge mixture; computed on first use and kept with the (cached) samples."""
        return linear_intensity(self.f_in)


@dataclass(frozen=True)
class _Geometry:
    """The blur-free part of :class:`ModelSamples`: points (model frame and photo crop)."""

    p_in: NDArray[np.float64]
    p_out: NDArray[np.float64]
    uv_in: NDArray[np.float64]
    nearest_in: NDArray[np.intp]
    px_per_mm: float
    table_out: NDArray[np.intp]


def _model_camera(model: PhotoModel) -> tuple[PinholeCamera, float, NDArray[np.float64]]:
    meta = model.meta
    camera = PinholeCamera(np.asarray(meta["camera_K"]), np.asarray(meta["camera_dist"]))
    centroid = np.asarray(meta["centroid_in_camera_mm"][:2], dtype=np.float64)
    return camera, float(meta["distance_mm"]), centroid


def _resample_closed(points: NDArray[np.float64], step: float) -> NDArray[np.float64]:
    closed = np.concatenate([points, points[:1]])
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(closed, axis=0), axis=1))])
    n = int(np.floor(s[-1] / step))
    if n < 8:
        return np.zeros((0, 2))
    t = np.arange(n) * (s[-1] / n)
    return np.column_stack([np.interp(t, s, closed[:, 0]), np.interp(t, s, closed[:, 1])])


def model_samples(model: PhotoModel | PreparedModel, spacing: SampleSpacing) -> ModelSamples:
    """Sample points and colours of ``model`` at ``spacing`` (see the module docstring).

    Kept in a :class:`~photomodel.fitness.PreparedModel` (per spacing; the points are shared
    by every blur of one spacing), so a prepared model is sampled once, not once per stereo
    pair.
    """
    prepared = as_prepared(model)
    shape = spacing.geometry

    def coloured() -> ModelSamples:
        geometry = prepared.kept.get(("geometry", shape),
                                     lambda: _geometry(prepared.model, shape))
        return _coloured(prepared.model, geometry, spacing)

    return prepared.kept.get(("samples", spacing), coloured)


def _lift(xy: NDArray[np.float64]) -> NDArray[np.float64]:
    """Model-plane points (N, 2) as (N, 3) with z = 0."""
    return np.ascontiguousarray(np.column_stack([xy, np.zeros(len(xy))]))


def _garment_blur(image: NDArray[np.float32], mask: NDArray[np.float32],
                  sigma_px: float) -> NDArray[np.float32]:
    """Gaussian blur of ``image`` (H, W, 3) over the garment only (normalised convolution
    with ``mask``): the model station's backdrop must not bleed into the garment's colours,
    it is not what lies around the garment in the scene."""
    if sigma_px <= 0:
        return image
    weight = cv2.GaussianBlur(mask, (0, 0), sigma_px)
    blurred = cv2.GaussianBlur(image * mask[..., None], (0, 0), sigma_px)
    return blurred / np.maximum(weight, 1e-3)[..., None]


def _coloured(model: PhotoModel, geometry: _Geometry, spacing: SampleSpacing) -> ModelSamples:
    """The samples of ``geometry`` with the photo's colours under ``spacing``'s blurs."""
    mask = model.mask.astype(np.float32)
    photo = model.photo_bgr
    if spacing.optics_blur_mm > 0:
        blurred = _garment_blur(photo.astype(np.float32), mask,
                                spacing.optics_blur_mm * geometry.px_per_mm)
        photo = np.clip(np.rint(blurred), 0, 255).astype(np.uint8)
    colours = _garment_blur(log_opponent(photo), mask,
                            max(spacing.blur_mm * geometry.px_per_mm, 0.3))
    f_in = np.ascontiguousarray(sample_bilinear(colours, geometry.uv_in), dtype=np.float64)
    return ModelSamples(geometry.p_in, f_in, geometry.p_out,
                        np.ascontiguousarray(f_in[geometry.nearest_in]), geometry.table_out)


def _geometry(model: PhotoModel, spacing: SampleSpacing) -> _Geometry:
    camera, distance_mm, centroid = _model_camera(model)
    origin = np.asarray(model.crop_origin_px, dtype=np.float64)
    px_per_mm = float(np.sqrt(camera.K[0, 0] * camera.K[1, 1])) / distance_mm

    def to_model(uv_crop: NDArray[np.float64]) -> NDArray[np.float64]:
        return camera.undistort_pixels(uv_crop + origin) * distance_mm - centroid

    def to_crop(xy: NDArray[np.float64]) -> NDArray[np.float64]:
        pts = np.column_stack([xy + centroid, np.full(len(xy), distance_mm)])
        return camera.project(pts) - origin

    mask = np.pad(model.mask.astype(np.uint8), 2)  # room for contours at the crop's edge
    pad = np.array([2.0, 2.0])
    soft = cv2.GaussianBlur(mask.astype(np.float32), (0, 0), 1.0)
    contour = max(find_contours(soft, 0.5), key=len)[:, ::-1] - pad  # (u, v) in the crop
    edge = _resample_closed(to_model(contour), spacing.ring_step_mm)
    tangent = np.roll(edge, -1, axis=0) - np.roll(edge, 1, axis=0)
    normal = np.column_stack([tangent[:, 1], -tangent[:, 0]])
    normal /= np.linalg.norm(normal, axis=1, keepdims=True) + 1e-12
    # Orient normals outwards: a step along them must leave the mask.
    dist_in = cv2.distanceTransform(mask, cv2.DIST_L2, cv2.DIST_MASK_PRECISE)
    dist_out = cv2.distanceTransform(1 - mask, cv2.DIST_L2, cv2.DIST_MASK_PRECISE)
    probe = sample_bilinear(dist_in, to_crop(edge + 3.0 * normal / px_per_mm) + pad)[:, 0]
    if np.mean(probe > 0) > 0.5:
        normal = -normal

    def keep(xy: NDArray[np.float64], dist: NDArray[np.float32], d_mm: float
             ) -> NDArray[np.bool_]:
        d = sample_bilinear(dist, to_crop(xy) + pad)[:, 0] / px_per_mm
        return d >= 0.6 * d_mm

    inner = edge - spacing.ring_mm * normal
    inner = inner[keep(inner, dist_in, spacing.ring_mm)]
    lo, hi = edge.min(axis=0), edge.max(axis=0)
    gx, gy = np.meshgrid(np.arange(lo[0], hi[0], spacing.grid_mm) + spacing.grid_mm / 2,
                         np.arange(lo[1], hi[1], spacing.grid_mm) + spacing.grid_mm / 2)
    grid = np.column_stack([gx.ravel(), gy.ravel()])
    grid = grid[keep(grid, dist_in, spacing.ring_mm + 0.5 * spacing.grid_mm)]
    p_in = np.concatenate([inner, grid])

    rings = []
    for k in range(spacing.band_rings):
        d_mm = spacing.ring_mm + spacing.band_gap_mm + k * spacing.band_step_mm
        ring = _resample_closed(edge + d_mm * normal, spacing.ring_step_mm) if k else \
            edge + d_mm * normal
        rings.append(ring[keep(ring, dist_out, d_mm)] if len(ring) else ring)
    p_out = np.concatenate(rings) if rings else np.zeros((0, 2))

    _, nearest = cKDTree(inner).query(p_out)
    table_out = np.full(len(p_in), -1, dtype=np.intp)
    if rings and len(rings[-1]) and len(inner):
        _, beside = cKDTree(rings[-1]).query(inner)
        table_out[:len(inner)] = len(p_out) - len(rings[-1]) + np.asarray(beside, np.intp)
    return _Geometry(_lift(p_in), _lift(p_out), to_crop(p_in), np.asarray(nearest, np.intp),
                     px_per_mm, table_out)


def _palette(colours: NDArray[np.float64], max_colours: int = 6) -> NDArray[np.float64]:
    """Main colours (K, 3) of ``colours`` (N, 3): k-means (fixed seed), K <= ``max_colours``."""
    k = int(min(max_colours, len(colours)))
    criteria = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 30, 1e-3)
    cv2.setRNGSeed(0)
    _, _, centres = cv2.kmeans(colours.astype(np.float32), k, None, criteria, 3,
                               cv2.KMEANS_PP_CENTERS)
    return np.ascontiguousarray(centres, dtype=np.float64)
