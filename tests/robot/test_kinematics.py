"""PA10-7C kinematics: the DH table against hand-computed poses, FK/IK round trips, limits."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from photomodel.errors import InputError
from photomodel.robot import (
    IKSettings,
    available_link_sets,
    forward_kinematics,
    inverse_kinematics,
    jacobian,
    joint_frames,
    load_arm,
)
from photomodel.robot._kinematics import pose_error

ARM = load_arm()
MARGIN = np.radians(5.0)


def test_table_is_the_cited_pa10_7c() -> None:
    assert ARM.n_joints == 7
    assert ARM.link_set == "317-450-480-70"
    assert ARM.d_mm.tolist() == [317.0, 0.0, 450.0, 0.0, 480.0, 0.0, 70.0]
    assert np.degrees(ARM.q_max_rad).round().tolist() == [177, 90, 174, 137, 255, 165, 255]
    assert "valterfc/Anthropomorphism" in ARM.sources["links"]
    assert set(available_link_sets()) == {"317-450-480-70", "315-450-500-80"}


@pytest.mark.parametrize(("link_set", "height"), [("317-450-480-70", 1317.0),
                                                  ("315-450-500-80", 1345.0)])
def test_zero_pose_points_straight_up(link_set: str, height: float) -> None:
    T = forward_kinematics(load_arm(link_set=link_set), np.zeros(7))
    np.testing.assert_allclose(T, [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, height], [0, 0, 0, 1]],
                               atol=1e-9)


def test_hand_computed_poses() -> None:
    # S2 = +90 deg tips the straight arm over about base y: the flange lies along +x at
    # shoulder height, its z along +x.
    T = forward_kinematics(ARM, np.radians([0, 90, 0, 0, 0, 0, 0]))
    np.testing.assert_allclose(T[:3, 3], [450 + 480 + 70, 0, 317], atol=1e-9)
    np.testing.assert_allclose(T[:3, 2], [1, 0, 0], atol=1e-12)
    # E1 = +90 deg bends the forearm (480 + 70) forward at the elbow (317 + 450 high) ...
    T = forward_kinematics(ARM, np.radians([0, 0, 0, 90, 0, 0, 0]))
    np.testing.assert_allclose(T[:3, 3], [550, 0, 767], atol=1e-9)
    # ... and S1 = +90 deg turns all of it to +y.
    T = forward_kinematics(ARM, np.radians([90, 0, 0, 90, 0, 0, 0]))
    np.testing.assert_allclose(T[:3, 3], [0, 550, 767], atol=1e-9)


def test_frames_and_batches_agree_with_single_calls() -> None:
    rng = np.random.default_rng(1)
    q = rng.uniform(ARM.q_min_rad, ARM.q_max_rad, size=(5, 7))
    batch = forward_kinematics(ARM, q)
    frames = joint_frames(ARM, q)
    for k in range(5):
        np.testing.assert_allclose(batch[k], forward_kinematics(ARM, q[k]), atol=1e-9)
        np.testing.assert_allclose(frames[k, -1], batch[k], atol=1e-9)


def test_jacobian_matches_finite_differences() -> None:
    q = np.radians([10, 30, -20, 70, 15, 40, -30])
    J = jacobian(ARM, q)
    h = 1e-6
    for i in range(7):
        dq = np.zeros(7)
        dq[i] = h
        e = pose_error(forward_kinematics(ARM, q + dq), forward_kinematics(ARM, q - dq)) / (2 * h)
        np.testing.assert_allclose(J[:, i], e, atol=1e-5)


joint_vectors = st.tuples(*[st.floats(float(lo + MARGIN), float(hi - MARGIN))
                            for lo, hi in zip(ARM.q_min_rad, ARM.q_max_rad, strict=True)])


@settings(max_examples=40, deadline=None)
@given(q=joint_vectors, seed=st.integers(0, 2**16))
@example(q=(0.0, 0.625, 0.0, 0.0, 0.0, 0.0, 0.0), seed=0)  # stretched: exactly at full reach
def test_ik_round_trip_from_the_middle(q: tuple[float, ...], seed: int) -> None:
    """Any pose FK reaches, IK reaches again from the middle of the ranges, within limits."""
    T = forward_kinematics(ARM, np.array(q))
    result = inverse_kinematics(ARM, T, rng=seed)
    assert result.success, result.reason
    assert ARM.within_limits(result.q)
    T_ik = forward_kinematics(ARM, result.q)
    assert np.linalg.norm(T_ik[:3, 3] - T[:3, 3]) < 1e-3
    assert Rotation.from_matrix(T_ik[:3, :3] @ T[:3, :3].T).magnitude() < 1e-6


@settings(max_examples=25, deadline=None)
@given(q=joint_vectors, kick=st.lists(st.floats(-0.05, 0.05), min_size=7, max_size=7))
def test_ik_from_a_nearby_start_stays_near(q: tuple[float, ...], kick: list[float]) -> None:
    """Redundancy resolved by continuity: a start 3 deg away gives a solution nearby."""
    q_true = np.array(q)
    T = forward_kinematics(ARM, q_true)
    result = inverse_kinematics(ARM, T, q_true + np.array(kick), rng=0)
    assert result.success
    assert result.starts == 1
    assert np.max(np.abs(result.q - q_true)) < np.radians(30.0)


def test_ik_near_the_straight_arm_needs_no_restart() -> None:
    # Hypothesis found this: next to the straight-arm singularity a refused step used to be
    # tried again unchanged until the solver gave up; the damping must grow on refusal.
    q_true = np.array([0.0, 0.0, 0.0, -0.0156, 0.0, 0.0, 0.0])
    T = forward_kinematics(ARM, q_true)
    rng = np.random.default_rng(1)
    for _ in range(50):
        result = inverse_kinematics(ARM, T, q_true + rng.uniform(-0.05, 0.05, 7), rng=0)
        assert result.success and result.starts == 1


def test_out_of_reach_fails_fast_with_a_reason() -> None:
    T = np.eye(4)
    T[:3, 3] = [1500.0, 0.0, 300.0]
    result = inverse_kinematics(ARM, T)
    assert not result.success
    assert "beyond the arm's reach" in result.reason
    assert ARM.within_limits(result.q)


def test_pose_reachable_only_outside_the_limits_is_refused() -> None:
    # The hand pose of E1 = 170 deg (limit 137) with everything else at zero: a folded elbow
    # the joint limits forbid; no other configuration reaches it either.
    q = np.zeros(7)
    q[3] = np.radians(170.0)
    frames = joint_frames(ARM, q)
    T = frames[-1]
    result = inverse_kinematics(ARM, T, settings=IKSettings(restarts=5), rng=0)
    assert not result.success
    assert ARM.within_limits(result.q)


def test_check_joints_names_the_problem() -> None:
    with pytest.raises(InputError, match="expected 7 joint angles"):
        ARM.check_joints(np.zeros(6), "--joints-deg")
    with pytest.raises(InputError, match="joint E1 at 150.0 deg is outside"):
        ARM.check_joints(np.radians([0, 0, 0, 150, 0, 0, 0]), "--joints-deg")
    with pytest.raises(InputError, match="unknown link set"):
        load_arm(link_set="1-2-3-4")


def test_agrees_with_roboticstoolbox() -> None:
    """The same table in roboticstoolbox-python (optional extra 'robot'): FK and ik_LM."""
    rtb = pytest.importorskip("roboticstoolbox")
    links = [rtb.RevoluteDH(d=d / 1000.0, a=a / 1000.0, alpha=al, qlim=[lo, hi])
             for d, a, al, lo, hi in zip(ARM.d_mm, ARM.a_mm, ARM.alpha_rad, ARM.q_min_rad,
                                         ARM.q_max_rad, strict=True)]
    robot = rtb.DHRobot(links, name="PA10-7C")
    rng = np.random.default_rng(3)
    for _ in range(20):
        q = rng.uniform(ARM.q_min_rad + MARGIN, ARM.q_max_rad - MARGIN)
        T_rtb = np.asarray(robot.fkine(q).A)
        T = forward_kinematics(ARM, q)
        np.testing.assert_allclose(T[:3, :3], T_rtb[:3, :3], atol=1e-9)
        np.testing.assert_allclose(T[:3, 3], 1000.0 * T_rtb[:3, 3], atol=1e-6)
        # RTB's tolerance bounds half the squared error in metres: 1e-10 ~ 0.014 mm
        sol = robot.ik_LM(T_rtb, q0=np.zeros(7), joint_limits=True, tol=1e-10)
        if sol.success:  # where RTB converges, its answer is a solution of ours too
            np.testing.assert_allclose(forward_kinematics(ARM, sol.q)[:3, 3], T[:3, 3],
                                       atol=0.05)
        assert inverse_kinematics(ARM, T, rng=0).success
