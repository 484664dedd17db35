"""Homogeneous 4x4 transforms. ``T_a_b`` maps coordinates in frame b to frame a."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray


def make_transform(R: ArrayLike, t: ArrayLike) -> NDArray[np.float64]:
    """Build ``T`` (4, 4) from a rotation ``R`` (3, 3) and a translation ``t`` (3,) in mm."""
    T = np.eye(4)
    T[:3, :3] = np.asarray(R, dtype=np.float64).reshape(3, 3)
    T[:3, 3] = np.asarray(t, dtype=np.float64).reshape(3)
    return T


def invert_transform(T_a_b: ArrayLike) -> NDArray[np.float64]:
    """Return ``T_b_a`` for a rigid ``T_a_b`` of shape (..., 4, 4), using R^T rather than inv."""
    T = np.asarray(T_a_b, dtype=np.float64)
    R_t = np.swapaxes(T[..., :3, :3], -1, -2)
    out = np.zeros_like(T)
    out[..., :3, :3] = R_t
    out[..., :3, 3] = -np.einsum("...ij,...j->...i", R_t, T[..., :3, 3])
    out[..., 3, 3] = 1.0
    return out


def transform_points(T_a_b: ArrayLike, points_b: ArrayLike) -> NDArray[np.float64]:
    """Map points (N, 3) in frame b to frame a with ``T_a_b`` (4, 4)."""
    T = np.asarray(T_a_b, dtype=np.float64)
    p = np.asarray(points_b, dtype=np.float64)
    return p @ T[:3, :3].T + T[:3, 3]


def rotation_angle_deg(R_a: ArrayLike, R_b: ArrayLike) -> float:
    """Angle (deg) of the rotation between two rotation matrices (3, 3): ``R_a^T R_b``'s."""
    c = (float(np.trace(np.asarray(R_a, dtype=np.float64).T @ np.asarray(R_b, np.float64)))
         - 1.0) / 2.0
    return float(np.degrees(np.arccos(np.clip(c, -1.0, 1.0))))
