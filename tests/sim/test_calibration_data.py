"""``simulate --calibration-views``: chessboard views whose truth the images agree with.

One small dataset (garment No.3, one scene, 6 views per set) made through the command line;
the checks detect the corners with OpenCV themselves and compare them with the truth's
projection, calibrate a camera from the views, and run ``photomodel handeye`` on the pairs.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import cv2
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from photomodel.cli import main
from photomodel.sim import CALIBRATION_BOARD, write_dataset
from photomodel.sim._calibration import chessboard_texture

VIEWS = 6
BOARD = CALIBRATION_BOARD
SUBPIX = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 50, 1e-4)


@pytest.fixture(scope="module")
def dataset(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("calibration") / "data"
    code = main(["simulate", "--out", str(out), "--garments", "No.3", "--scenes", "1",
                 "--calibration-views", str(VIEWS), "--seed", "3"])
    assert code == 0
    return out


@pytest.fixture(scope="module")
def truth(dataset: Path) -> dict[str, Any]:
    return json.loads((dataset / "calibration" / "truth.json").read_text())


def _projected(T: list[list[float]], K: list[list[float]], D: list[float]) -> np.ndarray:
    T_cam_board = np.asarray(T)
    uv, _ = cv2.projectPoints(BOARD.object_points(), cv2.Rodrigues(T_cam_board[:3, :3])[0],
                              T_cam_board[:3, 3], np.asarray(K), np.asarray(D))
    return uv.reshape(-1, 2)


def _classic(grey: np.ndarray) -> np.ndarray:
    """Inner corners (N, 2) by the classic detector + cornerSubPix, in the board frame's order
    (it reads this board from the other end: see chessboard_texture)."""
    found, corners = cv2.findChessboardCorners(grey, BOARD.inner_corners)
    assert found, "classic detector found no board"
    corners = cv2.cornerSubPix(grey, corners, (5, 5), (-1, -1), SUBPIX)
    return corners.reshape(-1, 2)[::-1].astype(np.float64)


def _sector_based(grey: np.ndarray) -> np.ndarray:
    """Inner corners (N, 2) by ``cv2.findChessboardCornersSB`` (the truth's order)."""
    found, corners = cv2.findChessboardCornersSB(grey, BOARD.inner_corners,
                                                 flags=cv2.CALIB_CB_ACCURACY)
    assert found, "sector-based detector found no board"
    return corners.reshape(-1, 2).astype(np.float64)


def _grey(path: Path) -> np.ndarray:
    grey = cv2.imread(str(path), cv2.IMREAD_GRAYSCALE)
    assert grey is not None, path
    return grey


def _views(dataset: Path, truth: dict[str, Any]) -> list[tuple[Path, Any, Any, Any]]:
    """(image, T_cam_board, K, D) of every view of every set."""
    root = dataset / "calibration"
    rig, station = truth["rig"], truth["station"]
    out = []
    for vid, v in truth["pairs"].items():
        out.append((root / "pairs" / vid / "right.png", v["T_cam1_board"], rig["K1"], rig["D1"]))
        out.append((root / "pairs" / vid / "left.png", v["T_cam2_board"], rig["K2"], rig["D2"]))
    for vid, v in truth["station_views"].items():
        out.append((root / "station" / "views" / f"{vid}.png", v["T_cam_board"], station["K"],
                    station["D"]))
    out.append((root / "station" / "plane.png", truth["station_plane"]["T_cam_board"],
                station["K"], station["D"]))
    for vid, v in truth["handeye"].items():
        out.append((root / "handeye" / "images" / f"{vid}.png", v["T_cam1_board"], rig["K1"],
                    rig["D1"]))
    return out


def test_the_layout_and_the_readme(dataset: Path, truth: dict[str, Any]) -> None:
    root = dataset / "calibration"
    ids = [f"{k:04d}" for k in range(VIEWS)]
    for vid in ids:
        for name in ("right.png", "left.png"):
            image = cv2.imread(str(root / "pairs" / vid / name))
            assert image is not None and image.shape == (480, 640, 3)
        assert (root / "station" / "views" / f"{vid}.png").is_file()
        assert (root / "handeye" / "images" / f"{vid}.png").is_file()
    assert (root / "station" / "plane.png").is_file()
    assert sorted(truth["pairs"]) == sorted(truth["station_views"]) == ids
    assert truth["board"]["inner_corners"] == [9, 6] and truth["board"]["square_mm"] == 25.0
    readme = (root / "README.txt").read_text()
    assert "photomodel calibrate stereo --pairs DIR/calibration/pairs" in readme
    assert "--pattern chessboard:9x6:25" in readme
    manifest = json.loads((dataset / "dataset.json").read_text())
    assert manifest["calibration"]["views"] == VIEWS
    # The truth's cameras are the dataset's calibration files.
    stereo = cv2.FileStorage(str(dataset / "stereo.yaml"), cv2.FILE_STORAGE_READ)
    np.testing.assert_allclose(stereo.getNode("K1").mat(), truth["rig"]["K1"])
    np.testing.assert_allclose(stereo.getNode("T").mat().ravel(), truth["rig"]["T"])
    stereo.release()


def test_the_board_texture_puts_the_first_inner_corner_at_the_origin() -> None:
    texture = chessboard_texture(BOARD)
    u, v = texture.px_from_mm([0.0, 0.0])
    n = round(BOARD.square_mm / texture.mm_per_px)
    assert (u + 0.5) % n == 0 and (v + 0.5) % n == 0   # on a pixel boundary
    grey = texture.image_bgr[..., 0]
    iu, iv = int(u + 0.5), int(v + 0.5)
    # White above-left and below-right of the first corner, black on the other diagonal.
    assert grey[iv - 1, iu - 1] > 200 and grey[iv, iu] > 200
    assert grey[iv - 1, iu] < 50 and grey[iv, iu - 1] < 50
    # A quiet zone of one square all round.
    assert (grey[:n] > 200).all() and (grey[:, :n] > 200).all()
    assert (grey[-n:] > 200).all() and (grey[:, -n:] > 200).all()


def test_detected_corners_agree_with_the_truth(dataset: Path, truth: dict[str, Any]) -> None:
    """Renderer, pixel convention and truth agree: the truth's corners projected through the
    true K and D land on the detected ones (no 0.5 px shift, no flipped numbering)."""
    classic_err, sb_err, bias = [], [], []
    for k, (path, T, K, D) in enumerate(_views(dataset, truth)):
        expected = _projected(T, K, D)
        grey = _grey(path)
        classic = _classic(grey)
        classic_err.append(np.linalg.norm(classic - expected, axis=1))
        bias.append((classic - expected).mean(axis=0))
        assert np.median(classic_err[-1]) < 0.15 and np.max(classic_err[-1]) < 0.5, path
        if k % 3 == 0:   # the slower detector on a third of the views
            sb_err.append(np.linalg.norm(_sector_based(grey) - expected, axis=1))
            assert np.median(sb_err[-1]) < 0.2, path
    assert np.median(np.concatenate(classic_err)) < 0.1
    assert np.median(np.concatenate(sb_err)) < 0.1
    assert np.all(np.abs(np.mean(bias, axis=0)) < 0.02)   # no half-pixel convention error


def test_views_are_varied(truth: dict[str, Any]) -> None:
    T = np.array([v["T_cam1_board"] for v in truth["pairs"].values()])
    centre = T[:, :3, :3] @ BOARD.centre_mm + T[:, :3, 3]
    assert centre[:, 2].min() < 600.0 and centre[:, 2].max() > 800.0
    tilts = np.degrees(np.arccos(np.clip(T[:, 2, 2], -1, 1)))
    assert tilts.max() > 20.0 and tilts.max() <= 60.0
    normals = T[:, :3, 2]
    assert np.linalg.matrix_rank(normals - normals.mean(axis=0), tol=0.05) >= 2


def test_opencv_calibration_recovers_the_focal_length(dataset: Path,
                                                      truth: dict[str, Any]) -> None:
    obj, img = [], []
    for vid in truth["pairs"]:
        corners = _classic(_grey(dataset / "calibration" / "pairs" / vid / "right.png"))
        obj.append(BOARD.object_points().astype(np.float32))
        img.append(corners.astype(np.float32).reshape(-1, 1, 2))
    rms, K, D, _, _ = cv2.calibrateCamera(obj, img, (640, 480), None, None,
                                          flags=cv2.CALIB_FIX_K3)
    K_true = np.asarray(truth["rig"]["K1"])
    assert rms < 0.2
    assert abs(K[0, 0] / K_true[0, 0] - 1) < 0.005 and abs(K[1, 1] / K_true[1, 1] - 1) < 0.005
    assert np.hypot(*(K[:2, 2] - K_true[:2, 2])) < 3.0


def test_the_plane_view_gives_the_station_distance(dataset: Path,
                                                   truth: dict[str, Any]) -> None:
    station = truth["station"]
    corners = _sector_based(_grey(dataset / "calibration" / "station" / "plane.png"))
    ok, rvec, tvec = cv2.solvePnP(BOARD.object_points(), corners, np.asarray(station["K"]),
                                  np.asarray(station["D"]))
    assert ok
    normal = cv2.Rodrigues(rvec)[0][:, 2]
    distance = float(normal @ tvec.ravel())
    assert truth["station_plane"]["distance_mm"] == station["distance_mm"] == 400.0
    assert distance == pytest.approx(400.0, abs=1.0)


def test_hand_eye_pairs_are_reachable_and_rotate_about_several_axes(
        dataset: Path, truth: dict[str, Any]) -> None:
    from photomodel.robot import forward_kinematics, load_arm

    pairs = json.loads((dataset / "calibration" / "handeye" / "pairs.json").read_text())
    assert pairs["chessboard"] == {"inner_corners": [9, 6], "square_mm": 25.0}
    assert len(pairs["pairs"]) == VIEWS
    arm = load_arm("pa10-7c")
    X = np.asarray(truth["T_hand_cam1"])
    T_base_board = np.asarray(truth["T_base_board"])
    hands = []
    for pair, view in zip(pairs["pairs"], truth["handeye"].values(), strict=True):
        q = arm.check_joints(np.radians(pair["joints_deg"]), "joints")
        T_base_hand = forward_kinematics(arm, q)
        np.testing.assert_allclose(T_base_hand, view["T_base_hand"], atol=1e-9)
        np.testing.assert_allclose(T_base_hand @ X @ np.asarray(view["T_cam1_board"]),
                                   T_base_board, atol=1e-6)
        hands.append(T_base_hand)
    R = Rotation.from_matrix(np.array(hands)[:, :3, :3])
    relative = (R[1:] * R[0].inv()).as_rotvec()
    angles = np.degrees(np.linalg.norm(relative, axis=1))
    assert angles.max() > 20.0
    axes = relative / np.linalg.norm(relative, axis=1, keepdims=True)
    assert np.linalg.matrix_rank(axes, tol=0.2) >= 2


def test_photomodel_handeye_recovers_the_mount(dataset: Path, truth: dict[str, Any],
                                               tmp_path: Path,
                                               capsys: pytest.CaptureFixture[str]) -> None:
    from photomodel.robot import hand_eye_error, load_hand_eye

    out = tmp_path / "he.yaml"
    code = main(["handeye", "--pairs", str(dataset / "calibration" / "handeye" / "pairs.json"),
                 "--stereo", str(dataset / "stereo.yaml"), "--out", str(out)])
    capsys.readouterr()
    assert code == 0
    err_mm, err_deg = hand_eye_error(load_hand_eye(out), truth["T_hand_cam1"])
    assert err_mm < 1.5 and err_deg < 0.1


@pytest.mark.parametrize("views", ["2", "201", "-1"])
def test_an_out_of_range_view_count_is_one_clear_error(
        views: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "d"
    code = main(["simulate", "--out", str(out), "--garments", "No.3",
                 "--calibration-views", views])
    captured = capsys.readouterr()
    assert code == 2
    line = captured.err.strip()
    assert line.startswith("photomodel: error: --calibration-views") and "3 to 200" in line
    assert "Traceback" not in captured.err and not out.exists()


def test_write_dataset_checks_the_view_count(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="calibration_views"):
        write_dataset(tmp_path / "d", ["No.3"], calibration_views=1)
    assert not (tmp_path / "d").exists()


def test_poses_are_fixed_by_the_seed() -> None:
    from photomodel.sim import hand_stereo_rig, scene_rng
    from photomodel.sim._calibration import _hand_eye_views, _held_pose

    rig = hand_stereo_rig()

    def held(seed: int) -> np.ndarray:
        return _held_pose(rig.cam1, BOARD, scene_rng(seed, "calibration", "pairs", 2), 2,
                          (500.0, 900.0), 6, ((rig.cam2, rig.T_cam2_cam1),))

    np.testing.assert_array_equal(held(5), held(5))
    assert not np.array_equal(held(5), held(6))
    first = _hand_eye_views(rig, BOARD, 3, 5)[2]
    again = _hand_eye_views(rig, BOARD, 3, 5)[2]
    assert [v.joints_deg for v in first] == [v.joints_deg for v in again]
