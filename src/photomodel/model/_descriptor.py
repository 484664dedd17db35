"""A photo-model's compact descriptor: what identification compares before any pose search.

A catalogue of thousands of garments cannot be pose-searched model by model; the descriptor
lets :mod:`photomodel.identify` rank the whole catalogue against the garments a stereo pair
shows in milliseconds. It holds:

- the silhouette's size: area (mm^2), bounding box (mm) and principal second moments (mm^2);
- the garment's colours: a sparse, normalised histogram of its log-opponent colours
  (:func:`~photomodel.image.log_opponent`) on the fixed grid :data:`COLOUR_GRID_SHAPE`
  (bins of :data:`COLOUR_BIN` log units). The photo is area-resampled to the hand cameras'
  pixel size at the working distance and taken through the same feature chain as a scene
  (smoothed features, a Gaussian pyramid) to :data:`DESCRIPTOR_LEVEL`, so that a print is
  blurred as the scene's screening sees it; each pixel is weighted by its garment cover and
  shared between the 8 nearest bins (trilinear), the :data:`MAX_COLOUR_BINS` heaviest bins
  kept;
- the mean colour (l, a, b), for the light offset between the station and the scene.

It is stored in the library's index (``descriptor``), so that a library opens and screens
without reading its model files. :data:`DESCRIPTOR_VERSION` changes when its meaning does; a
library re-describes entries of another version.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import cv2
import numpy as np
from numpy.typing import NDArray

from photomodel.image import feature_pyramid, log_opponent
from photomodel.model._config import DEFAULT_STATION_DISTANCE_MM
from photomodel.model._photomodel import PhotoModel

__all__ = [
    "COLOUR_BIN",
    "COLOUR_GRID_LOW",
    "COLOUR_GRID_SHAPE",
    "DESCRIPTOR_LEVEL",
    "DESCRIPTOR_VERSION",
    "HAND_MM_PER_PX",
    "MAX_COLOUR_BINS",
    "ModelDescriptor",
    "colour_grid_coords",
    "describe_model",
    "model_mm_per_px",
    "soft_colour_histogram",
]

DESCRIPTOR_VERSION = 1
COLOUR_BIN = 0.2
"""Width of a colour bin in each log-opponent channel (log units)."""
COLOUR_GRID_LOW = np.array([2.0, -3.6, -3.6])
"""Lower edge of the grid in (l, a, b): ``l`` spans ln 8 .. ln 263, ``a`` and ``b`` +-3.6."""
COLOUR_GRID_SHAPE = (18, 36, 36)
HAND_MM_PER_PX = 0.86
"""Millimetres of a hand-camera pixel on the table at the working distance (685 mm, 800 px)."""
DESCRIPTOR_LEVEL = 2
"""Pyramid level of the colours (about 3.4 mm a pixel), the scene screening's level."""
SCENE_SMOOTH_SIGMA_PX = 0.7
"""Smoothing of the level-0 features, as :class:`~photomodel.fitness.SoftMatch`'s default."""
MAX_COLOUR_BINS = 64
_N_BINS = int(np.prod(COLOUR_GRID_SHAPE))
_NUMBER_LISTS = {"size_mm": False, "moments_mm2": False, "mean_lab": False,
                 "colour_bins": True, "colour_weights": False}
"""The list fields of a stored descriptor, and whether they hold whole numbers."""


def _is_number(value: Any, whole: bool = False) -> bool:
    """Whether ``value`` is a JSON number (not a boolean, nor a text of digits); an integer
    when ``whole``."""
    if isinstance(value, bool):
        return False
    return isinstance(value, int) if whole else isinstance(value, int | float)


@dataclass(frozen=True)
class ModelDescriptor:
    """What :func:`describe_model` measures of a photo-model (see the module docstring).

    Attributes
    ----------
    area_mm2 : float
        Silhouette area.
    size_mm : (float, float)
        Width and height of the silhouette's bounding box.
    moments_mm2 : (float, float)
        Principal second moments of the silhouette about its centroid, largest first (the
        variances along its two axes, mm^2).
    mean_lab : (float, float, float)
        Mean log-opponent colour of the garment.
    colour_bins : ndarray (K,) int32
        Flat indices into :data:`COLOUR_GRID_SHAPE`, heaviest first, K <= MAX_COLOUR_BINS.
    colour_weights : ndarray (K,) float32
        Their shares of the garment, summing to 1.
    version : int
    """

    area_mm2: float
    size_mm: tuple[float, float]
    moments_mm2: tuple[float, float]
    mean_lab: tuple[float, float, float]
    colour_bins: NDArray[np.int32]
    colour_weights: NDArray[np.float32]
    version: int = DESCRIPTOR_VERSION

    def to_json_dict(self) -> dict[str, Any]:
        """The descriptor as stored in a library index (plain JSON types, rounded; a
        positive value stays positive)."""
        return {"version": self.version, "area_mm2": _rounded(self.area_mm2, 2),
                "size_mm": [_rounded(v, 2) for v in self.size_mm],
                "moments_mm2": [_rounded(v, 2) for v in self.moments_mm2],
                "mean_lab": [_rounded(v, 4) for v in self.mean_lab],
                "colour_bins": [int(b) for b in self.colour_bins],
                "colour_weights": [_rounded(w, 5) for w in self.colour_weights]}

    @classmethod
    def from_json_dict(cls, d: Any) -> ModelDescriptor:
        """Inverse of :meth:`to_json_dict`.

        Raises
        ------
        ValueError
            Not a descriptor of this version, or one whose values are out of range.
        """
        if not isinstance(d, dict):
            raise ValueError(f"descriptor: expected an object, got {type(d).__name__}")
        version = d.get("version")
        if isinstance(version, bool) or version != DESCRIPTOR_VERSION:
            raise ValueError(f"descriptor: version {version!r}, this photomodel reads "
                             f"{DESCRIPTOR_VERSION}")
        for key, whole in _NUMBER_LISTS.items():   # a missing key is said below
            value = d.get(key)
            if key in d and not (isinstance(value, list | tuple)
                                 and all(_is_number(v, whole) for v in value)):
                raise ValueError(f"descriptor: {key}: expected a list of "
                                 f"{'whole ' if whole else ''}numbers, got {repr(value)[:40]}")
        if "area_mm2" in d and not _is_number(d["area_mm2"]):
            raise ValueError(f"descriptor: area_mm2: expected a number, got "
                             f"{repr(d['area_mm2'])[:40]}")
        try:
            area = float(d["area_mm2"])
            size = tuple(float(v) for v in d["size_mm"])
            moments = tuple(float(v) for v in d["moments_mm2"])
            mean = tuple(float(v) for v in d["mean_lab"])
            bins = np.asarray(d["colour_bins"], dtype=np.int64)
            weights = np.asarray(d["colour_weights"], dtype=np.float64)
        except (KeyError, TypeError, ValueError, OverflowError) as exc:  # 10**400 too
            raise ValueError(f"descriptor: malformed ({type(exc).__name__}: {exc})") from None
        numbers = np.array([area, *size, *moments, *mean], dtype=np.float64)
        if (len(size) != 2 or len(moments) != 2 or len(mean) != 3
                or not np.all(np.isfinite(numbers)) or area <= 0 or min(size) <= 0
                or min(moments) < 0):
            raise ValueError("descriptor: sizes must be positive and finite, with 2 sizes, "
                             "2 moments and 3 mean colours")
        if (bins.ndim != 1 or bins.shape != weights.shape or not 0 < len(bins) <= MAX_COLOUR_BINS
                or bins.min() < 0 or bins.max() >= _N_BINS or len(np.unique(bins)) < len(bins)
                or not np.all(np.isfinite(weights))
                or weights.min() < 0 or weights.max() > 1.5  # the sum cannot overflow
                or not 0.5 < weights.sum() < 1.5):
            raise ValueError(f"descriptor: expected 1 to {MAX_COLOUR_BINS} distinct colour bins "
                             f"in 0..{_N_BINS - 1} with non-negative weights summing to 1")
        return cls(area, (size[0], size[1]), (moments[0], moments[1]),
                   (mean[0], mean[1], mean[2]), bins.astype(np.int32),
                   (weights / weights.sum()).astype(np.float32))


def model_mm_per_px(model: PhotoModel) -> float:
    """Millimetres per pixel of the model photo on the garment plane (its camera's focal
    length and distance; :data:`DEFAULT_STATION_DISTANCE_MM` and 760 px when the file does
    not say)."""
    K = np.asarray(model.meta.get("camera_K", [[760.0, 0, 0], [0, 760.0, 0], [0, 0, 1]]),
                   dtype=np.float64)
    distance_mm = model.meta.get("distance_mm", DEFAULT_STATION_DISTANCE_MM)
    return float(distance_mm) / float(np.sqrt(K[0, 0] * K[1, 1]))


def _rounded(value: float, decimals: int) -> float:
    """``value`` rounded to ``decimals``, or to six significant digits where that would
    make it 0 (a positive size stays positive when read back)."""
    r = round(float(value), decimals)
    return r if r != 0.0 or value == 0 else float(f"{float(value):.6g}")


def colour_grid_coords(features: NDArray[np.floating]) -> NDArray[np.float64]:
    """Continuous grid coordinates (N, 3) of log-opponent colours (..., 3): bin ``i`` spans
    ``[i - 0.5, i + 0.5)``; clipped to the grid."""
    f = np.asarray(features, dtype=np.float64).reshape(-1, 3)
    c = (f - COLOUR_GRID_LOW) / COLOUR_BIN - 0.5
    return np.clip(c, 0.0, np.asarray(COLOUR_GRID_SHAPE, dtype=np.float64) - 1.0)


def soft_colour_histogram(features: NDArray[np.floating], weights: NDArray[np.floating]
                          ) -> NDArray[np.float64]:
    """Dense histogram (prod(COLOUR_GRID_SHAPE),) of colours (N, 3) with ``weights`` (N,),
    each shared between its 8 nearest bins (trilinear)."""
    c = colour_grid_coords(features)
    w = np.asarray(weights, dtype=np.float64).reshape(-1)
    shape = np.asarray(COLOUR_GRID_SHAPE)
    base = np.minimum(np.floor(c).astype(np.int64), shape - 2)
    frac = c - base
    out = np.zeros(_N_BINS, dtype=np.float64)
    for corner in range(8):
        step = np.array([(corner >> 2) & 1, (corner >> 1) & 1, corner & 1])
        share = w * np.prod(np.where(step, frac, 1.0 - frac), axis=1)
        flat = np.ravel_multi_index(tuple((base + step).T), COLOUR_GRID_SHAPE)
        out += np.bincount(flat, weights=share, minlength=_N_BINS)
    return out


def describe_model(model: PhotoModel) -> ModelDescriptor:
    """The descriptor of ``model`` (see the module docstring).

    Parameters
    ----------
    model : PhotoModel

    Returns
    -------
    ModelDescriptor
    """
    mm = model_mm_per_px(model)
    mask = model.mask.astype(bool)
    rows, cols = np.nonzero(mask)
    xy = np.stack([cols, rows], axis=1).astype(np.float64) * mm
    cov = np.cov(xy.T) if len(xy) > 2 else np.zeros((2, 2))
    moments = np.sort(np.linalg.eigvalsh(cov))[::-1]
    scale = mm / HAND_MM_PER_PX
    h, w = mask.shape
    size = (max(1, round(w * scale)), max(1, round(h * scale)))
    interpolation = cv2.INTER_AREA if scale < 1 else cv2.INTER_LINEAR
    photo = cv2.resize(model.photo_bgr, size, interpolation=interpolation)
    cover = cv2.resize(mask.astype(np.float32), size, interpolation=interpolation)
    levels = DESCRIPTOR_LEVEL + 1
    features = feature_pyramid(log_opponent(photo, SCENE_SMOOTH_SIGMA_PX),
                               levels)[-1].reshape(-1, 3)
    cover = feature_pyramid(cover[..., None].repeat(3, axis=2), levels)[-1][..., 0].reshape(-1)
    keep = cover > 0.05
    hist = soft_colour_histogram(features[keep], cover[keep])
    order = np.argsort(-hist, kind="stable")[:MAX_COLOUR_BINS]
    order = order[hist[order] > 0]
    weights = hist[order] / hist[order].sum()
    mean = (features[keep] * cover[keep, None]).sum(axis=0) / cover[keep].sum()
    return ModelDescriptor(
        area_mm2=float(model.area_mm2), size_mm=(float(model.size_mm[0]),
                                                 float(model.size_mm[1])),
        moments_mm2=(float(moments[0]), float(moments[1])),
        mean_lab=(float(mean[0]), float(mean[1]), float(mean[2])),
        colour_bins=order.astype(np.int32), colour_weights=weights.astype(np.float32))
