"""Test helpers for the simulator's tests: a dotted calibration card and a dot detector."""

from __future__ import annotations

from functools import lru_cache

import numpy as np
from numpy.typing import NDArray

from photomodel.sim import PlaneTexture

DOT_SIGMA_MM = 1.2
DOT_SPACING_MM = 40.0


@lru_cache(maxsize=2)
def dot_card(size_mm: tuple[float, float] = (520.0, 400.0),
             mm_per_px: float = 0.5) -> tuple[PlaneTexture, NDArray[np.float64]]:
    """A white card with dark Gaussian dots on a grid, and the dots' centres (N, 2), mm.

    Each dot is centred on a texel, so its bilinear interpolant is point-symmetric about the
    centre and its intensity centroid is exactly the centre.
    """
    w, h = round(size_mm[0] / mm_per_px), round(size_mm[1] / mm_per_px)
    step, sigma = DOT_SPACING_MM / mm_per_px, DOT_SIGMA_MM / mm_per_px
    us = np.arange(step / 2, w - step / 4, step).round().astype(int)
    vs = np.arange(step / 2, h - step / 4, step).round().astype(int)
    r = int(np.ceil(5 * sigma))
    yy, xx = np.mgrid[-r:r + 1, -r:r + 1]
    dot = 235.0 * np.exp(-(xx**2 + yy**2) / (2 * sigma**2))
    grey = np.full((h, w), 255.0)
    for cv in vs:
        for cu in us:
            grey[cv - r:cv + r + 1, cu - r:cu + r + 1] -= dot
    image = np.repeat(np.rint(grey).astype(np.uint8)[..., None], 3, axis=-1)
    card = PlaneTexture(image, np.ones((h, w), np.float32), mm_per_px,
                        np.array([(w - 1) / 2, (h - 1) / 2]))
    centres_px = np.stack(np.meshgrid(us, vs), axis=-1).reshape(-1, 2)
    return card, card.mm_from_px(centres_px)


def dot_centroid(image: NDArray[np.uint8], uv: NDArray[np.float64],
                 half: int = 10) -> NDArray[np.float64] | None:
    """Intensity-weighted centroid (2,) of a dark dot on white in a window around ``uv``.

    None when the window does not fit in the image.
    """
    c, r = np.rint(uv).astype(int)
    h, w = image.shape[:2]
    if c - half < 0 or r - half < 0 or c + half >= w or r + half >= h:
        return None
    patch = image[r - half:r + half + 1, c - half:c + half + 1].astype(np.float64).mean(axis=2)
    weight = np.clip(255.0 - patch, 0.0, None)
    vv, uu = np.mgrid[r - half:r + half + 1, c - half:c + half + 1]
    return np.array([(weight * uu).sum(), (weight * vv).sum()]) / weight.sum()
