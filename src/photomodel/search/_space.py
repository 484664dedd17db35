"""The search space of pose vectors (x, y, z, eps1, eps2, eps3) of ``T_cam1_model``."""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial.transform import Rotation

from photomodel.geometry import facing_pose_vectors

__all__ = ["GENE_NAMES", "SearchSpace"]

GENE_NAMES = ("x_mm", "y_mm", "z_mm", "eps1", "eps2", "eps3")


@dataclass(frozen=True)
class SearchSpace:
    """Box bounds (6,) on the pose vector; ``eps`` = quaternion vector part (w >= 0).

    A rotation by ``a`` about a unit axis has ``eps = sin(a / 2) * axis``, so an in-plane
    angle range of +-theta (about camera 1's z axis) is ``|eps3| <= sin(theta / 2)`` and a
    tilt range of +-tilt is ``|eps1|, |eps2| <= sin(tilt / 2)``.
    """

    lower: NDArray[np.float64]
    upper: NDArray[np.float64]

    def __post_init__(self) -> None:
        lo = np.asarray(self.lower, dtype=np.float64).reshape(6)
        hi = np.asarray(self.upper, dtype=np.float64).reshape(6)
        if not (np.isfinite(lo).all() and np.isfinite(hi).all()) or np.any(hi < lo):
            raise ValueError(f"search space: expected finite lower <= upper, got {lo}, {hi}")
        if lo[2] <= 0:
            raise ValueError(f"z_mm: the garment must be in front of camera 1, got {lo[2]}")
        if np.sum(np.maximum(np.abs(lo[3:]), np.abs(hi[3:])) ** 2) > 1:
            raise ValueError("eps bounds: the quaternion vector part must stay in the unit ball")
        object.__setattr__(self, "lower", lo)
        object.__setattr__(self, "upper", hi)

    @classmethod
    def from_ranges(
        cls,
        x_mm: tuple[float, float] = (-255.0, 255.0),
        y_mm: tuple[float, float] = (-195.0, 195.0),
        z_mm: tuple[float, float] = (500.0, 900.0),
        theta_deg: float = 53.0,
        tilt_deg: float = 10.0,
        R_cam1_plane: ArrayLike | None = None,
    ) -> SearchSpace:
        """Bounds from position ranges (mm) and symmetric in-plane / tilt angle ranges (deg).

        The defaults are the paper's experiment (docs/contracts.md, "Command line"):
        x +-255 mm, y +-195 mm, z 500-900 mm, in-plane angle +-53 deg, tilt +-10 deg.

        Parameters
        ----------
        x_mm, y_mm, z_mm : (float, float)
            Position ranges in camera 1's frame.
        theta_deg : float
            In-plane angle range +-, about camera 1's z axis.
        tilt_deg : float
            Tilt range +-, away from the plane of ``R_cam1_plane``.
        R_cam1_plane : array (3, 3), optional
            Orientation of the plane the garments lie on (the table:
            :attr:`~photomodel.camera.StereoRig.R_cam1_facing`), from which the tilt is
            measured; default camera 1's image plane (the paper's camera looked straight down
            at its table). The eps1 and eps2 bounds are then the smallest box around every
            rotation ``R_cam1_plane @ R_tilt @ Rz(theta)`` with a tilt up to ``tilt_deg``
            about any axis of the plane and ``|theta| <= theta_deg``: a converging rig's
            table lies half the vergence tilted in camera 1 (5 deg for the simulated rig), and
            a garment tilted 8 deg on it lay up to 13 deg from camera 1, beyond a box measured
            from camera 1.
        """
        for key, (lo, hi) in (("x_mm", x_mm), ("y_mm", y_mm), ("z_mm", z_mm)):
            if not (np.isfinite(lo) and np.isfinite(hi) and lo <= hi):
                raise ValueError(f"{key}: expected a range LO HI in mm with LO <= HI, got "
                                 f"{lo:g} {hi:g}")
        if not z_mm[0] > 0:
            raise ValueError(f"z_mm: expected distances in front of camera 1 (LO above 0 mm), "
                             f"got {z_mm[0]:g} {z_mm[1]:g}")
        if not 0 <= theta_deg <= 180:
            raise ValueError(f"theta_deg: expected an angle from 0 to 180 deg, got {theta_deg:g}")
        if not 0 <= tilt_deg <= 90:
            raise ValueError(f"tilt_deg: expected an angle from 0 to 90 deg, got {tilt_deg:g}")
        e3 = np.sin(np.deg2rad(theta_deg) / 2)
        e12 = np.sin(np.deg2rad(tilt_deg) / 2)
        lo12, hi12 = np.array([-e12, -e12]), np.array([e12, e12])
        if R_cam1_plane is not None:
            lo12, hi12 = _tilt_box(np.asarray(R_cam1_plane, dtype=np.float64).tobytes(),
                                   float(theta_deg), float(tilt_deg))
        if np.sum(np.maximum(np.abs(lo12), np.abs(hi12)) ** 2) + e3**2 > 1:
            raise ValueError(f"tilt_deg: a tilt of +-{tilt_deg:g} deg with an in-plane range of "
                             f"+-{theta_deg:g} deg is no box of rotations (the quaternion's "
                             "vector part leaves the unit ball); narrow one of them")
        return cls(
            np.array([x_mm[0], y_mm[0], z_mm[0], lo12[0], lo12[1], -e3]),
            np.array([x_mm[1], y_mm[1], z_mm[1], hi12[0], hi12[1], e3]),
        )

    @property
    def span(self) -> NDArray[np.float64]:
        """upper - lower (6,)."""
        return self.upper - self.lower

    def clip(self, x: ArrayLike) -> NDArray[np.float64]:
        """Clip pose vectors (..., 6) into the box (``np.clip``'s arithmetic without its
        wrapper, which cost more than the clipping on a search's small batches)."""
        return np.minimum(np.maximum(np.asarray(x, dtype=np.float64), self.lower), self.upper)

    def contains(self, x: ArrayLike) -> NDArray[np.bool_]:
        """Whether pose vectors (..., 6) lie inside the box."""
        x = np.asarray(x, dtype=np.float64)
        return np.all((x >= self.lower) & (x <= self.upper), axis=-1)


@functools.lru_cache(maxsize=8)
def _tilt_box(R_cam1_plane: bytes, theta_deg: float, tilt_deg: float
              ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Bounds (2,) and (2,) of eps1 and eps2 over the rotations ``R_cam1_plane @ R_tilt @
    Rz(theta)`` (the plane's 3 x 3 float64 bytes): tilts up to ``tilt_deg`` about any axis of
    the plane, ``|theta| <= theta_deg``, on a grid of 1 deg in theta and 5 deg in the tilt's
    axis (the extremes lie on the largest tilt; eps varies by under 1e-3 between grid points),
    widened by 1e-3. Each tilted plane's poses are :func:`facing_pose_vectors` of the angles.
    Cached: a rig's plane is the same for every stereo pair."""
    theta = np.deg2rad(np.linspace(-theta_deg, theta_deg, 2 * int(np.ceil(theta_deg)) + 1))
    flat = np.zeros((len(theta), 6))
    flat[:, 5] = np.sin(theta / 2)
    axis = np.deg2rad(np.arange(0.0, 360.0, 5.0))
    rotvec = np.deg2rad(tilt_deg) * np.column_stack([np.cos(axis), np.sin(axis),
                                                     np.zeros(len(axis))])
    tilted = (Rotation.from_matrix(np.frombuffer(R_cam1_plane).reshape(3, 3))
              * Rotation.from_rotvec(rotvec)).as_quat(scalar_first=True)
    eps = np.concatenate([facing_pose_vectors(flat, q_plane)[:, 3:5] for q_plane in tilted])
    return eps.min(axis=0) - 1e-3, eps.max(axis=0) + 1e-3
