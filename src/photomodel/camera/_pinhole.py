"""Pinhole camera with OpenCV's distortion model (eq. 4 of the paper plus lens distortion).

Conventions: camera frame x right, y down, z forward (OpenCV); pixel (u, v) = (column, row)
with the origin at the centre of the top-left pixel; distortion coefficients in OpenCV order
(k1, k2, p1, p2[, k3[, k4, k5, k6[, s1, s2, s3, s4]]]) and honoured everywhere.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import cv2
import numpy as np
from numpy.typing import ArrayLike, NDArray

from photomodel._limits import (
    FOCAL_PX_RANGE,
    MAX_DISTORTION_COEFF,
    MAX_FOCAL_PER_SIDE,
    MAX_IMAGE_PIXELS,
    MAX_PRINCIPAL_POINT_PX,
)

_N_DIST = 12  # rational model + thin prism; (tilted model tau_x, tau_y is not supported)


def _padded_distortion(dist: NDArray[np.float64]) -> NDArray[np.float64]:
    d = np.zeros(_N_DIST)
    d[: dist.size] = dist
    return d


@dataclass(frozen=True)
class PinholeCamera:
    """One calibrated camera.

    Parameters
    ----------
    K : ndarray (3, 3)
        Intrinsic matrix [[fx, s, cx], [0, fy, cy], [0, 0, 1]] in pixels; the focal lengths
        within :data:`~photomodel._limits.FOCAL_PX_RANGE`, |s| at most fx, the principal
        point within :data:`~photomodel._limits.MAX_PRINCIPAL_POINT_PX`; with the image size
        given, the focal lengths at most :data:`~photomodel._limits.MAX_FOCAL_PER_SIDE` times
        its larger side.
    dist : ndarray (n,)
        OpenCV distortion coefficients, n in {0, 4, 5, 8, 12}, finite, each at most
        :data:`~photomodel._limits.MAX_DISTORTION_COEFF` in size.
    width_px, height_px : int
        Image size; 0 when the calibration does not say.

    Raises
    ------
    ValueError
        A value outside those bounds (the message starts with the parameter's name).
    """

    K: NDArray[np.float64]
    dist: NDArray[np.float64] = field(default_factory=lambda: np.zeros(5))
    width_px: int = 0
    height_px: int = 0

    def __post_init__(self) -> None:
        K = np.asarray(self.K, dtype=np.float64)
        if K.shape != (3, 3):
            raise ValueError(f"K: expected shape (3, 3), got {K.shape}")
        if not np.isfinite(K).all() or K[0, 0] <= 0 or K[1, 1] <= 0:
            raise ValueError("K: focal lengths must be finite and positive")
        if K[1, 0] != 0 or not np.array_equal(K[2], [0.0, 0.0, 1.0]):
            raise ValueError("K: expected [[fx, s, cx], [0, fy, cy], [0, 0, 1]]")
        lo, hi = FOCAL_PX_RANGE
        if not (lo <= K[0, 0] <= hi and lo <= K[1, 1] <= hi):
            raise ValueError(f"K: focal lengths ({K[0, 0]:g}, {K[1, 1]:g}) px are outside "
                             f"{lo:g}-{hi:g} px")
        if abs(K[0, 1]) > K[0, 0]:
            raise ValueError(f"K: skew {K[0, 1]:g} is larger than the focal length")
        if max(abs(K[0, 2]), abs(K[1, 2])) > MAX_PRINCIPAL_POINT_PX:
            raise ValueError(f"K: principal point ({K[0, 2]:g}, {K[1, 2]:g}) px is beyond "
                             f"{MAX_PRINCIPAL_POINT_PX:g} px")
        d = np.asarray(self.dist, dtype=np.float64).ravel()
        if d.size not in (0, 4, 5, 8, 12, 14):
            raise ValueError(f"dist: expected 0, 4, 5, 8, 12 or 14 coefficients, got {d.size}")
        if d.size == 14 and np.any(d[12:] != 0):
            raise ValueError("dist: the tilted-sensor terms (tau_x, tau_y) are not supported")
        if not np.isfinite(d).all() or np.abs(d).max(initial=0.0) > MAX_DISTORTION_COEFF:
            raise ValueError(f"dist: coefficients must be finite and at most "
                             f"{MAX_DISTORTION_COEFF:g} in size")
        width, height = int(self.width_px), int(self.height_px)
        if width < 0 or height < 0 or width * height > MAX_IMAGE_PIXELS:
            raise ValueError(f"width_px, height_px: expected a size of at most "
                             f"{MAX_IMAGE_PIXELS / 1e6:.0f} megapixels (0 for unknown), "
                             f"got {width}x{height}")
        if width and height and max(K[0, 0], K[1, 1]) > MAX_FOCAL_PER_SIDE * max(width, height):
            raise ValueError(f"K: focal length {max(K[0, 0], K[1, 1]):g} px is more than "
                             f"{MAX_FOCAL_PER_SIDE:g} x the {width}x{height} image's larger side "
                             f"(a field of view under "
                             f"{np.degrees(2 * np.arctan(0.5 / MAX_FOCAL_PER_SIDE)):.1f} deg)")
        object.__setattr__(self, "K", K)
        object.__setattr__(self, "dist", d[:12] if d.size == 14 else d)
        object.__setattr__(self, "width_px", width)
        object.__setattr__(self, "height_px", height)

    @property
    def has_distortion(self) -> bool:
        """True when any distortion coefficient is non-zero."""
        return bool(np.any(self.dist != 0))

    @property
    def image_size(self) -> tuple[int, int]:
        """(width_px, height_px)."""
        return self.width_px, self.height_px

    @property
    def distortion12(self) -> NDArray[np.float64]:
        """The coefficients padded to 12: (k1, k2, p1, p2, k3, k4, k5, k6, s1, s2, s3, s4)."""
        return _padded_distortion(self.dist)

    def distort_normalized(self, xy: ArrayLike) -> NDArray[np.float64]:
        """Apply the distortion model to normalised coordinates (..., 2) = (X/Z, Y/Z)."""
        p = np.asarray(xy, dtype=np.float64)
        k1, k2, p1, p2, k3, k4, k5, k6, s1, s2, s3, s4 = self.distortion12
        x, y = p[..., 0], p[..., 1]
        r2 = x * x + y * y
        radial = (1 + r2 * (k1 + r2 * (k2 + r2 * k3))) / (1 + r2 * (k4 + r2 * (k5 + r2 * k6)))
        xd = x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x) + s1 * r2 + s2 * r2 * r2
        yd = y * radial + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y + s3 * r2 + s4 * r2 * r2
        return np.stack([xd, yd], axis=-1)

    def project(self, points_cam: ArrayLike) -> NDArray[np.float64]:
        """Project points (..., 3) in the camera frame (mm) to pixels (..., 2) = (u, v).

        Points at or behind the camera (Z <= 0) give NaN.
        """
        p = np.asarray(points_cam, dtype=np.float64)
        z = p[..., 2]
        with np.errstate(divide="ignore", invalid="ignore"):
            z_safe = np.where(z > 0, z, np.nan)
            xy = p[..., :2] / z_safe[..., None]
        xd = self.distort_normalized(xy)
        K = self.K
        u = K[0, 0] * xd[..., 0] + K[0, 1] * xd[..., 1] + K[0, 2]
        v = K[1, 1] * xd[..., 1] + K[1, 2]
        return np.stack([u, v], axis=-1)

    def undistort_pixels(self, uv: ArrayLike) -> NDArray[np.float64]:
        """Normalised coordinates (N, 2) = (X/Z, Y/Z) of pixels (N, 2), inverting the distortion.

        ``cv2.undistortPoints`` gives the starting point; Newton steps on this class's own
        distortion model then make the inverse exact to ~1e-12 (OpenCV's fixed-point iteration
        alone leaves errors of 0.01-0.1 px for strong lenses, and its criteria argument differs
        between OpenCV 4 and 5).
        """
        pts = np.asarray(uv, dtype=np.float64).reshape(-1, 2)
        Kinv = np.linalg.inv(self.K)
        target = pts @ Kinv[:2, :2].T + Kinv[:2, 2]  # skew included (OpenCV ignores it)
        if not self.has_distortion:
            return target
        xy = cv2.undistortPoints(pts.reshape(-1, 1, 2), self.K, self.dist).reshape(-1, 2)
        h = 1e-7
        for _ in range(20):
            f = self.distort_normalized(xy) - target
            if np.nanmax(np.abs(f), initial=0.0) < 1e-13:
                break
            jx = (self.distort_normalized(xy + [h, 0.0]) - self.distort_normalized(xy)) / h
            jy = (self.distort_normalized(xy + [0.0, h]) - self.distort_normalized(xy)) / h
            det = jx[:, 0] * jy[:, 1] - jy[:, 0] * jx[:, 1]
            dx = (jy[:, 1] * f[:, 0] - jy[:, 0] * f[:, 1]) / det
            dy = (-jx[:, 1] * f[:, 0] + jx[:, 0] * f[:, 1]) / det
            xy = xy - np.stack([dx, dy], axis=-1)
        return xy

    def check_image(self, image: NDArray, source: str = "image") -> None:
        """Raise ``InputError`` when an image's size differs from the calibrated size, or (size
        not calibrated) the focal length is more than ``MAX_FOCAL_PER_SIDE`` x its larger side."""
        from photomodel.errors import InputError

        h, w = image.shape[:2]
        focal_px = max(self.K[0, 0], self.K[1, 1])
        if not (self.width_px and self.height_px) and focal_px > MAX_FOCAL_PER_SIDE * max(w, h):
            # checked at load time when the calibration gives its size; a search's grids
            # grow with f^2, so a wrong focal length must not reach them
            raise InputError(source, f"the calibration's focal length {focal_px:g} px is more "
                                     f"than {MAX_FOCAL_PER_SIDE:g} x this {w}x{h} image's "
                                     "larger side: a calibration for another camera or in "
                                     "other units?")
        if self.width_px and self.height_px:
            if (w, h) != (self.width_px, self.height_px):
                raise InputError(
                    source,
                    f"image is {w}x{h} px but the calibration is for "
                    f"{self.width_px}x{self.height_px} px",
                )
