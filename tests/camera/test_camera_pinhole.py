"""PinholeCamera and StereoRig against OpenCV, and the exactness of the distortion inverse."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from photomodel.camera import PinholeCamera, StereoRig
from photomodel.errors import InputError
from photomodel.geometry import make_transform

K_TEST = np.array([[801.2, 0.0, 322.1], [0.0, 795.4, 238.4], [0.0, 0.0, 1.0]])

# Non-zero distortion for each model size OpenCV knows (k1 k2 p1 p2 k3 [k4 k5 k6 [s1..s4]]).
DIST_5 = np.array([-0.21, 0.07, 0.0013, -0.0011, -0.012])
DIST_8 = np.array([-0.21, 0.07, 0.0013, -0.0011, -0.012, 0.031, -0.004, 0.0021])
DIST_12 = np.array([-0.21, 0.07, 0.0013, -0.0011, -0.012, 0.031, -0.004, 0.0021,
                    0.0017, -0.0008, -0.0012, 0.0005])
DISTORTIONS = {"5": DIST_5, "8": DIST_8, "12": DIST_12}

WIDTH, HEIGHT = 640, 480


def _camera(dist: np.ndarray) -> PinholeCamera:
    return PinholeCamera(K_TEST, dist, WIDTH, HEIGHT)


def _points_in_front(n: int, seed: int) -> np.ndarray:
    """Points (n, 3) in front of the camera, inside its field of view, mm."""
    rng = np.random.default_rng(seed)
    xy = np.column_stack([rng.uniform(-0.38, 0.38, n), rng.uniform(-0.29, 0.29, n)])
    z = rng.uniform(150.0, 2500.0, n)
    return np.column_stack([xy * z[:, None], z])


def _cv_project(points: np.ndarray, K: np.ndarray, dist: np.ndarray,
                R: np.ndarray | None = None, t: np.ndarray | None = None) -> np.ndarray:
    rvec = np.zeros(3) if R is None else cv2.Rodrigues(R)[0]
    tvec = np.zeros(3) if t is None else np.asarray(t, dtype=np.float64)
    uv, _ = cv2.projectPoints(points.reshape(-1, 1, 3), rvec, tvec, K, dist)
    return uv.reshape(-1, 2)


@pytest.mark.parametrize("n_coeffs", sorted(DISTORTIONS))
def test_project_matches_cv2_project_points(n_coeffs: str) -> None:
    dist = DISTORTIONS[n_coeffs]
    camera = _camera(dist)
    points = _points_in_front(2000, seed=int(n_coeffs))
    uv = camera.project(points)
    expected = _cv_project(points, K_TEST, dist)
    assert uv.shape == (2000, 2)
    np.testing.assert_allclose(uv, expected, rtol=0, atol=1e-6)


def test_project_differs_when_distortion_is_dropped() -> None:
    """The coefficients are honoured: dropping them moves points by many pixels."""
    points = _points_in_front(200, seed=3)
    with_dist = _camera(DIST_5).project(points)
    without = _camera(np.zeros(5)).project(points)
    assert np.max(np.linalg.norm(with_dist - without, axis=1)) > 5.0


def test_project_keeps_leading_shape() -> None:
    camera = _camera(DIST_8)
    points = _points_in_front(12, seed=4).reshape(3, 4, 3)
    uv = camera.project(points)
    assert uv.shape == (3, 4, 2)
    np.testing.assert_allclose(uv.reshape(-1, 2), camera.project(points.reshape(-1, 3)),
                               rtol=0, atol=1e-12)


def test_project_principal_point_and_focal_length() -> None:
    camera = PinholeCamera(K_TEST, np.zeros(5))
    uv = camera.project(np.array([[0.0, 0.0, 500.0], [50.0, -25.0, 500.0]]))
    np.testing.assert_allclose(uv[0], [322.1, 238.4], atol=1e-12)
    np.testing.assert_allclose(uv[1], [322.1 + 801.2 * 0.1, 238.4 - 795.4 * 0.05], atol=1e-9)


def test_points_at_or_behind_the_camera_give_nan() -> None:
    camera = _camera(DIST_5)
    points = np.array([[10.0, 5.0, -300.0], [0.0, 0.0, 0.0], [1.0, 2.0, 0.0],
                       [10.0, 5.0, 300.0]])
    uv = camera.project(points)
    assert np.isnan(uv[:3]).all()
    assert np.isfinite(uv[3]).all()


@pytest.mark.parametrize("n_coeffs", sorted(DISTORTIONS))
@settings(max_examples=150, deadline=None)
@given(
    x=st.floats(-0.4, 0.4),
    y=st.floats(-0.3, 0.3),
    z=st.floats(50.0, 5000.0),
)
def test_undistort_pixels_inverts_project(n_coeffs: str, x: float, y: float, z: float) -> None:
    camera = _camera(DISTORTIONS[n_coeffs])
    point = np.array([[x * z, y * z, z]])
    uv = camera.project(point)
    assume(0.0 <= uv[0, 0] <= WIDTH - 1 and 0.0 <= uv[0, 1] <= HEIGHT - 1)
    xy = camera.undistort_pixels(uv)
    assert xy.shape == (1, 2)
    np.testing.assert_allclose(xy[0], [x, y], rtol=0, atol=1e-6)


@pytest.mark.parametrize("n_coeffs", sorted(DISTORTIONS))
def test_undistort_pixels_inverts_project_over_the_whole_image(n_coeffs: str) -> None:
    """Every pixel of the image, including the corners where distortion is strongest."""
    camera = _camera(DISTORTIONS[n_coeffs])
    vv, uu = np.mgrid[0:HEIGHT:7, 0:WIDTH:7]
    uv = np.column_stack([uu.ravel(), vv.ravel()]).astype(np.float64)
    uv = np.concatenate([uv, [[0.0, 0.0], [WIDTH - 1, HEIGHT - 1], [0.0, HEIGHT - 1]]])
    xy = camera.undistort_pixels(uv)
    back = camera.project(np.column_stack([xy, np.ones(len(xy))]))
    np.testing.assert_allclose(back, uv, rtol=0, atol=1e-6)


def test_undistort_pixels_beats_plain_opencv_for_a_strong_lens() -> None:
    """The docstring's claim: exact where cv2.undistortPoints alone is not."""
    dist = np.array([-0.42, 0.21, 0.002, -0.0015, -0.05])
    camera = _camera(dist)
    uv = np.array([[2.0, 3.0], [637.0, 2.0], [630.0, 476.0], [5.0, 470.0]])
    xy = camera.undistort_pixels(uv)
    back = camera.project(np.column_stack([xy, np.ones(len(xy))]))
    np.testing.assert_allclose(back, uv, rtol=0, atol=1e-6)


def test_undistort_pixels_without_distortion_is_the_inverse_intrinsics() -> None:
    camera = PinholeCamera(K_TEST, np.zeros(0), WIDTH, HEIGHT)
    uv = np.array([[322.1, 238.4], [0.0, 0.0], [639.0, 479.0]])
    xy = camera.undistort_pixels(uv)
    expected = (np.column_stack([uv, np.ones(3)]) @ np.linalg.inv(K_TEST).T)[:, :2]
    np.testing.assert_allclose(xy, expected, rtol=0, atol=1e-12)


def test_undistort_pixels_with_skew_and_distortion_inverts_project() -> None:
    K = K_TEST.copy()
    K[0, 1] = 1.5
    camera = PinholeCamera(K, DIST_5, WIDTH, HEIGHT)
    points = _points_in_front(300, seed=8)
    xy = camera.undistort_pixels(camera.project(points))
    np.testing.assert_allclose(xy, points[:, :2] / points[:, 2:], rtol=0, atol=1e-9)


def test_undistort_pixels_with_skew_and_no_distortion_inverts_project() -> None:
    K = K_TEST.copy()
    K[0, 1] = 1.5
    camera = PinholeCamera(K, np.zeros(5), WIDTH, HEIGHT)
    points = _points_in_front(300, seed=9)
    xy = camera.undistort_pixels(camera.project(points))
    np.testing.assert_allclose(xy, points[:, :2] / points[:, 2:], rtol=0, atol=1e-9)


# --- validation ----------------------------------------------------------------------------


@pytest.mark.parametrize(
    "K",
    [
        np.eye(2),
        np.ones((3, 4)),
        np.ones(9),
        np.array([[-800.0, 0, 320], [0, 800, 240], [0, 0, 1]]),
        np.array([[800.0, 0, 320], [0, 0.0, 240], [0, 0, 1]]),
        np.array([[np.nan, 0, 320], [0, 800, 240], [0, 0, 1]]),
        np.array([[800.0, 0, np.inf], [0, 800, 240], [0, 0, 1]]),
    ],
    ids=["2x2", "3x4", "flat9", "negative-fx", "zero-fy", "nan", "inf"],
)
def test_invalid_K_raises_value_error(K: np.ndarray) -> None:
    with pytest.raises(ValueError, match="K"):
        PinholeCamera(K, np.zeros(5))


@pytest.mark.parametrize("entry", [(1, 0), (2, 0), (2, 2)])
def test_K_not_upper_triangular_with_unit_corner_raises(entry: tuple[int, int]) -> None:
    K = K_TEST.copy()
    K[entry] = 2.0 if entry == (2, 2) else 5.0
    with pytest.raises(ValueError, match="K"):
        PinholeCamera(K, np.zeros(5))


@pytest.mark.parametrize("n", [1, 2, 3, 6, 7, 9, 13, 15])
def test_wrong_number_of_distortion_coefficients_raises(n: int) -> None:
    with pytest.raises(ValueError, match="dist"):
        PinholeCamera(K_TEST, np.full(n, 0.01))


def test_tilted_sensor_terms_are_rejected() -> None:
    dist = np.zeros(14)
    dist[12] = 0.01
    with pytest.raises(ValueError, match="dist"):
        PinholeCamera(K_TEST, dist)


@pytest.mark.parametrize("n", [0, 4, 5, 8, 12])
def test_valid_distortion_sizes_are_accepted_and_padded(n: int) -> None:
    dist = np.linspace(0.001, 0.002, n)
    camera = PinholeCamera(K_TEST, dist)
    assert camera.dist.shape == (n,)
    assert camera.distortion12.shape == (12,)
    np.testing.assert_array_equal(camera.distortion12[:n], dist)
    assert not camera.distortion12[n:].any()
    assert camera.has_distortion == (n > 0)


def test_fourteen_coefficients_with_zero_tilt_equal_twelve() -> None:
    camera = PinholeCamera(K_TEST, np.concatenate([DIST_12, [0.0, 0.0]]))
    np.testing.assert_array_equal(camera.dist, DIST_12)
    points = _points_in_front(50, seed=5)
    np.testing.assert_allclose(camera.project(points), _camera(DIST_12).project(points),
                               rtol=0, atol=1e-12)


# --- check_image ---------------------------------------------------------------------------


def test_check_image_accepts_the_calibrated_size() -> None:
    _camera(DIST_5).check_image(np.zeros((HEIGHT, WIDTH, 3), np.uint8), "right.png")


@pytest.mark.parametrize("shape", [(WIDTH, HEIGHT, 3), (HEIGHT, WIDTH + 1, 3), (240, 320)])
def test_check_image_rejects_another_size_naming_the_source(shape: tuple[int, ...]) -> None:
    image = np.zeros(shape, np.uint8)
    with pytest.raises(InputError) as info:
        _camera(DIST_5).check_image(image, "scenes/0007/right.png")
    message = str(info.value)
    assert message.startswith("scenes/0007/right.png")
    assert f"{shape[1]}x{shape[0]}" in message
    assert f"{WIDTH}x{HEIGHT}" in message
    assert info.value.source == "scenes/0007/right.png"


def test_check_image_without_calibrated_size_accepts_any_plausible_size() -> None:
    camera = PinholeCamera(K_TEST, DIST_5)
    camera.check_image(np.zeros((170, 230, 3), np.uint8), "x.png")
    with pytest.raises(InputError, match="more than 20 x this 23x17 image"):
        camera.check_image(np.zeros((17, 23, 3), np.uint8), "x.png")


# --- StereoRig -----------------------------------------------------------------------------


def _rig() -> StereoRig:
    R = cv2.Rodrigues(np.array([0.02, -0.17, 0.01]))[0]
    T = np.array([119.5, -0.8, 10.5])
    cam2 = PinholeCamera(np.array([[798.4, 0, 317.6], [0, 798.9, 241.3], [0, 0, 1]]), DIST_8,
                         WIDTH, HEIGHT)
    return StereoRig(_camera(DIST_5), cam2, R, T)


def _rot_z(angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def test_stereo_project_poses_matches_cv2_in_both_cameras() -> None:
    rig = _rig()
    rng = np.random.default_rng(6)
    poses = np.stack([make_transform(_rot_z(a), [x, y, z]) for a, x, y, z in
                      zip(rng.uniform(-1, 1, 5), rng.uniform(-80, 80, 5),
                          rng.uniform(-60, 60, 5), rng.uniform(600, 800, 5), strict=True)])
    pts = np.column_stack([rng.uniform(-100, 100, (40, 2)), np.zeros(40)])
    uv1, uv2 = rig.project_poses(poses, pts)
    assert uv1.shape == uv2.shape == (5, 40, 2)
    for p in range(5):
        R, t = poses[p, :3, :3], poses[p, :3, 3]
        np.testing.assert_allclose(uv1[p], _cv_project(pts, rig.cam1.K, rig.cam1.dist, R, t),
                                   rtol=0, atol=1e-6)
        # X2 = R X1 + T: camera 2 sees the model through T_cam2_cam1 @ T_cam1_model.
        T21 = rig.T_cam2_cam1 @ poses[p]
        np.testing.assert_allclose(
            uv2[p], _cv_project(pts, rig.cam2.K, rig.cam2.dist, T21[:3, :3], T21[:3, 3]),
            rtol=0, atol=1e-6)


def test_stereo_single_pose_is_squeezed() -> None:
    rig = _rig()
    pose = make_transform(_rot_z(0.3), [10.0, -5.0, 700.0])
    pts = np.array([[0.0, 0.0, 0.0], [30.0, 10.0, 0.0]])
    uv1, uv2 = rig.project_poses(pose, pts)
    assert uv1.shape == uv2.shape == (2, 2)
    uv1_b, uv2_b = rig.project_poses(pose[None], pts)
    np.testing.assert_array_equal(uv1, uv1_b[0])
    np.testing.assert_array_equal(uv2, uv2_b[0])


def test_stereo_T_cam2_cam1_maps_camera1_to_camera2() -> None:
    rig = _rig()
    X1 = np.array([12.0, -7.0, 650.0])
    X2 = rig.R @ X1 + rig.T
    np.testing.assert_allclose((rig.T_cam2_cam1 @ np.append(X1, 1.0))[:3], X2, atol=1e-12)


def test_stereo_points_behind_a_camera_give_nan() -> None:
    rig = _rig()
    uv1, uv2 = rig.project_poses(np.eye(4), np.array([[0.0, 0.0, -100.0], [0, 0, 500.0]]))
    assert np.isnan(uv1[0]).all() and np.isnan(uv2[0]).all()
    assert np.isfinite(uv1[1]).all() and np.isfinite(uv2[1]).all()


@pytest.mark.parametrize(
    "R",
    [np.diag([1.0, 1.0, -1.0]), 2.0 * np.eye(3), np.array([[1.0, 0.1, 0], [0, 1, 0], [0, 0, 1]])],
    ids=["reflection", "scaled", "sheared"],
)
def test_stereo_rejects_non_rotation(R: np.ndarray) -> None:
    with pytest.raises(ValueError, match="R"):
        StereoRig(_camera(DIST_5), _camera(DIST_5), R, np.zeros(3))


def test_stereo_facing_plane_is_square_to_the_bisector_of_the_optical_axes() -> None:
    rig = _rig()
    R_face = rig.R_cam1_facing
    np.testing.assert_allclose(R_face.T @ R_face, np.eye(3), atol=1e-12)
    assert np.linalg.det(R_face) == pytest.approx(1.0)
    axis2_in_cam1 = rig.R.T @ np.array([0.0, 0.0, 1.0])
    bisector = (np.array([0.0, 0.0, 1.0]) + axis2_in_cam1) / 2
    np.testing.assert_allclose(R_face[:, 2], bisector / np.linalg.norm(bisector), atol=1e-12)
    # Half the vergence from each optical axis; x is camera 1's x projected on the plane.
    half = np.degrees(np.arccos(R_face[2, 2]))
    vergence = np.degrees(np.arccos(axis2_in_cam1[2]))
    assert half == pytest.approx(vergence / 2, abs=1e-9) and half > 4
    assert np.cross([1.0, 0.0, 0.0], R_face[:, 2]) @ R_face[:, 0] == pytest.approx(0.0, abs=1e-12)
    assert R_face[0, 0] > 0.99


def test_stereo_facing_plane_of_parallel_cameras_is_square_to_camera_1() -> None:
    rig = StereoRig(_camera(DIST_5), _camera(DIST_5), np.eye(3), np.array([-120.0, 0, 0]))
    np.testing.assert_allclose(rig.R_cam1_facing, np.eye(3), atol=1e-12)


def test_stereo_calibration_key_tells_rigs_apart_by_their_calibration() -> None:
    rig = StereoRig(_camera(DIST_5), _camera(DIST_5), np.eye(3), np.array([-120.0, 0, 0]))
    same = StereoRig(_camera(DIST_5), _camera(DIST_5), np.eye(3), np.array([-120.0, 0, 0]))
    moved = StereoRig(_camera(DIST_5), _camera(DIST_5), np.eye(3), np.array([-121.0, 0, 0]))
    assert rig.calibration_key == same.calibration_key
    assert rig.calibration_key != moved.calibration_key
    assert hash(rig.calibration_key) == hash(same.calibration_key)
