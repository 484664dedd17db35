"""The search space's tilt bounds, measured from camera 1 or from the table facing the rig."""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from photomodel.search import SearchSpace
from photomodel.sim import hand_stereo_rig


def _eps(R: Rotation) -> np.ndarray:
    q = R.as_quat()     # (x, y, z, w)
    return np.where(q[:, 3:] < 0, -q[:, :3], q[:, :3])


def _on_plane(R_plane: np.ndarray, tilt_deg: np.ndarray, axis_rad: np.ndarray,
              theta_deg: np.ndarray) -> Rotation:
    """Rotations ``R_plane @ R_tilt @ Rz(theta)``, the tilt about an axis of the plane."""
    rotvec = np.column_stack([np.cos(axis_rad), np.sin(axis_rad), np.zeros_like(axis_rad)])
    tilt = Rotation.from_rotvec(rotvec * np.radians(tilt_deg)[:, None])
    return (Rotation.from_matrix(R_plane) * tilt
            * Rotation.from_euler("z", theta_deg[:, None], degrees=True))


def test_tilt_from_camera_plane_is_the_paper_box() -> None:
    camera = SearchSpace.from_ranges()
    plane = SearchSpace.from_ranges(R_cam1_plane=np.eye(3))
    np.testing.assert_allclose(plane.lower, camera.lower, atol=1.1e-3)
    np.testing.assert_allclose(plane.upper, camera.upper, atol=1.1e-3)
    assert np.all(plane.lower <= camera.lower) and np.all(plane.upper >= camera.upper)


def test_tilt_bounds_follow_the_table_facing_a_converging_rig() -> None:
    R_plane = hand_stereo_rig().R_cam1_facing
    space = SearchSpace.from_ranges(R_cam1_plane=R_plane)
    gen = np.random.default_rng(0)
    n = 20000
    tilt = 10.0 * np.sqrt(gen.uniform(0.0, 1.0, n))
    eps = _eps(_on_plane(R_plane, tilt, gen.uniform(0.0, 2 * np.pi, n),
                         gen.uniform(-53.0, 53.0, n)))
    # every garment within 10 deg of the table is inside; the box is no looser than needed
    assert np.all(eps[:, :2] >= space.lower[3:5]) and np.all(eps[:, :2] <= space.upper[3:5])
    np.testing.assert_allclose(eps[:, :2].min(axis=0), space.lower[3:5], atol=4e-3)
    np.testing.assert_allclose(eps[:, :2].max(axis=0), space.upper[3:5], atol=4e-3)
    # a garment tilted 8 deg on that table lies 13 deg from camera 1: outside the paper's box
    far = _eps(_on_plane(R_plane, np.array([8.0]), np.array([0.5 * np.pi]), np.array([0.0])))
    pose = np.concatenate([[0.0, 0.0, 700.0], far[0]])
    assert space.contains(pose)
    assert not SearchSpace.from_ranges().contains(pose)
