"""How far a calibration is from another (a fitted one from the truth, say), in the figures
a user checks: focal lengths (relative), principal points (px), the distortion's bend over the
image (px), the stereo baseline (mm) and rotation (deg), a transform's translation (mm) and
rotation (deg)."""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.spatial.transform import Rotation

from photomodel.camera import PinholeCamera, StereoRig

__all__ = ["camera_difference", "distortion_difference_px", "stereo_difference",
           "transform_difference"]


def distortion_difference_px(est: PinholeCamera, true: PinholeCamera, inset: float = 0.0,
                             grid: tuple[int, int] = (25, 19)) -> float:
    """How far ``est``'s distortion bends the image from ``true``'s, px.

    A grid of pixels over the image (less ``inset``, a fraction of each side) is undistorted
    by both models; the largest difference left once a homography (what the intrinsics and a
    turn of the camera change) maps the true rays onto the fitted ones, in ``est``'s pixels.
    """
    import cv2

    w, h = true.image_size
    uu, vv = np.meshgrid(np.linspace(inset * w, (1 - inset) * w - 1, grid[0]),
                         np.linspace(inset * h, (1 - inset) * h - 1, grid[1]))
    uv = np.stack([uu.ravel(), vv.ravel()], axis=-1)
    xy_true, xy_est = true.undistort_pixels(uv), est.undistort_pixels(uv)
    H, _ = cv2.findHomography(xy_true, xy_est, 0)
    mapped = cv2.perspectiveTransform(xy_true.reshape(-1, 1, 2), H).reshape(-1, 2)
    return float(np.abs(mapped - xy_est).max() * est.K[0, 0])


def camera_difference(est: PinholeCamera, true: PinholeCamera) -> dict[str, Any]:
    """``{"focal_rel": [fx, fy] (est / true - 1), "principal_point_px": [du, dv],
    "distortion_px": whole image, "distortion_px_inset5": 5 % in from each side}``."""
    return {
        "focal_rel": (np.diag(est.K)[:2] / np.diag(true.K)[:2] - 1.0).tolist(),
        "principal_point_px": (est.K[:2, 2] - true.K[:2, 2]).tolist(),
        "distortion_px": distortion_difference_px(est, true, 0.0),
        "distortion_px_inset5": distortion_difference_px(est, true, 0.05),
    }


def transform_difference(est: NDArray[np.float64], true: NDArray[np.float64]
                         ) -> dict[str, float]:
    """``{"translation_mm": |t_est - t_true|, "rotation_deg": angle of R_est R_true^T}`` of
    two 4 x 4 transforms (mm)."""
    return {"translation_mm": float(np.linalg.norm(est[:3, 3] - true[:3, 3])),
            "rotation_deg": float(np.degrees(Rotation.from_matrix(
                est[:3, :3] @ true[:3, :3].T).magnitude()))}


def stereo_difference(est: StereoRig, true: StereoRig) -> dict[str, Any]:
    """Both cameras' :func:`camera_difference`, and ``"baseline_mm"`` (|T_est| - |T_true|),
    ``"translation_mm"`` and ``"rotation_deg"`` (of camera 2 from camera 1)."""
    return {"cam1": camera_difference(est.cam1, true.cam1),
            "cam2": camera_difference(est.cam2, true.cam2),
            "baseline_mm": float(np.linalg.norm(est.T) - np.linalg.norm(true.T)),
            **transform_difference(est.T_cam2_cam1, true.T_cam2_cam1)}
