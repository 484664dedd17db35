"""Colour evidence: a cheap first look that drops models whose colours the images lack.

Before any pose search, each model's colours are compared with the colours both images show,
as histograms of the log-opponent features (:mod:`photomodel.image._features`) at one
pyramid level. The model's histogram is that of its photo shrunk to the scene's pixel size at
the working distance, so its mass is the number of pixels the garment would cover. The
*evidence* of a model is the share of that mass the image holds in the same colour bins
(histogram intersection), the best over a few shifts of lightness (exposure), averaged over
the two cameras: about 1 when the garment lies unoccluded on the table, its visible fraction
when partly hidden, low when its colours are missing. It cannot tell a garment from another of
the same colours (that is the pose search's work), so it ranks and drops, it does not decide.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import cv2
import numpy as np
from numpy.typing import NDArray
from scipy.ndimage import uniform_filter

from photomodel.fitness import PreparedModel, StereoFeatures, as_prepared
from photomodel.fitness._soft import HAND_MM_PER_PX
from photomodel.image._features import log_opponent
from photomodel.model import PhotoModel

__all__ = ["ScreenConfig", "colour_evidence"]


@dataclass(frozen=True)
class ScreenConfig:
    """Settings of :func:`colour_evidence`.

    Attributes
    ----------
    level : int
        Pyramid level of the scene features compared.
    bin_l, bin_c : float
        Bin widths of lightness and of the two chroma channels (log units).
    light_shifts : int
        Lightness shifts tried, in bins, each way (exposure changes).
    """

    level: int = 2
    bin_l: float = 0.15
    bin_c: float = 0.12
    light_shifts: int = 1

    def __post_init__(self) -> None:
        if self.level < 0 or self.bin_l <= 0 or self.bin_c <= 0 or self.light_shifts < 0:
            raise ValueError(f"ScreenConfig: expected level >= 0, positive bins and "
                             f"light_shifts >= 0, got {self}")

    def edges(self) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """Bin edges of (l, a, b)."""
        el = np.arange(1.9, 5.8 + self.bin_l, self.bin_l)
        ec = np.arange(-3.8, 3.8 + self.bin_c, self.bin_c)
        return el, ec, ec


def _histogram(features: NDArray[np.float32], config: ScreenConfig,
               weights: NDArray[np.float64] | None = None) -> NDArray[np.float64]:
    h, _ = np.histogramdd(features.reshape(-1, 3).astype(np.float64), bins=config.edges(),
                          weights=weights)
    return uniform_filter(h, size=3, mode="constant")


def _model_histogram(prepared: PreparedModel, config: ScreenConfig) -> NDArray[np.float64]:
    """Histogram of the model photo's garment pixels at the scene level's pixel size, kept
    in the prepared model."""
    return prepared.kept.get(("screen histogram", config),
                             lambda: _make_histogram(prepared.model, config))


def _make_histogram(model: PhotoModel, config: ScreenConfig) -> NDArray[np.float64]:
    K = np.asarray(model.meta.get("camera_K", [[760.0, 0, 0], [0, 760.0, 0], [0, 0, 1]]))
    mm_per_px_model = float(model.meta.get("distance_mm", 400.0)) / float(
        np.sqrt(K[0, 0] * K[1, 1]))
    scale = mm_per_px_model / (HAND_MM_PER_PX * 2.0**config.level)
    h, w = model.mask.shape
    size = (max(1, round(w * scale)), max(1, round(h * scale)))
    photo = cv2.resize(model.photo_bgr, size, interpolation=cv2.INTER_AREA)
    cover = cv2.resize(model.mask.astype(np.float32), size, interpolation=cv2.INTER_AREA)
    feats = log_opponent(photo)
    return _histogram(feats, config, cover.reshape(-1).astype(np.float64))


def colour_evidence(models: Sequence[PhotoModel | PreparedModel], features: StereoFeatures,
                    config: ScreenConfig | None = None) -> NDArray[np.float64]:
    """Colour evidence of each model in a stereo pair (see the module docstring).

    Parameters
    ----------
    models : sequence of PhotoModel or PreparedModel
    features : StereoFeatures
        The stereo pair's feature pyramids (the level must exist).
    config : ScreenConfig, optional

    Returns
    -------
    ndarray (len(models),)
        Evidence in [0, 1].
    """
    c = config or ScreenConfig()
    level = min(c.level, features.levels - 1)
    if level != c.level:
        c = ScreenConfig(level, c.bin_l, c.bin_c, c.light_shifts)
    images = [_histogram(p[level], c) for p in features.pyramids]
    out = np.zeros(len(models))
    for i, model in enumerate(models):
        m = _model_histogram(as_prepared(model), c)
        total = float(m.sum())
        if total <= 0:
            continue
        per_camera = []
        for img in images:
            best = 0.0
            for s in range(-c.light_shifts, c.light_shifts + 1):
                shifted = np.roll(m, s, axis=0)
                best = max(best, float(np.minimum(shifted, img).sum()))
            per_camera.append(best / total)
        out[i] = float(np.clip(np.mean(per_camera), 0.0, 1.0))
    return out
