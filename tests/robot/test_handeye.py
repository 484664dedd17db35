"""Hand-eye: the frame chain by hand, the calibration file, recovery from noisy pairs."""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from photomodel.camera import PinholeCamera
from photomodel.errors import InputError
from photomodel.geometry import invert_transform, make_transform, transform_points
from photomodel.robot import (
    Chessboard,
    base_from_camera,
    calibrate_hand_eye,
    chessboard_pose,
    forward_kinematics,
    hand_eye_error,
    inverse_kinematics,
    load_arm,
    load_hand_eye,
    load_hand_eye_pairs,
    save_hand_eye,
)
from photomodel.robot._handeye import _park_martin

ARM = load_arm()
X_TRUE = make_transform(Rotation.from_euler("xyz", [3.0, -2.0, 91.0], degrees=True).as_matrix(),
                        [25.0, -110.0, 40.0])
Q_CENTRE = np.radians([5.0, 20.0, -20.0, 70.0, 5.0, 95.0, 160.0])


def test_chain_against_a_hand_computed_case() -> None:
    # Hand above the base, pointing down (half turn about x): base = (x, -y, -z) + (100, 0, 500).
    T_base_hand = make_transform(np.diag([1.0, -1.0, -1.0]), [100.0, 0.0, 500.0])
    T_hand_cam1 = make_transform(np.eye(3), [0.0, 50.0, 0.0])  # camera 50 mm along hand y
    T_cam1_model = make_transform(np.eye(3), [0.0, 0.0, 600.0])  # garment 600 mm ahead
    T = base_from_camera(T_base_hand, T_hand_cam1, T_cam1_model)
    # model origin: cam1 (0, 0, 600) -> hand (0, 50, 600) -> base (100, -50, -100)
    np.testing.assert_allclose(T[:3, 3], [100.0, -50.0, -100.0], atol=1e-12)
    np.testing.assert_allclose(T[:3, :3], np.diag([1.0, -1.0, -1.0]), atol=1e-12)
    p = transform_points(T, [[10.0, 0.0, 0.0]])  # model x maps to base x
    np.testing.assert_allclose(p, [[110.0, -50.0, -100.0]], atol=1e-12)


@pytest.mark.parametrize("suffix", [".yaml", ".json", ".xml"])
def test_file_round_trip(tmp_path: Path, suffix: str) -> None:
    path = tmp_path / f"hand_eye{suffix}"
    save_hand_eye(path, X_TRUE, {"method": "park", "residual_mm": 0.3})
    np.testing.assert_allclose(load_hand_eye(path), X_TRUE, atol=1e-12)
    assert [p.name for p in tmp_path.iterdir()] == [path.name]


def test_file_errors(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="not found"):
        load_hand_eye(tmp_path / "missing.yaml")
    path = tmp_path / "other.yaml"
    fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_WRITE)
    fs.write("K", np.eye(3))
    fs.release()
    with pytest.raises(InputError, match="lacks the key T_hand_cam1"):
        load_hand_eye(path)
    bad = X_TRUE.copy()
    bad[:3, :3] *= 2.0
    with pytest.raises(InputError, match="not a rigid transform"):
        save_hand_eye(tmp_path / "bad.yaml", bad)


def _pairs(rng: np.random.Generator, n: int, noise_mm: float,
           noise_deg: float) -> tuple[np.ndarray, np.ndarray, list[np.ndarray]]:
    T_photo = forward_kinematics(ARM, Q_CENTRE)
    T_base_target = T_photo @ X_TRUE @ make_transform(np.eye(3), [0.0, 0.0, 650.0])
    hands, targets, qs = [], [], []
    while len(hands) < n:
        dR = Rotation.from_rotvec(rng.normal(size=3) * np.radians(12.0)).as_matrix()
        result = inverse_kinematics(ARM, T_photo @ make_transform(dR, rng.uniform(-60, 60, 3)),
                                    Q_CENTRE, rng=rng)
        if not result.success:
            continue
        T_hand = forward_kinematics(ARM, result.q)
        noise = make_transform(
            Rotation.from_rotvec(rng.normal(size=3) * np.radians(noise_deg)).as_matrix(),
            rng.normal(0.0, noise_mm, 3))
        hands.append(T_hand)
        targets.append(invert_transform(T_hand @ X_TRUE) @ T_base_target @ noise)
        qs.append(result.q)
    return np.stack(hands), np.stack(targets), qs


def test_recovers_the_mount_without_noise() -> None:
    hands, targets, _ = _pairs(np.random.default_rng(0), 8, 0.0, 0.0)
    result = calibrate_hand_eye(hands, targets)
    err_mm, err_deg = hand_eye_error(result.T_hand_cam1, X_TRUE)
    assert err_mm < 1e-4 and err_deg < 1e-6
    assert result.residual_mm < 1e-4


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_recovers_the_mount_from_noisy_pairs(seed: int) -> None:
    """0.3 mm and 0.05 deg of noise on the target poses, 15 pairs: within 3 mm and 0.2 deg."""
    hands, targets, _ = _pairs(np.random.default_rng(seed), 15, 0.3, 0.05)
    result = calibrate_hand_eye(hands, targets)
    err_mm, err_deg = hand_eye_error(result.T_hand_cam1, X_TRUE)
    assert err_mm < 3.0, err_mm
    assert err_deg < 0.2, err_deg
    assert 0.1 < result.residual_mm < 3.0


@pytest.mark.skipif(not hasattr(cv2, "calibrateHandEye"),
                    reason="this OpenCV lacks cv2.calibrateHandEye (OpenCV 5)")
def test_numpy_park_martin_matches_opencv() -> None:
    hands, targets, _ = _pairs(np.random.default_rng(4), 12, 0.3, 0.05)
    R, t = cv2.calibrateHandEye(list(hands[:, :3, :3]), list(hands[:, :3, 3]),
                                list(targets[:, :3, :3]), list(targets[:, :3, 3]),
                                method=cv2.CALIB_HAND_EYE_PARK)
    ours = _park_martin(hands, targets)
    theirs = make_transform(R, t.ravel())
    err_mm, err_deg = hand_eye_error(ours, theirs)
    assert err_mm < 0.5 and err_deg < 0.02


def test_too_few_pairs_and_unknown_method() -> None:
    hands, targets, _ = _pairs(np.random.default_rng(5), 3, 0.0, 0.0)
    with pytest.raises(InputError, match="at least 3 pairs"):
        calibrate_hand_eye(hands[:2], targets[:2])
    with pytest.raises(InputError, match="unknown hand-eye method"):
        calibrate_hand_eye(hands, targets, method="magic")


def test_pairs_file_joints_and_hand_poses(tmp_path: Path) -> None:
    hands, targets, qs = _pairs(np.random.default_rng(6), 6, 0.0, 0.0)
    pairs = [{"joints_deg": np.degrees(q).tolist(), "T_cam1_target": T.tolist()}
             for q, T in zip(qs[:3], targets[:3], strict=True)]
    pairs += [{"T_base_hand": H.tolist(), "T_cam1_target": T.tolist()}
              for H, T in zip(hands[3:], targets[3:], strict=True)]
    path = tmp_path / "pairs.json"
    path.write_text(json.dumps({"pairs": pairs}))
    loaded = load_hand_eye_pairs(path, ARM)
    np.testing.assert_allclose(loaded.T_base_hand, hands, atol=1e-9)
    pairs[1]["joints_deg"] = pairs[1]["joints_deg"][:6]
    path.write_text(json.dumps({"pairs": pairs}))
    with pytest.raises(InputError, match="pair 1: joints_deg: expected 7 joint angles"):
        load_hand_eye_pairs(path, ARM)


def _render_chessboard(camera: PinholeCamera, board: Chessboard,
                       T_cam_target: np.ndarray) -> np.ndarray:
    """A white image with the board's black squares drawn where the camera sees them."""
    image = np.full((camera.height_px, camera.width_px, 3), 255, np.uint8)
    cols, rows = board.inner_corners
    s = board.square_mm
    rvec = cv2.Rodrigues(T_cam_target[:3, :3])[0]
    for i in range(-1, cols):
        for j in range(-1, rows):
            if (i + j) % 2:
                continue
            quad = np.array([[i, j, 0], [i + 1, j, 0], [i + 1, j + 1, 0], [i, j + 1, 0]],
                            float) * s
            uv, _ = cv2.projectPoints(quad, rvec, T_cam_target[:3, 3], camera.K, camera.dist)
            cv2.fillConvexPoly(image, np.round(uv.reshape(-1, 2) * 16).astype(np.int32), (0,) * 3,
                               lineType=cv2.LINE_AA, shift=4)
    return image


def test_chessboard_pose_from_an_image() -> None:
    camera = PinholeCamera(np.array([[800.0, 0, 320], [0, 800.0, 240], [0, 0, 1]]),
                           np.array([-0.1, 0.05, 0, 0, 0]), 640, 480)
    board = Chessboard((7, 5), 30.0)
    T = make_transform(Rotation.from_euler("xyz", [8.0, -6.0, 3.0], degrees=True).as_matrix(),
                       [-90.0, -60.0, 700.0])
    image = cv2.GaussianBlur(_render_chessboard(camera, board, T), (0, 0), 0.7)
    T_est = chessboard_pose(image, camera, board)
    assert np.linalg.norm(T_est[:3, 3] - T[:3, 3]) < 2.0
    assert Rotation.from_matrix(T_est[:3, :3] @ T[:3, :3].T).magnitude() < np.radians(0.3)
    with pytest.raises(InputError, match="no 7x5 chessboard found"):
        chessboard_pose(np.full_like(image, 255), camera, board, "blank.png")
