"""Hue codes: the per-pixel and per-point colour the fitness compares.

A *hue code* is the hue in degrees [0, 360) where the colour has a hue, and -1 where it has
none: saturation below ``min_saturation`` or value below ``min_value`` (grey, white and black
have no defined hue; OpenCV would report noise there). Two codes *match* when both are -1, or
when both are hues within ``hue_threshold_deg`` of each other on the hue circle and, with
``relative_saturation > 0``, the pixel's saturation is at least that fraction of the model
point's. The last condition puts the edge of a garment on a grey table where the blur has
mixed the two half and half, instead of where a trace of the garment's colour remains (which
makes every garment look about a pixel larger and biases the depth).
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
from numpy.typing import NDArray

from photomodel.image import bgr_to_hsv, hue_distance_deg

__all__ = ["HueMatch", "hue_codes", "hue_code_image", "hue_codes_match"]


@dataclass(frozen=True)
class HueMatch:
    """When an image pixel's colour matches a model point's colour.

    Attributes
    ----------
    hue_threshold_deg : float
        Largest hue difference that still matches. 20 deg: the hue of a fabric seen by two
        cameras under the same light drifts by a few degrees (white balance, noise, blur at
        colour edges), while distinct dye colours in prints are 30 deg or more apart.
    min_saturation, min_value : float
        Below either, a colour has no hue (code -1).
    smooth_sigma_px : float
        Gaussian smoothing of the scene images before conversion, against sensor noise.
    relative_saturation : float
        A pixel matches a chromatic model point only if its saturation is at least this
        fraction of the point's (0 = hue alone, as in the paper).
    """

    hue_threshold_deg: float = 20.0
    min_saturation: float = 0.18
    min_value: float = 0.12
    smooth_sigma_px: float = 0.7
    relative_saturation: float = 0.0

    def __post_init__(self) -> None:
        if not 0 < self.hue_threshold_deg <= 180:
            raise ValueError(f"hue_threshold_deg: expected (0, 180], got {self.hue_threshold_deg}")


def hue_codes(hsv: NDArray[np.floating], match: HueMatch) -> NDArray[np.float32]:
    """Hue codes (...) of HSV colours (..., 3): hue in degrees, or -1 where there is no hue."""
    h = np.asarray(hsv, dtype=np.float32)
    chromatic = (h[..., 1] >= match.min_saturation) & (h[..., 2] >= match.min_value)
    return np.where(chromatic, h[..., 0], np.float32(-1.0)).astype(np.float32)


def hue_code_image(image_bgr: NDArray[np.uint8], match: HueMatch
                   ) -> tuple[NDArray[np.float32], NDArray[np.float32]]:
    """Hue-code image and saturation image, both (H, W), of a BGR image after smoothing."""
    img = image_bgr
    if match.smooth_sigma_px > 0:
        img = cv2.GaussianBlur(img, (0, 0), match.smooth_sigma_px)
    hsv = bgr_to_hsv(img)
    return (np.ascontiguousarray(hue_codes(hsv, match)),
            np.ascontiguousarray(hsv[..., 1], dtype=np.float32))


def hue_codes_match(a: NDArray[np.floating], b: NDArray[np.floating],
                    threshold_deg: float, sat_a: NDArray[np.floating] | None = None,
                    min_sat_a: NDArray[np.floating] | None = None) -> NDArray[np.bool_]:
    """Element-wise match of hue codes ``a`` (pixels) and ``b`` (model points).

    With ``sat_a`` and ``min_sat_a``, a chromatic match also needs ``sat_a >= min_sat_a``.
    """
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    both_grey = (a < 0) & (b < 0)
    both_hue = (a >= 0) & (b >= 0) & (hue_distance_deg(a, b) <= threshold_deg)
    if sat_a is not None and min_sat_a is not None:
        both_hue &= np.asarray(sat_a) >= np.asarray(min_sat_a)
    return both_grey | both_hue
