"""Rigid transforms and the paper's pose vector, against independent computations."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from photomodel.geometry import (
    eps_from_rotation,
    facing_pose_vectors,
    flat_pose_vectors,
    in_plane_angle_rad,
    invert_transform,
    make_transform,
    plane_quat_wxyz,
    pose_vectors_to_matrices,
    quat_wxyz_from_matrix,
    rotation_from_eps,
    strained_matrices,
    transform_points,
)

SETTINGS = settings(max_examples=200, deadline=None)


@st.composite
def quats_wxyz(draw: st.DrawFn, min_w: float = 0.0) -> np.ndarray:
    """Unit quaternions (4,) in (w, x, y, z) order with w >= min_w: an axis and an angle up to
    ``2 arccos(min_w)`` (drawing four components and keeping those with w >= 0.9 filtered out
    so many that Hypothesis's health check failed now and then)."""
    axis = np.array([draw(st.floats(-1.0, 1.0)) for _ in range(3)])
    n = np.linalg.norm(axis)
    assume(n > 0.1)
    half = 0.5 * draw(st.floats(0.0, 2.0 * float(np.arccos(min_w))))
    q = np.concatenate([[np.cos(half)], np.sin(half) * axis / n])
    assume(q[0] >= min_w)
    return q


@st.composite
def transforms(draw: st.DrawFn) -> np.ndarray:
    """Rigid transforms (4, 4) with translations up to 1 m."""
    q = draw(quats_wxyz())
    t = [draw(st.floats(-1000.0, 1000.0)) for _ in range(3)]
    return make_transform(Rotation.from_quat([q[1], q[2], q[3], q[0]]).as_matrix(), t)


def _scipy_matrix(q_wxyz: np.ndarray) -> np.ndarray:
    w, x, y, z = q_wxyz
    return Rotation.from_quat([x, y, z, w]).as_matrix()  # scipy's order is (x, y, z, w)


def _rot_z(angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _rot_x(angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


# --- rotation_from_eps / eps_from_rotation -------------------------------------------------


@SETTINGS
@given(q=quats_wxyz(min_w=1e-4))
def test_rotation_from_eps_matches_scipy(q: np.ndarray) -> None:
    np.testing.assert_allclose(rotation_from_eps(q[1:]), _scipy_matrix(q), rtol=0, atol=1e-9)


@SETTINGS
@given(q=quats_wxyz())
def test_rotation_from_eps_matches_scipy_up_to_half_turns(q: np.ndarray) -> None:
    """At |eps| -> 1 the scalar part sqrt(1 - |eps|^2) has only ~1e-8 absolute precision."""
    np.testing.assert_allclose(rotation_from_eps(q[1:]), _scipy_matrix(q), rtol=0, atol=1e-7)


@SETTINGS
@given(q=quats_wxyz(min_w=1e-3))
def test_eps_round_trip(q: np.ndarray) -> None:
    eps = q[1:]
    assert np.linalg.norm(eps) < 1.0
    np.testing.assert_allclose(eps_from_rotation(rotation_from_eps(eps)), eps, rtol=0, atol=1e-9)


@SETTINGS
@given(q=quats_wxyz())
def test_rotation_from_eps_is_a_rotation(q: np.ndarray) -> None:
    R = rotation_from_eps(q[1:])
    np.testing.assert_allclose(R @ R.T, np.eye(3), rtol=0, atol=1e-9)
    assert np.linalg.det(R) == pytest.approx(1.0, abs=1e-12)


def test_rotation_from_eps_known_values() -> None:
    np.testing.assert_array_equal(rotation_from_eps(np.zeros(3)), np.eye(3))
    angle = 0.7
    np.testing.assert_allclose(rotation_from_eps([0.0, 0.0, np.sin(angle / 2)]), _rot_z(angle),
                               atol=1e-15)
    np.testing.assert_allclose(rotation_from_eps([np.sin(angle / 2), 0.0, 0.0]), _rot_x(angle),
                               atol=1e-15)


def test_rotation_from_eps_is_vectorised() -> None:
    rng = np.random.default_rng(0)
    q = Rotation.random(35, random_state=rng).as_quat()  # (x, y, z, w)
    q[q[:, 3] < 0] *= -1
    eps = q[:, :3].reshape(5, 7, 3)
    R = rotation_from_eps(eps)
    assert R.shape == (5, 7, 3, 3)
    np.testing.assert_allclose(R.reshape(-1, 3, 3), Rotation.from_quat(q).as_matrix(),
                               rtol=0, atol=1e-9)
    np.testing.assert_allclose(R[2, 3], rotation_from_eps(eps[2, 3]), rtol=0, atol=0)


# --- quat_wxyz_from_matrix -----------------------------------------------------------------


@SETTINGS
@given(q=quats_wxyz())
def test_quat_wxyz_from_matrix(q: np.ndarray) -> None:
    R = _scipy_matrix(q)
    got = quat_wxyz_from_matrix(R)
    assert got.shape == (4,)
    assert got[0] >= 0.0
    assert np.linalg.norm(got) == pytest.approx(1.0, abs=1e-12)
    # The same rotation (q and -q are the same; with w >= 0 only w == 0 leaves a choice).
    assert min(np.abs(got - q).max(), np.abs(got + q).max()) < 1e-9
    np.testing.assert_allclose(_scipy_matrix(got), R, rtol=0, atol=1e-9)


def test_quat_wxyz_order_for_a_z_rotation() -> None:
    angle = 1.1
    q = quat_wxyz_from_matrix(_rot_z(angle))
    np.testing.assert_allclose(q, [np.cos(angle / 2), 0.0, 0.0, np.sin(angle / 2)], atol=1e-15)


def test_quat_wxyz_from_matrix_accepts_a_transform() -> None:
    T = make_transform(_rot_x(-0.4), [10.0, 20.0, 30.0])
    np.testing.assert_allclose(quat_wxyz_from_matrix(T), quat_wxyz_from_matrix(T[:3, :3]),
                               atol=0)


def test_quat_wxyz_w_non_negative_for_large_angles() -> None:
    """Rotations beyond 180 deg as scipy might return them (w < 0) come back with w >= 0."""
    for angle in np.linspace(-np.pi + 1e-3, np.pi - 1e-3, 41):
        q = quat_wxyz_from_matrix(_rot_z(angle))
        assert q[0] >= 0.0
        assert np.sign(q[3]) == np.sign(angle) or abs(angle) < 1e-12


# --- transforms ----------------------------------------------------------------------------


@SETTINGS
@given(T=transforms())
def test_invert_transform_matches_numpy(T: np.ndarray) -> None:
    inv = invert_transform(T)
    np.testing.assert_allclose(inv, np.linalg.inv(T), rtol=0, atol=1e-9)
    np.testing.assert_allclose(inv @ T, np.eye(4), rtol=0, atol=1e-9)
    np.testing.assert_array_equal(inv[3], [0.0, 0.0, 0.0, 1.0])


def test_invert_transform_is_vectorised() -> None:
    rng = np.random.default_rng(1)
    Rs = Rotation.random(6, random_state=rng).as_matrix()
    T = np.stack([make_transform(R, t) for R, t in
                  zip(Rs, rng.uniform(-500, 500, (6, 3)), strict=True)]).reshape(2, 3, 4, 4)
    inv = invert_transform(T)
    assert inv.shape == (2, 3, 4, 4)
    np.testing.assert_allclose(inv, np.linalg.inv(T), rtol=0, atol=1e-9)


@SETTINGS
@given(T_a_b=transforms(), T_b_c=transforms(),
       p=st.lists(st.floats(-500.0, 500.0), min_size=3, max_size=3))
def test_transform_chain(T_a_b: np.ndarray, T_b_c: np.ndarray, p: list[float]) -> None:
    points_c = np.array([p, [0.0, 0.0, 0.0], [1.0, -2.0, 3.0]])
    T_a_c = T_a_b @ T_b_c
    np.testing.assert_allclose(transform_points(T_a_c, points_c),
                               transform_points(T_a_b, transform_points(T_b_c, points_c)),
                               rtol=0, atol=1e-8)
    np.testing.assert_allclose(invert_transform(T_a_c),
                               invert_transform(T_b_c) @ invert_transform(T_a_b),
                               rtol=0, atol=1e-8)
    # p_a = T_a_b @ p_b in homogeneous coordinates.
    homog = np.column_stack([points_c, np.ones(3)]) @ T_a_c.T
    np.testing.assert_allclose(transform_points(T_a_c, points_c), homog[:, :3], atol=1e-8)


def test_make_transform_layout() -> None:
    R = _rot_z(0.3) @ _rot_x(0.2)
    T = make_transform(R, [1.0, 2.0, 3.0])
    assert T.shape == (4, 4)
    np.testing.assert_array_equal(T[:3, :3], R)
    np.testing.assert_array_equal(T[:3, 3], [1.0, 2.0, 3.0])
    np.testing.assert_array_equal(T[3], [0.0, 0.0, 0.0, 1.0])
    np.testing.assert_allclose(transform_points(T, [[1.0, 0.0, 0.0]]),
                               [R[:, 0] + [1.0, 2.0, 3.0]], atol=1e-15)


# --- in-plane angle and pose vectors -------------------------------------------------------


@SETTINGS
@given(angle=st.floats(-np.pi + 1e-9, np.pi - 1e-9), tilt=st.floats(-0.5, 0.5))
def test_in_plane_angle_of_z_rotation(angle: float, tilt: float) -> None:
    assert in_plane_angle_rad(_rot_z(angle)) == pytest.approx(angle, abs=1e-12)
    # A tilt about the model's own x axis leaves the x axis, and so the angle, unchanged.
    assert in_plane_angle_rad(_rot_z(angle) @ _rot_x(tilt)) == pytest.approx(angle, abs=1e-12)
    T = make_transform(_rot_z(angle), [5.0, 6.0, 700.0])
    assert in_plane_angle_rad(T) == pytest.approx(angle, abs=1e-12)


def test_in_plane_angle_from_eps() -> None:
    for angle in np.deg2rad([-53.0, -10.0, 0.0, 17.5, 53.0]):
        R = rotation_from_eps([0.0, 0.0, np.sin(angle / 2)])
        assert in_plane_angle_rad(R) == pytest.approx(angle, abs=1e-12)


@SETTINGS
@given(q=quats_wxyz(min_w=1e-4),
       xyz=st.lists(st.floats(-900.0, 900.0), min_size=3, max_size=3))
def test_pose_vectors_to_matrices(q: np.ndarray, xyz: list[float]) -> None:
    pose = np.concatenate([xyz, q[1:]])
    T = pose_vectors_to_matrices(pose[None])
    assert T.shape == (1, 4, 4)
    np.testing.assert_allclose(T[0], make_transform(_scipy_matrix(q), xyz), rtol=0, atol=1e-9)


def test_pose_vectors_to_matrices_batch_and_single() -> None:
    rng = np.random.default_rng(2)
    q = Rotation.random(9, random_state=rng).as_quat()
    q[q[:, 3] < 0] *= -1
    poses = np.column_stack([rng.uniform(-200, 800, (9, 3)), q[:, :3]])
    T = pose_vectors_to_matrices(poses)
    assert T.shape == (9, 4, 4)
    np.testing.assert_allclose(T[:, :3, :3], Rotation.from_quat(q).as_matrix(), atol=1e-9)
    np.testing.assert_array_equal(T[:, :3, 3], poses[:, :3])
    np.testing.assert_array_equal(T[:, 3], np.tile([0.0, 0.0, 0.0, 1.0], (9, 1)))
    np.testing.assert_array_equal(pose_vectors_to_matrices(poses[4]), T[4:5])


@pytest.mark.parametrize("shape", [(5,), (3, 7), (2, 3)])
def test_pose_vectors_to_matrices_rejects_wrong_shape(shape: tuple[int, ...]) -> None:
    with pytest.raises(ValueError, match="poses"):
        pose_vectors_to_matrices(np.zeros(shape))


# --- facing_pose_vectors / flat_pose_vectors ------------------------------------------------


@SETTINGS
@given(q=quats_wxyz(min_w=0.9), angle=st.floats(-3.0, 3.0))
def test_facing_pose_vectors_lay_the_garment_on_the_plane(q: np.ndarray, angle: float) -> None:
    R_face = _scipy_matrix(q)
    flat = np.array([[12.0, -30.0, 650.0, 0.3, -0.2, np.sin(angle / 2)]])
    pose = facing_pose_vectors(flat, R_face)
    np.testing.assert_array_equal(pose[0, :3], flat[0, :3])
    np.testing.assert_allclose(rotation_from_eps(pose[0, 3:]), R_face @ _rot_z(angle),
                               atol=1e-12)
    back = flat_pose_vectors(pose, R_face)
    np.testing.assert_allclose(back, [[12.0, -30.0, 650.0, 0.0, 0.0, np.sin(angle / 2)]],
                               atol=1e-12)


def test_facing_pose_vectors_of_a_population_keep_the_scalar_part_non_negative() -> None:
    """A population at once, row by row as alone, the plane given as a matrix or as its
    quaternion: a plane turned 170 deg about z makes some angles' products' scalar part
    negative, and those rows flip sign (the same rotation, the one ``eps``)."""
    rng = np.random.default_rng(3)
    R_face = _rot_z(np.deg2rad(170.0)) @ _rot_x(0.1)
    angles = rng.uniform(-3.0, 3.0, 40)
    flat = np.column_stack([rng.uniform(-100, 100, (40, 3)), np.zeros((40, 2)),
                            np.sin(angles / 2)])
    poses = facing_pose_vectors(flat, R_face)
    np.testing.assert_array_equal(poses, facing_pose_vectors(flat, quat_wxyz_from_matrix(R_face)))
    for row, pose, angle in zip(flat, poses, angles, strict=True):
        np.testing.assert_array_equal(facing_pose_vectors(row, R_face)[0], pose)
        np.testing.assert_allclose(rotation_from_eps(pose[3:]), R_face @ _rot_z(angle),
                                   atol=1e-12)
    q = quat_wxyz_from_matrix(R_face)
    flipped = q[0] * np.cos(angles / 2) - q[3] * np.sin(angles / 2) < 0
    assert flipped.any() and not flipped.all()


@pytest.mark.parametrize("shape", [(5,), (3, 7), (2, 3)])
def test_facing_pose_vectors_reject_wrong_shape(shape: tuple[int, ...]) -> None:
    with pytest.raises(ValueError, match="flat"):
        facing_pose_vectors(np.zeros(shape), np.eye(3))


def test_facing_pose_vectors_of_the_identity_are_the_flat_vectors() -> None:
    flat = np.array([[1.0, 2.0, 600.0, 0.0, 0.0, 0.3], [0.0, 0.0, 700.0, 0.0, 0.0, -0.4]])
    np.testing.assert_allclose(facing_pose_vectors(flat, np.eye(3)), flat, atol=1e-15)
    np.testing.assert_allclose(flat_pose_vectors(flat, np.eye(3)), flat, atol=1e-15)


def test_flat_pose_vectors_drop_the_tilt() -> None:
    R_face = _rot_x(0.1)
    tilted = np.array([[0.0, 0.0, 700.0, *eps_from_rotation(_rot_x(0.15) @ _rot_z(0.4))]])
    flat = flat_pose_vectors(tilted, R_face)
    assert flat[0, 3] == flat[0, 4] == 0.0
    assert 2 * np.arcsin(flat[0, 5]) == pytest.approx(0.4, abs=2e-3)  # 0.05 rad of tilt left


def test_strained_matrices_keep_the_pose_and_stretch_the_model_plane() -> None:
    pose = np.array([[12.0, -30.0, 690.0, 0.02, -0.05, 0.3]])
    np.testing.assert_array_equal(strained_matrices(pose, np.zeros(3)),
                                  pose_vectors_to_matrices(pose))
    A = strained_matrices(pose, [-0.02, 0.01, 0.005])[0]
    T = pose_vectors_to_matrices(pose)[0]
    # A model point (x, y, 0) lands where the pose puts ((I + E) (x, y), 0).
    p = np.array([100.0, -40.0, 0.0, 1.0])
    q = np.array([100.0 * 0.98 - 40.0 * 0.005, 100.0 * 0.005 - 40.0 * 1.01, 0.0, 1.0])
    np.testing.assert_allclose(A @ p, T @ q, atol=1e-9)
    U, _, Vt = np.linalg.svd(A[:3, :3])           # the rotation is the polar factor
    np.testing.assert_allclose(U @ Vt, T[:3, :3], atol=1e-12)
    np.testing.assert_array_equal(A[:3, 2:], T[:3, 2:])
    both = strained_matrices(np.repeat(pose, 2, axis=0), [[0, 0, 0], [-0.02, 0.01, 0.005]])
    np.testing.assert_array_equal(both[1], A)


@SETTINGS
@given(quats_wxyz())
def test_plane_quat_wxyz_keeps_what_quat_wxyz_from_matrix_gives(q: np.ndarray) -> None:
    R = Rotation.from_quat(q[[1, 2, 3, 0]]).as_matrix()
    first = plane_quat_wxyz(R)
    np.testing.assert_array_equal(first, quat_wxyz_from_matrix(R))
    np.testing.assert_array_equal(plane_quat_wxyz(R.copy()), first)   # kept, same values
