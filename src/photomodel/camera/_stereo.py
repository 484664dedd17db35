"""The hand's stereo rig: camera 1 (reference, the paper's right camera) and camera 2."""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from photomodel._limits import MAX_BASELINE_MM
from photomodel.camera._pinhole import PinholeCamera
from photomodel.geometry import make_transform

_ROTATION_ATOL = 1e-5  # R R^T = I and det R = 1 to this (a file's R has 6-17 digits)


@dataclass(frozen=True)
class StereoRig:
    """Two calibrated cameras; ``R``, ``T`` map camera-1 to camera-2 coordinates.

    ``X2 = R @ X1 + T`` (as ``cv2.stereoCalibrate`` returns), ``T`` in mm, so
    ``T_cam2_cam1 = [[R, T], [0, 1]]``.

    Raises
    ------
    ValueError
        ``R`` is not a rotation (orthonormal, det +1, to 1e-5), ``T`` is not finite or longer
        than :data:`~photomodel._limits.MAX_BASELINE_MM`.
    """

    cam1: PinholeCamera
    cam2: PinholeCamera
    R: NDArray[np.float64]
    T: NDArray[np.float64]

    def __post_init__(self) -> None:
        R = np.asarray(self.R, dtype=np.float64).reshape(3, 3)
        T = np.asarray(self.T, dtype=np.float64).reshape(3)
        if not np.isfinite(R).all() or not np.allclose(R @ R.T, np.eye(3), atol=_ROTATION_ATOL) \
                or not abs(np.linalg.det(R) - 1.0) <= _ROTATION_ATOL:
            raise ValueError("R: expected a rotation matrix (orthonormal, det +1)")
        if not np.isfinite(T).all() or np.linalg.norm(T) > MAX_BASELINE_MM:
            raise ValueError(f"T: expected a finite translation of at most {MAX_BASELINE_MM:g} "
                             "mm")
        object.__setattr__(self, "R", R)
        object.__setattr__(self, "T", T)

    @property
    def T_cam2_cam1(self) -> NDArray[np.float64]:
        """(4, 4) transform from camera-1 to camera-2 coordinates."""
        return make_transform(self.R, self.T)

    @functools.cached_property
    def R_cam1_facing(self) -> NDArray[np.float64]:
        """(3, 3) orientation of a plane that faces the rig, in camera 1's frame (read-only;
        computed once per rig: a stereo pair's search asks for it a dozen times).

        Its z axis is the bisector of the two optical axes (away from the cameras), its x axis
        camera 1's x projected onto the plane, y = z x x. A converging rig sees a table it
        faces tilted by half the vergence angle in each camera, not square to camera 1.
        """
        bisector = np.array([0.0, 0.0, 1.0]) + self.R[2]  # R.T[:, 2]: camera 2's axis
        z = bisector / np.linalg.norm(bisector)
        x = np.array([1.0, 0.0, 0.0]) - z[0] * z
        x /= np.linalg.norm(x)
        facing = np.stack([x, np.cross(z, x), z], axis=-1)
        facing.setflags(write=False)
        return facing

    @functools.cached_property
    def calibration_key(self) -> tuple[bytes, ...]:
        """The calibration as a hashable key (both cameras' matrices and distortions, ``R``,
        ``T``; computed once per rig): the caches of work that depends on the rig key on it."""
        return tuple(np.ascontiguousarray(a).tobytes()
                     for a in (self.cam1.K, self.cam1.dist, self.cam2.K, self.cam2.dist,
                               self.R, self.T))

    @property
    def cameras(self) -> tuple[PinholeCamera, PinholeCamera]:
        """(cam1, cam2)."""
        return self.cam1, self.cam2

    def project_poses(
        self, T_cam1_model: ArrayLike, points_model: ArrayLike
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Project model points for many poses into both images at once.

        Parameters
        ----------
        T_cam1_model : ndarray (P, 4, 4) or (4, 4)
            Candidate poses of the model in camera 1's frame (mm).
        points_model : ndarray (N, 3)
            Points in the model frame (mm).

        Returns
        -------
        uv1, uv2 : ndarray (P, N, 2)
            Pixels in camera 1 and camera 2; NaN for points behind a camera.
        """
        T = np.asarray(T_cam1_model, dtype=np.float64)
        squeeze = T.ndim == 2
        T = T.reshape(-1, 4, 4)
        pts = np.asarray(points_model, dtype=np.float64).reshape(-1, 3)
        p1 = np.einsum("pij,nj->pni", T[:, :3, :3], pts) + T[:, None, :3, 3]
        p2 = p1 @ self.R.T + self.T
        uv1, uv2 = self.cam1.project(p1), self.cam2.project(p2)
        if squeeze:
            return uv1[0], uv2[0]
        return uv1, uv2
