"""Numpy transcriptions shared by the fitness tests' references."""

from __future__ import annotations

import numpy as np


def bilinear_samples(img: np.ndarray, uv: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Bilinear samples (N, C) of ``img`` (H, W, C) at pixels ``uv`` (N, 2), and whether each
    lies inside the image (the kernels' rule: ``0 <= u <= W - 1``, ``0 <= v <= H - 1``; the
    samples outside are of no use)."""
    h, w = img.shape[:2]
    u, v = uv[:, 0], uv[:, 1]
    ok = (u >= 0) & (v >= 0) & (u <= w - 1) & (v <= h - 1)
    iu = np.minimum(np.floor(np.where(ok, u, 0)).astype(int), w - 2)
    iv = np.minimum(np.floor(np.where(ok, v, 0)).astype(int), h - 2)
    fu, fv = (np.where(ok, u, 0) - iu)[:, None], (np.where(ok, v, 0) - iv)[:, None]
    top = img[iv, iu] * (1 - fu) + img[iv, iu + 1] * fu
    bottom = img[iv + 1, iu] * (1 - fu) + img[iv + 1, iu + 1] * fu
    return top * (1 - fv) + bottom * fv, ok
