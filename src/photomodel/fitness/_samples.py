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

The point geometry does not depend on the blurs: it is computed once per model and spacing
(from one outline of the mask for every spacing), the colours once per blur (from one blurred
photo per camera blur for every spacing a :class:`SampleDrawer` draws).

Offset points that land on the wrong side of the edge (at concave corners, in narrow gaps)
are dropped by a distance-transform check.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field, replace
from functools import cached_property, partial

import cv2
import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree
from skimage.measure import find_contours

from photomodel.camera import PinholeCamera
from photomodel.fitness._prepared import Kept, PreparedModel, as_prepared
from photomodel.image import linear_intensity, log_opponent, sample_bilinear
from photomodel.model import PhotoModel

__all__ = ["ModelSamples", "SampleDrawer", "SampleSpacing", "model_samples"]


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
    pair. A :class:`SampleDrawer` draws several spacings for less.
    """
    prepared = as_prepared(model)
    return prepared.kept.get(("samples", spacing), partial(SampleDrawer(prepared).drawn, spacing))


def _lift(xy: NDArray[np.float64]) -> NDArray[np.float64]:
    """Model-plane points (N, 2) as (N, 3) with z = 0."""
    return np.ascontiguousarray(np.column_stack([xy, np.zeros(len(xy))]))


@dataclass(frozen=True)
class _Outline:
    """What every spacing's points derive from: the silhouette's edge and distance maps.

    Attributes
    ----------
    camera : PinholeCamera
        The model station's camera.
    distance_mm : float
        Its distance to the model plane.
    centroid : ndarray (2,)
        The model origin in the camera frame (x, y mm).
    origin : ndarray (2,)
        The crop's corner in the station image (u, v pixels).
    px_per_mm : float
        Photo pixels per mm on the garment.
    edge_mm : ndarray (K, 2)
        The silhouette's longest 0.5 iso-line (mask smoothed by one pixel, sub-pixel), in
        the model frame (x, y mm).
    dist_in, dist_out : ndarray (H + 4, W + 4) float32
        Each pixel's distance (pixels) to the nearest pixel off the garment (``dist_in``, 0
        off it) and on it (``dist_out``, 0 on it), the mask padded by ``_PAD`` pixels a side.
    """

    camera: PinholeCamera
    distance_mm: float
    centroid: NDArray[np.float64]
    origin: NDArray[np.float64]
    px_per_mm: float
    edge_mm: NDArray[np.float64]
    dist_in: NDArray[np.float32]
    dist_out: NDArray[np.float32]

    def to_crop(self, xy: NDArray[np.float64]) -> NDArray[np.float64]:
        """Photo-crop pixels (N, 2) (u, v) of model-plane points (N, 2) (x, y mm)."""
        pts = np.column_stack([xy + self.centroid, np.full(len(xy), self.distance_mm)])
        return self.camera.project(pts) - self.origin


_PAD = 2
"""Pixels of padding around the mask: room for contours at the crop's edge."""


def _outline_of(model: PhotoModel) -> _Outline:
    """:class:`_Outline` of ``model``'s mask."""
    camera, distance_mm, centroid = _model_camera(model)
    origin = np.asarray(model.crop_origin_px, dtype=np.float64)
    px_per_mm = float(np.sqrt(camera.K[0, 0] * camera.K[1, 1])) / distance_mm
    mask = np.pad(model.mask.astype(np.uint8), _PAD)
    soft = cv2.GaussianBlur(mask.astype(np.float32), (0, 0), 1.0)
    contour = max(find_contours(soft, 0.5), key=len)[:, ::-1] - float(_PAD)  # (u, v), crop
    edge_mm = camera.undistort_pixels(contour + origin) * distance_mm - centroid
    return _Outline(camera, distance_mm, centroid, origin, px_per_mm, edge_mm,
                    cv2.distanceTransform(mask, cv2.DIST_L2, cv2.DIST_MASK_PRECISE),
                    cv2.distanceTransform(1 - mask, cv2.DIST_L2, cv2.DIST_MASK_PRECISE))


class SampleDrawer:
    """Draws one model's samples at several spacings (:func:`model_samples` for each), what
    they share computed once: the mask's outline and distance maps (every spacing), the photo
    under each camera blur and its log-opponent features (every spacing of that blur), the
    blurred mask (every spacing of that blur width).

    It holds images of the photo's size (a few MB): make one for a preparation
    (:func:`~photomodel.locate.prepare_model` does) and drop it after; the samples it draws
    are kept in the PreparedModel. One thread at a time.

    Parameters
    ----------
    model : PhotoModel or PreparedModel
        Where the samples are kept (a bare PhotoModel keeps them in a PreparedModel of its
        own, :attr:`prepared`).
    """

    def __init__(self, model: PhotoModel | PreparedModel) -> None:
        self.prepared = as_prepared(model)
        self._weights: dict[float, NDArray[np.float32]] = {}
        self._features: tuple[float, NDArray[np.float32]] | None = None

    def draw(self, spacings: Iterable[SampleSpacing]) -> None:
        """Draw and keep the samples at each of ``spacings`` not drawn before."""
        kept = self.prepared.kept
        todo = [s for s in dict.fromkeys(spacings) if ("samples", s) not in kept]
        for spacing in sorted(todo, key=lambda s: s.optics_blur_mm):   # a camera blur at a time
            kept.get(("samples", spacing), partial(self.drawn, spacing))

    def drawn(self, spacing: SampleSpacing) -> ModelSamples:
        """The samples at ``spacing``, drawn now (their points kept per geometry, the samples
        not kept: :meth:`draw` keeps them)."""
        shape = spacing.geometry
        geometry = self.prepared.kept.get(("geometry", shape),
                                          lambda: _geometry(self._outline, shape))
        return _coloured(self, geometry, spacing)

    @cached_property
    def _outline(self) -> _Outline:
        """The mask's :class:`_Outline`."""
        return _outline_of(self.prepared.model)

    def crop_pixels(self, xy_mm: NDArray[np.float64]) -> NDArray[np.float64]:
        """Photo-crop pixels (..., 2) (u, v) of model-plane points (..., 2) (x, y mm): where
        :meth:`colours` and the model's mask show them."""
        xy = np.asarray(xy_mm, dtype=np.float64)
        return self._outline.to_crop(xy.reshape(-1, 2)).reshape(xy.shape)

    @property
    def px_per_mm(self) -> float:
        """Photo pixels per mm on the garment."""
        return self._outline.px_per_mm

    @cached_property
    def _mask(self) -> NDArray[np.float32]:
        """The garment's mask (H, W) as 0 / 1 float32."""
        return self.prepared.model.mask.astype(np.float32)

    @cached_property
    def _mask3(self) -> NDArray[np.float32]:
        """The mask repeated for three channels (H, W, 3): products and quotients with images
        of three channels then run without broadcasting (several times faster, the same
        values)."""
        return _three(self._mask)

    @cached_property
    def _masked_photo(self) -> NDArray[np.float32]:
        """The photo (H, W, 3) float32 (B, G, R) times the mask."""
        return self.prepared.model.photo_bgr.astype(np.float32) * self._mask3

    def colours(self, optics_sigma_px: float, sigma_px: float) -> NDArray[np.float32]:
        """Log-opponent features (H, W, 3) of the photo blurred over the garment only: by
        ``optics_sigma_px`` in grey levels (0: none), rounded to grey levels, then by
        ``sigma_px`` in the features. The last camera blur's features are kept for the next
        call."""
        if self._features is None or self._features[0] != optics_sigma_px:
            photo = self.prepared.model.photo_bgr
            if optics_sigma_px > 0:
                blurred = self._garment_blur(self._masked_photo, optics_sigma_px)
                photo = np.clip(np.rint(blurred, out=blurred), 0, 255, out=blurred
                                ).astype(np.uint8)
            features = log_opponent(photo)
            self._features = (optics_sigma_px, np.multiply(features, self._mask3, out=features))
        return self._garment_blur(self._features[1], sigma_px)

    def _garment_blur(self, masked: NDArray[np.float32], sigma_px: float
                      ) -> NDArray[np.float32]:
        """Gaussian blur (H, W, 3) over the garment only of an image ``masked`` (H, W, 3)
        already multiplied by the mask: normalised convolution, the model station's backdrop
        must not bleed into the garment's colours (it is not what lies around the garment in
        the scene). The mask's blur is kept per ``sigma_px``."""
        if sigma_px not in self._weights:
            weight = cv2.GaussianBlur(self._mask, (0, 0), sigma_px)
            self._weights[sigma_px] = _three(np.maximum(weight, 1e-3, out=weight))
        blurred = cv2.GaussianBlur(masked, (0, 0), sigma_px)
        return np.divide(blurred, self._weights[sigma_px], out=blurred)


def _three(image: NDArray[np.float32]) -> NDArray[np.float32]:
    """``image`` (H, W) repeated for three channels (H, W, 3)."""
    return cv2.merge([image, image, image])


def _coloured(drawer: SampleDrawer, geometry: _Geometry, spacing: SampleSpacing
              ) -> ModelSamples:
    """The samples of ``geometry`` with the photo's colours under ``spacing``'s blurs."""
    optics_px = spacing.optics_blur_mm * geometry.px_per_mm if spacing.optics_blur_mm > 0 \
        else 0.0
    colours = drawer.colours(optics_px, max(spacing.blur_mm * geometry.px_per_mm, 0.3))
    f_in = np.ascontiguousarray(sample_bilinear(colours, geometry.uv_in), dtype=np.float64)
    return ModelSamples(geometry.p_in, f_in, geometry.p_out,
                        np.ascontiguousarray(f_in[geometry.nearest_in]), geometry.table_out)


def _geometry(outline: _Outline, spacing: SampleSpacing) -> _Geometry:
    """The sample points of ``spacing`` around and inside ``outline``."""
    px_per_mm = outline.px_per_mm
    pad = np.array([float(_PAD), float(_PAD)])
    edge = _resample_closed(outline.edge_mm, spacing.ring_step_mm)
    tangent = np.roll(edge, -1, axis=0) - np.roll(edge, 1, axis=0)
    normal = np.column_stack([tangent[:, 1], -tangent[:, 0]])
    normal /= np.linalg.norm(normal, axis=1, keepdims=True) + 1e-12
    # Orient normals outwards: a step along them must leave the mask.
    dist_in, dist_out = outline.dist_in, outline.dist_out
    probe = sample_bilinear(dist_in, outline.to_crop(edge + 3.0 * normal / px_per_mm) + pad)
    if np.mean(probe[:, 0] > 0) > 0.5:
        normal = -normal

    def keep(xy: NDArray[np.float64], dist: NDArray[np.float32], d_mm: float
             ) -> NDArray[np.bool_]:
        d = sample_bilinear(dist, outline.to_crop(xy) + pad)[:, 0] / px_per_mm
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
    return _Geometry(_lift(p_in), _lift(p_out), outline.to_crop(p_in),
                     np.asarray(nearest, np.intp), px_per_mm, table_out)


def _palette(colours: NDArray[np.float64], max_colours: int = 6) -> NDArray[np.float64]:
    """Main colours (K, 3) of ``colours`` (N, 3): k-means (fixed seed), K <= ``max_colours``."""
    k = int(min(max_colours, len(colours)))
    criteria = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 30, 1e-3)
    cv2.setRNGSeed(0)
    _, _, centres = cv2.kmeans(colours.astype(np.float32), k, None, criteria, 3,
                               cv2.KMEANS_PP_CENTERS)
    return np.ascontiguousarray(centres, dtype=np.float64)
