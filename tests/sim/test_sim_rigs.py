"""Geometry of the default cameras: baseline, vergence, table pose."""

from __future__ import annotations

import numpy as np
import pytest

from photomodel.sim import (
    BASELINE_MM,
    WORK_DISTANCE_MM,
    hand_stereo_rig,
    hand_table_pose,
    model_station_camera,
)


def _closest_points(p1, d1, p2, d2):
    """Closest points of the lines p1 + s d1 and p2 + t d2."""
    A = np.array([[d1 @ d1, -d1 @ d2], [d1 @ d2, -d2 @ d2]])
    s, t = np.linalg.solve(A, [(p2 - p1) @ d1, (p2 - p1) @ d2])
    return p1 + s * d1, p2 + t * d2


@pytest.mark.parametrize("distortion", [True, False])
def test_optical_axes_cross_at_the_work_distance(distortion):
    rig = hand_stereo_rig(distortion)
    centre2 = -rig.R.T @ rig.T  # camera 2's centre in camera 1's frame
    assert np.linalg.norm(centre2) == pytest.approx(BASELINE_MM, abs=1e-9)
    assert centre2[0] < -0.99 * BASELINE_MM  # camera 2 (left) lies along camera 1's -x
    a1, a2 = _closest_points(np.zeros(3), np.array([0.0, 0, 1]), centre2, rig.R.T[:, 2])
    assert np.linalg.norm(a1 - a2) < 1.0
    crossing = (a1 + a2) / 2
    assert np.linalg.norm(crossing - centre2 / 2) == pytest.approx(WORK_DISTANCE_MM, abs=1.0)
    half_vergence = np.arccos(rig.R.T[2, 2]) / 2
    assert np.degrees(half_vergence) == pytest.approx(np.degrees(np.arctan(60 / 685)), abs=1e-6)


def test_cameras_are_realistic_and_slightly_different():
    rig = hand_stereo_rig()
    for cam in rig.cameras:
        assert cam.image_size == (640, 480)
        assert 790 < cam.K[0, 0] < 810 and 790 < cam.K[1, 1] < 810
        assert abs(cam.K[0, 2] - 319.5) < 10 and abs(cam.K[1, 2] - 239.5) < 10
        assert cam.dist[0] == pytest.approx(-0.15, abs=0.01)
    assert not np.allclose(rig.cam1.K, rig.cam2.K)
    assert not hand_stereo_rig(distortion=False).cam1.has_distortion
    model = model_station_camera()
    assert model.image_size == (640, 480) and model.K[0, 0] == model.K[1, 1] == 760.0
    assert model.dist[:2].tolist() == [-0.12, 0.08]


def test_table_faces_the_rig_at_the_work_distance(rig):
    T_cam1_table = hand_table_pose(rig)
    R, origin = T_cam1_table[:3, :3], T_cam1_table[:3, 3]
    np.testing.assert_allclose(R @ R.T, np.eye(3), atol=1e-12)
    assert np.linalg.det(R) == pytest.approx(1.0)
    centre2 = -rig.R.T @ rig.T
    assert np.linalg.norm(origin - centre2 / 2) == pytest.approx(WORK_DISTANCE_MM)
    # Normal along the bisector, pointing away from the cameras; same angle to both axes.
    z = R[:, 2]
    assert z[2] > 0 and z @ [0, 0, 1] == pytest.approx(z @ rig.R.T[:, 2])
    assert np.degrees(np.arccos(z[2])) == pytest.approx(np.degrees(np.arctan(60 / 685)))
    assert R[0, 0] > 0.99 and R[1, 1] > 0.99  # x, y roughly camera 1's
    # The table origin is where both axes cross: it projects to each principal point.
    for cam, T_cam_cam1 in ((rig.cam1, np.eye(4)), (rig.cam2, rig.T_cam2_cam1)):
        p = (T_cam_cam1 @ T_cam1_table)[:3, 3]
        np.testing.assert_allclose(cam.project(p), cam.K[:2, 2], atol=1e-6)
