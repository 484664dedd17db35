"""HSV in float units: hue in degrees [0, 360), saturation and value in [0, 1]."""

from __future__ import annotations

import cv2
import numpy as np
from numpy.typing import ArrayLike, NDArray


def bgr_to_hsv(image_bgr: ArrayLike) -> NDArray[np.float32]:
    """Convert 8-bit BGR (..., 3) to float HSV (..., 3): hue deg [0, 360), s and v in [0, 1].

    Uses OpenCV's float conversion, which keeps the full hue resolution (the 8-bit
    conversion quantises hue to 2 degree steps).
    """
    img = np.asarray(image_bgr)
    shape = img.shape
    flat = img.reshape(-1, 1, 3).astype(np.float32) / 255.0
    hsv = cv2.cvtColor(flat, cv2.COLOR_BGR2HSV).reshape(shape)
    hsv[..., 0] = np.mod(hsv[..., 0], 360.0)
    return hsv


def hue_distance_deg(h1: ArrayLike, h2: ArrayLike) -> NDArray[np.float64]:
    """Circular distance between hues in degrees, in [0, 180]."""
    d = np.abs(np.asarray(h1, dtype=np.float64) - np.asarray(h2, dtype=np.float64)) % 360.0
    return np.minimum(d, 360.0 - d)


def circular_mean_hue_deg(hue_deg: ArrayLike, weights: ArrayLike | None = None) -> float:
    """Mean hue in degrees [0, 360) as the angle of the (weighted) mean unit vector."""
    h = np.deg2rad(np.asarray(hue_deg, dtype=np.float64).ravel())
    w = np.ones_like(h) if weights is None else np.asarray(weights, dtype=np.float64).ravel()
    return float(np.rad2deg(np.arctan2((w * np.sin(h)).sum(), (w * np.cos(h)).sum())) % 360.0)
