"""Bilinear samples of an image at arbitrary pixel positions."""

from __future__ import annotations

import cv2
import numpy as np
from numpy.typing import NDArray

_ROW = 4096  # cv2.remap takes no map side over 32767: the points go in rows of this many


def sample_bilinear(image: NDArray, uv: NDArray[np.float64]) -> NDArray:
    """Bilinear samples of ``image`` (H, W[, C]) at pixels ``uv`` (N, 2) = (u, v), as (N, C)
    of the image's dtype; positions outside the image take the nearest border pixel."""
    uv = np.asarray(uv, dtype=np.float64).reshape(-1, 2)
    n = len(uv)
    cols = min(max(n, 1), _ROW)
    rows = max(-(-n // cols), 1)
    maps = np.zeros((rows * cols, 2), dtype=np.float32)
    maps[:n] = uv
    out = cv2.remap(image, maps[:, 0].reshape(rows, cols), maps[:, 1].reshape(rows, cols),
                    cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
    channels = image.shape[2] if image.ndim == 3 else 1
    return out.reshape(rows * cols, channels)[:n]
