"""Feature pyramids of two image windows around a predicted pose, at the resolution it needs.

A tracked frame does not need the whole images: the garment's predicted outline, widened by a
margin, bounds where its samples can fall in each camera. :class:`WindowFeatures` are the
feature pyramids of those windows only, optionally of the images already reduced ``2**d``
times (``level_offset``): when the hand comes close, the garment covers ``2**d`` times more
pixels, and level ``j`` of the reduced window then has level ``j``'s resolution on the
garment at the working distance, which the model's samples at level ``j`` were drawn for.
Their camera matrices are the rig's, scaled to the level and shifted to the window, so that
every fitness of :mod:`photomodel.fitness` runs on them unchanged.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
from numpy.typing import NDArray

from photomodel.camera import StereoRig
from photomodel.fitness import SoftMatch, StereoFeatures
from photomodel.image import feature_pyramid, log_opponent

__all__ = ["Window", "WindowFeatures", "window_of_points"]


@dataclass(frozen=True)
class Window:
    """A rectangle of one image, level-0 pixels: columns ``x0 .. x1 - 1``, rows ``y0 ..
    y1 - 1``."""

    x0: int
    y0: int
    x1: int
    y1: int

    @property
    def width(self) -> int:
        return self.x1 - self.x0

    @property
    def height(self) -> int:
        return self.y1 - self.y0


def window_of_points(uv: NDArray[np.float64], image_size: tuple[int, int], margin_px: float,
                     align: int, min_size: int = 32) -> Window | None:
    """The window around pixels ``uv`` (N, 2) widened by ``margin_px``, its corner on a
    multiple of ``align`` and its sides multiples of ``align``, clipped to the image
    ``(width, height)``; None when no finite pixel lies within the margin of the image."""
    w, h = image_size
    finite = uv[np.all(np.isfinite(uv), axis=1)]
    if not len(finite):
        return None
    lo = finite.min(axis=0) - margin_px
    hi = finite.max(axis=0) + margin_px
    if hi[0] < 0 or hi[1] < 0 or lo[0] >= w or lo[1] >= h:
        return None
    x0 = int(max(0, np.floor(lo[0] / align) * align))
    y0 = int(max(0, np.floor(lo[1] / align) * align))
    x1 = int(min(w, np.ceil(hi[0] / align) * align))
    y1 = int(min(h, np.ceil(hi[1] / align) * align))
    x1 = max(x1, min(w, x0 + min_size))
    y1 = max(y1, min(h, y0 + min_size))
    return Window(x0, y0, x1, y1)


def _reduced(image: NDArray[np.uint8], window: Window, level_offset: int
             ) -> NDArray[np.uint8]:
    """The window of ``image``, reduced ``2**level_offset`` times by ``cv2.pyrDown``."""
    out = np.ascontiguousarray(image[window.y0:window.y1, window.x0:window.x1])
    for _ in range(level_offset):
        out = cv2.pyrDown(out)
    return out


class WindowFeatures(StereoFeatures):
    """:class:`~photomodel.fitness.StereoFeatures` of one window of each image.

    Parameters
    ----------
    rig : StereoRig
    right_bgr, left_bgr : ndarray (H, W, 3) uint8
        The whole images of camera 1 and camera 2 (sizes checked against the calibration).
    windows : (Window, Window)
        Camera 1's and camera 2's window, level-0 pixels; their corners should lie on
        multiples of ``2**(level_offset + levels - 1)`` so that every level's pixels fall
        on the whole images' level pixels.
    levels : int
        Pyramid levels of the windows.
    level_offset : int
        The windows are reduced ``2**level_offset`` times before their features are taken:
        this object's level ``j`` is the images' level ``j + level_offset``.
    match : SoftMatch, optional
    """

    def __init__(self, rig: StereoRig, right_bgr: NDArray[np.uint8],
                 left_bgr: NDArray[np.uint8], windows: tuple[Window, Window], levels: int = 2,
                 level_offset: int = 0, match: SoftMatch | None = None) -> None:
        rig.cam1.check_image(right_bgr, "right image")
        rig.cam2.check_image(left_bgr, "left image")
        if levels < 1 or level_offset < 0:
            raise ValueError(f"expected levels >= 1 and level_offset >= 0, got {levels}, "
                             f"{level_offset}")
        match = match or SoftMatch()
        sigma = match.smooth_sigma_px
        self.windows = windows
        self.level_offset = int(level_offset)
        pyramids = tuple(
            feature_pyramid(log_opponent(_reduced(image, window, level_offset), sigma), levels)
            for image, window in zip((right_bgr, left_bgr), windows, strict=True))
        self._set(rig, match, (pyramids[0], pyramids[1]))

    def camera_matrices(self, level: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Camera matrices (3, 3) of both windows at ``level``: the rig's at the images'
        level ``level + level_offset``, their principal points moved to the window."""
        if level not in self._cameras:
            scale = 0.5 ** (level + self.level_offset)
            out = []
            for K, window in zip((self.rig.cam1.K, self.rig.cam2.K), self.windows,
                                 strict=True):
                Kw = np.diag([scale, scale, 1.0]) @ np.asarray(K, dtype=np.float64)
                Kw[0, 2] -= window.x0 * scale
                Kw[1, 2] -= window.y0 * scale
                out.append(np.ascontiguousarray(Kw))
            self._cameras[level] = (out[0], out[1])
        return self._cameras[level]
