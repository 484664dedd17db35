"""Grasp and place planning: the grasp frame, waypoints the arm reaches, clear refusals."""

from __future__ import annotations

import numpy as np
import pytest

from photomodel.geometry import make_transform
from photomodel.robot import (
    CellLayout,
    PickSettings,
    UnreachableError,
    forward_kinematics,
    grasp_pose,
    load_arm,
    plan_pick,
)
from photomodel.sim import garment_placement

ARM = load_arm()
Q_PHOTO = np.radians([0.0, 20.0, 0.0, 80.0, 0.0, 80.0, 0.0])
# The table frame of the cell: z down into the table top at base z = 0.
T_BASE_TABLE = make_transform(np.diag([1.0, -1.0, -1.0]), [600.0, 0.0, 0.0])


def _garment(x: float, y: float, theta_deg: float) -> np.ndarray:
    return T_BASE_TABLE @ garment_placement(x, y, theta_deg)


@pytest.mark.parametrize("theta_deg", [-53.0, 0.0, 30.0, 120.0])
def test_grasp_frame_follows_the_garment(theta_deg: float) -> None:
    T_model = _garment(40.0, -30.0, theta_deg)
    T = grasp_pose(T_model, (0.0, 0.0), x_prefer=(1.0, 0.0, 0.0))
    np.testing.assert_allclose(T[:3, 3], T_model[:3, 3], atol=1e-12)
    np.testing.assert_allclose(T[:3, 2], [0.0, 0.0, -1.0], atol=1e-12)  # down onto the cloth
    assert abs(abs(T[:3, 0] @ T_model[:3, 0]) - 1.0) < 1e-12  # yaw = garment angle mod 180
    assert T[0, 0] >= 0.0  # the half turn nearer to x_prefer
    np.testing.assert_allclose(T[:3, :3].T @ T[:3, :3], np.eye(3), atol=1e-12)


def test_grasp_point_away_from_the_centroid() -> None:
    T_model = _garment(0.0, 0.0, 90.0)  # model x along table y = base -y
    T = grasp_pose(T_model, (50.0, 0.0))
    np.testing.assert_allclose(T[:3, 3], [600.0, -50.0, 0.0], atol=1e-9)


def test_plan_reaches_every_waypoint_within_limits() -> None:
    settings = PickSettings()
    layout = CellLayout()
    plan = plan_pick(ARM, Q_PHOTO, _garment(120.0, -90.0, 35.0), layout, settings, rng=0)
    names = [w.name for w in plan.waypoints]
    assert names == ["start", "pre_grasp", "grasp", "lift", "pre_place", "place", "retreat"]
    assert plan.within_limits
    T_hand_tcp = settings.gripper.T_hand_tcp
    for w in plan.waypoints:
        assert ARM.within_limits(w.q)
        T = forward_kinematics(ARM, w.q) @ T_hand_tcp
        np.testing.assert_allclose(T[:3, 3], w.T_base_tcp[:3, 3], atol=1e-2)
        np.testing.assert_allclose(T[:3, :3], w.T_base_tcp[:3, :3], atol=1e-5)
    grasp, pre = plan.waypoint("grasp"), plan.waypoint("pre_grasp")
    np.testing.assert_allclose(pre.T_base_tcp[:3, 3] - grasp.T_base_tcp[:3, 3],
                               [0.0, 0.0, settings.approach_mm], atol=1e-9)
    place = plan.waypoint("place").T_base_tcp[:3, 3]
    np.testing.assert_allclose(place, np.add(layout.box_centre_mm, [0, 0, settings.release_mm]))
    np.testing.assert_allclose(plan.grasp_point_mm, [720.0, 90.0, 0.0], atol=1e-9)
    # consecutive rows of the joint path are small steps (no flips on straight segments)
    steps = np.abs(np.diff(plan.path_q, axis=0))
    straight = [r for r in range(1, len(plan.path_q)) if r not in (1, plan.waypoint_rows[4])]
    assert np.degrees(steps[np.array(straight) - 1].max()) < 60.0
    data = plan.to_json_dict()
    assert data["reachable"] and len(data["waypoints"]) == 7
    assert len(data["waypoints"][2]["joints_deg"]) == 7


def test_out_of_reach_garment_is_refused_clearly() -> None:
    far = make_transform(np.diag([1.0, -1.0, -1.0]), [1500.0, 0.0, 0.0])
    with pytest.raises(UnreachableError, match=r"pre_grasp at \(1500, 0, 100\) mm in the base "
                                               r"frame is out of reach of the PA10-7C"):
        plan_pick(ARM, Q_PHOTO, far)


def test_box_out_of_reach_is_refused() -> None:
    layout = CellLayout(box_centre_mm=(0.0, -1400.0, 0.0))
    with pytest.raises(UnreachableError, match="pre_place"):
        plan_pick(ARM, Q_PHOTO, _garment(0.0, 0.0, 0.0), layout)

