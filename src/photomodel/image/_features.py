"""Log-opponent colour features: the per-pixel colour the ``soft`` fitness compares.

A pixel's colour (B, G, R in 0..255) becomes three log-opponent channels::

    l = (ln R' + ln G' + ln B') / 3         lightness
    a = ln R' - ln G'                       red-green
    b = (ln R' + ln G') / 2 - ln B'         yellow-blue

with ``X' = X + offset`` (offset 8 grey levels keeps the logarithm of dark, noisy pixels
from swinging). A change of exposure adds a constant to ``l`` alone; a change of the light's
colour under a fixed white balance (the von Kries model) adds constants to ``a`` and ``b``.
Both become offsets that the fitness estimates per candidate pose instead of thresholds that
fail under the next lamp: this is what lets grey, black and white fabric (no hue) be matched
by lightness, where the hue code has nothing to compare.
"""

from __future__ import annotations

from functools import lru_cache

import cv2
import numba
import numpy as np
from numba import prange
from numpy.typing import NDArray

from photomodel._jit import njit

__all__ = ["LOG_OFFSET", "feature_pyramid", "linear_intensity",
           "log_opponent"]

LOG_OFFSET = 8.0
"""Grey levels added before the logarithm."""

_LUT = np.log(np.arange(256, dtype=np.float64) + LOG_OFFSET).astype(np.float32)
# Rows give (l, a, b) from (ln B, ln G, ln R), the channel order of OpenCV images.
_OPPONENT = np.array([[1 / 3, 1 / 3, 1 / 3],
                      [0.0, -1.0, 1.0],
                      [-1.0, 0.5, 0.5]], dtype=np.float32)
_LOGS_FROM_FEATURES = np.linalg.inv(_OPPONENT.astype(np.float64))


def log_opponent(image_bgr: NDArray[np.uint8], smooth_sigma_px: float = 0.0
                 ) -> NDArray[np.float32]:
    """Log-opponent features (H, W, 3) float32, channels (l, a, b), of a BGR image (H, W, 3).

    Parameters
    ----------
    image_bgr : ndarray (H, W, 3) uint8
    smooth_sigma_px : float
        Gaussian smoothing of the features against sensor noise (0 = none).
    """
    img = np.asarray(image_bgr)
    if img.ndim != 3 or img.shape[2] != 3 or img.dtype != np.uint8:
        raise ValueError(f"image_bgr: expected (H, W, 3) uint8, got {img.shape} {img.dtype}")
    feat = np.empty(img.shape, dtype=np.float32)
    if smooth_sigma_px > 0:
        _smoothed_log_opponent(np.ascontiguousarray(img), _LUT, _gaussian_taps(smooth_sigma_px),
                               numba.get_num_threads(), feat)
    else:
        _log_opponent_kernel(np.ascontiguousarray(img), _LUT, feat)
    return feat


@lru_cache(maxsize=8)
def _gaussian_taps(sigma_px: float) -> NDArray[np.float32]:
    """The taps of ``cv2.GaussianBlur``'s kernel for a float image and ``sigma_px``: size
    ``round(8 sigma + 1) | 1``, ``cv2.getGaussianKernel``'s values."""
    size = int(round(8.0 * sigma_px + 1.0)) | 1
    return cv2.getGaussianKernel(size, sigma_px, cv2.CV_32F).ravel().astype(np.float32)


@njit
def _log_opponent_kernel(img, lut, out):  # pragma: no cover - compiled
    """``out`` (H, W, 3) float32 = the rows of ``_OPPONENT`` applied to ``lut`` (256,) of
    each channel of ``img`` (H, W, 3) uint8 (B, G, R): one pass over the pixels, on one
    thread (about a nanosecond a pixel: less than waking numba's threads costs, and on a
    busy machine much less than waiting for them)."""
    for r in range(img.shape[0]):
        for c in range(img.shape[1]):
            lb = lut[img[r, c, 0]]
            lg = lut[img[r, c, 1]]
            lr = lut[img[r, c, 2]]
            for k in range(3):
                out[r, c, k] = _OPPONENT[k, 0] * lb + _OPPONENT[k, 1] * lg + _OPPONENT[k, 2] * lr


@njit(inline="always")
def _reflect101(i, n):  # pragma: no cover - compiled
    """Index ``i`` reflected into ``0 .. n - 1`` without repeating the edge (OpenCV's
    ``BORDER_REFLECT_101``, ``cv2.GaussianBlur``'s default)."""
    if n == 1:
        return 0
    while i < 0 or i >= n:
        i = -i if i < 0 else 2 * n - 2 - i
    return i


@njit(inline="always")
def _opponent_row(img, lut, y, out):  # pragma: no cover - compiled
    """Row ``y`` of ``img`` (H, W, 3) uint8 as log-opponent features into ``out`` (3 W,)."""
    for x in range(img.shape[1]):
        lb = lut[img[y, x, 0]]
        lg = lut[img[y, x, 1]]
        lr = lut[img[y, x, 2]]
        for k in range(3):
            out[3 * x + k] = _OPPONENT[k, 0] * lb + _OPPONENT[k, 1] * lg + _OPPONENT[k, 2] * lr


@njit(inline="always")
def _sum7(s0, s1, s2, s3, s4, s5, s6, step, taps, out):  # pragma: no cover - compiled
    """``out[m]`` = the seven ``taps`` times ``s_i[m + i step]``, summed in the taps' order
    (seven rows of a vertical pass with ``step`` 0, one padded row with ``step`` 3: the
    horizontal pass of three interleaved channels), for every ``m`` of ``out``."""
    w0, w1, w2, w3, w4, w5, w6 = taps[0], taps[1], taps[2], taps[3], taps[4], taps[5], taps[6]
    for m in range(out.shape[0]):
        out[m] = (((((w0 * s0[m] + w1 * s1[m + step]) + w2 * s2[m + 2 * step])
                    + w3 * s3[m + 3 * step]) + w4 * s4[m + 4 * step]) + w5 * s5[m + 5 * step]
                  ) + w6 * s6[m + 6 * step]


@njit(parallel=True)
def _smoothed_log_opponent(img, lut, taps, chunks, out):  # pragma: no cover - compiled
    """``out`` (H, W, 3) float32 = the log-opponent features of ``img`` (H, W, 3) uint8
    smoothed by the separable kernel ``taps`` (odd size) with reflected borders: what
    ``cv2.GaussianBlur`` gives from :func:`_log_opponent_kernel`'s features, to 2e-6.

    The rows in ``chunks`` bands on numba's threads, each keeping the feature rows its
    kernel spans in a ring: every output row is the same sums in the same order on any
    number of them. Without ``fastmath`` (here and in :func:`_opponent_row`): with it, the
    kernel as compiled and as loaded from numba's cache can contract the float32 sums
    differently (features 1e-7 apart), so processes that compile and processes that load it
    would disagree.

    Seven taps (the default 0.7-pixel smoothing) take each output row in one pass, the seven
    products summed in the taps' order (the same sums to the bit as a pass a tap)."""
    H = img.shape[0]
    flat = out.reshape(H, 3 * img.shape[1])
    for chunk in prange(chunks):
        _smooth_rows(img, lut, taps, np.int64(chunk) * H // chunks,
                     (np.int64(chunk) + 1) * H // chunks, flat)


@njit
def _smooth_rows(img, lut, taps, y0, y1, flat):  # pragma: no cover - compiled
    """Rows ``y0`` to ``y1`` of :func:`_smoothed_log_opponent`'s output ``flat`` (H, 3 W)."""
    H = img.shape[0]
    W = img.shape[1]
    n = taps.shape[0]
    r = n // 2
    M = 3 * W
    ring = np.empty((n, M), dtype=np.float32)     # feature row yy in ring[yy % n]
    row = np.empty(M + 6 * r, dtype=np.float32)   # a column-smoothed row, r pixels padded
    mid = row[3 * r:3 * r + M]
    for yy in range(y0 - r, y0 + r):
        _opponent_row(img, lut, _reflect101(yy, H), ring[yy % n])
    for y in range(y0, y1):
        _opponent_row(img, lut, _reflect101(y + r, H), ring[(y + r) % n])
        if n == 7:
            _sum7(ring[(y - 3) % 7], ring[(y - 2) % 7], ring[(y - 1) % 7], ring[y % 7],
                  ring[(y + 1) % 7], ring[(y + 2) % 7], ring[(y + 3) % 7], 0, taps, mid)
        else:
            for i in range(n):
                w = taps[i]
                src = ring[(y - r + i) % n]
                if i == 0:
                    for m in range(M):
                        mid[m] = w * src[m]
                else:
                    for m in range(M):
                        mid[m] += w * src[m]
        for x in range(1, r + 1):
            left = _reflect101(-x, W)
            right = _reflect101(W - 1 + x, W)
            for c in range(3):
                row[3 * (r - x) + c] = mid[3 * left + c]
                row[3 * (r + W - 1 + x) + c] = mid[3 * right + c]
        dst = flat[y]
        if n == 7:
            _sum7(row, row, row, row, row, row, row, 3, taps, dst)
            continue
        for i in range(n):
            w = taps[i]
            if i == 0:
                for m in range(M):
                    dst[m] = w * row[m]
            else:
                for m in range(M):
                    dst[m] += w * row[3 * i + m]


def linear_intensity(features: NDArray[np.floating]) -> NDArray[np.float64]:
    """The intensities ``(B', G', R') = (B, G, R) + LOG_OFFSET`` (..., 3) of log-opponent
    features (..., 3): the inverse of :func:`log_opponent` before its rounding to uint8."""
    return np.exp(np.asarray(features, dtype=np.float64) @ _LOGS_FROM_FEATURES.T)


def feature_pyramid(features: NDArray[np.float32], levels: int) -> list[NDArray[np.float32]]:
    """``levels`` Gaussian pyramid levels of a feature image, level 0 the image itself.

    Level ``k`` is ``cv2.pyrDown`` applied ``k`` times: its pixel (u, v) lies at level-0 pixel
    ``(2**k u, 2**k v)``, so a camera matrix scales by ``2**-k`` in its first two rows.
    """
    if levels < 1:
        raise ValueError(f"levels: expected >= 1, got {levels}")
    out = [np.ascontiguousarray(features, dtype=np.float32)]
    for _ in range(levels - 1):
        out.append(np.ascontiguousarray(cv2.pyrDown(out[-1])))
    return out
