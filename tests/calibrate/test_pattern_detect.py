"""The target (``--pattern``) and the corner detector, against rendered truth."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from calib_helpers import BOARD, board_in_view, charuco_texture, chessboard_texture, render_board
from scipy.spatial.transform import Rotation

from photomodel.calibrate import (
    CharucoBoard,
    Chessboard,
    find_corners,
    parse_pattern,
    plane_distance,
)
from photomodel.calibrate._detect import _canonical
from photomodel.errors import InputError
from photomodel.geometry import make_transform
from photomodel.sim import hand_stereo_rig, model_station_camera


def test_parse_pattern_reads_inner_corners_and_square_size() -> None:
    board = parse_pattern("chessboard:9x6:25")
    assert board == Chessboard((9, 6), 25.0)
    assert board.n_corners == 54 and not board.symmetric and board.name == "9x6 chessboard"
    assert parse_pattern(" chessboard:7X5:22.5 ").square_mm == 22.5
    assert Chessboard((7, 5), 20.0).symmetric


@pytest.mark.parametrize(("text", "message"), [
    ("chess:9x6:25", "expected chessboard:COLSxROWS:SQUARE_MM"),
    ("chessboard:9x6", "expected chessboard:COLSxROWS:SQUARE_MM"),
    ("chessboard:9x1:25", "expected 2 to 200 inner corners a side, got 9x1"),
    ("chessboard:9x6:0", "expected a square size above 0"),
    ("chessboard:9x6:1e9", "expected a square size above 0 and at most 1000 mm"),
    ("charuco:9x6:25:18", "expected charuco:COLSxROWS:SQUARE_MM:MARKER_MM:DICT"),
    ("charuco:9x6:25:18:DICT_9X9_1", "unknown ArUco dictionary 'DICT_9X9_1'"),
    ("charuco:9x6:25:30:DICT_5X5_100", "a smaller marker, got 25 and 30 mm"),
    ("charuco:30x20:25:18:DICT_4X4_50", "needs 300 markers, more than DICT_4X4_50's 50"),
])
def test_parse_pattern_refuses_malformed_text(text: str, message: str) -> None:
    with pytest.raises(InputError, match=message) as info:
        parse_pattern(text)
    assert info.value.source == "--pattern"


def test_the_robot_package_uses_the_same_target() -> None:
    import photomodel.calibrate as calibrate
    import photomodel.robot as robot

    assert robot.Chessboard is calibrate.Chessboard
    assert robot.chessboard_pose is calibrate.chessboard_pose


def _truth(camera, T, board=BOARD) -> np.ndarray:  # type: ignore[no-untyped-def]
    return camera.project(board.object_points() @ T[:3, :3].T + T[:3, 3])


def test_corners_are_found_to_a_tenth_of_a_pixel() -> None:
    camera = hand_stereo_rig().cam1
    texture = chessboard_texture(BOARD)
    for k, (angles, position) in enumerate([((0.3, 0.1, 0.2), (-120.0, -60.0, 600.0)),
                                            ((-0.5, 0.4, -0.3), (-120.0, -40.0, 560.0)),
                                            ((0.2, -0.6, 2.8), (60.0, 90.0, 700.0))]):
        T = make_transform(Rotation.from_rotvec(angles).as_matrix(), position)
        assert board_in_view(camera, T, BOARD, 3.0)
        image = render_board(camera, T, texture, k)
        detection = find_corners(image, BOARD)
        assert detection.found and detection.reason == ""
        corners = detection.corners
        assert corners is not None
        error = np.sqrt(np.mean(np.sum((corners - _truth(camera, T)) ** 2, axis=-1)))
        assert error < 0.1, (k, error)  # in the board frame's order, to a tenth of a pixel
        # the classic detector numbers a 9x6 board from the other end; put in order, its
        # corners are the same
        grey = cv2.cvtColor(image, cv2.COLOR_BGR2GRAY)
        found, classic = cv2.findChessboardCorners(grey, BOARD.inner_corners)
        assert found
        classic = classic.reshape(-1, 2).astype(np.float64)
        assert np.abs(classic[::-1] - corners).max() < 1.0
        assert np.abs(_canonical(grey, classic, BOARD) - corners).max() < 1.0


def test_a_view_without_the_board_says_so() -> None:
    detection = find_corners(np.full((480, 640), 200, np.uint8), BOARD)
    assert not detection.found and detection.reason == "no 9x6 chessboard found"


def test_a_symmetric_board_is_numbered_from_the_top_left() -> None:
    board = Chessboard((7, 5), 25.0)
    camera = hand_stereo_rig().cam1
    texture = chessboard_texture(board)
    for turn in (0.1, np.pi + 0.1):  # the same board turned by 180 degrees looks the same
        c, s = np.cos(turn), np.sin(turn)
        centre = np.array([75.0, 50.0, 0.0])
        R = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
        T = make_transform(R, np.array([0.0, 0.0, 600.0]) - R @ centre)
        corners = find_corners(render_board(camera, T, texture, 1), board).corners
        assert corners is not None and corners[0].sum() < corners[-1].sum()


def test_plane_distance_is_the_planes_depth_on_the_optical_axis() -> None:
    camera = model_station_camera()
    tilt = np.radians(6.0)
    R = np.array([[np.cos(tilt), 0.0, np.sin(tilt)], [0.0, 1.0, 0.0],
                  [-np.sin(tilt), 0.0, np.cos(tilt)]])
    T_cam_plane = make_transform(R, [0.0, 0.0, 400.0])  # meets the axis at z = 400
    T_plane_board = make_transform(np.eye(3), [-80.0, -50.0, 0.0])
    T = T_cam_plane @ T_plane_board
    corners = _truth(camera, T)
    for order in (corners, corners[::-1]):  # either numbering: the normal's sign is fixed
        plane = plane_distance(order, camera, BOARD)
        assert plane.distance_mm == pytest.approx(400.0, abs=1e-6)
        assert plane.normal_distance_mm == pytest.approx(400.0 * np.cos(tilt), abs=1e-6)
        assert plane.tilt_deg == pytest.approx(6.0, abs=1e-6)
        assert plane.rms_px < 1e-6
    thick = plane_distance(corners, camera, BOARD, thickness_mm=3.0)
    assert thick.distance_mm == pytest.approx(400.0 + 3.0 / np.cos(tilt), abs=1e-6)


CHARUCO = CharucoBoard((11, 8), 20.0, 15.0, "DICT_5X5_100")


def test_parse_a_charuco_pattern() -> None:
    board = parse_pattern("charuco:11x8:20:15:dict_5x5_100")
    assert board == CHARUCO and board.n_corners == 70
    assert board.name == "11x8 ChArUco board"


def test_charuco_corners_are_found_with_their_ids_even_in_part() -> None:
    camera = hand_stereo_rig().cam1
    texture = charuco_texture(CHARUCO)
    counts = []
    # the whole board, then a board partly out of the image
    for k, position in enumerate([(-110.0, -80.0, 600.0), (150.0, -80.0, 600.0)]):
        T = make_transform(Rotation.from_rotvec([0.3, -0.2, 0.1]).as_matrix(), position)
        detection = find_corners(render_board(camera, T, texture, k), CHARUCO)
        assert detection.found and detection.ids is not None
        points = detection.object_points(CHARUCO)
        truth = camera.project(points @ T[:3, :3].T + T[:3, 3])
        error = np.sqrt(np.mean(np.sum((detection.corners - truth) ** 2, axis=-1)))
        assert error < 0.1, (k, error)
        counts.append(len(detection.ids))
    assert counts[0] > 50 and 10 < counts[1] < counts[0]


def test_plane_distance_from_part_of_a_charuco_board() -> None:
    camera = model_station_camera()
    T = make_transform(np.eye(3), [-100.0, -80.0, 400.0])
    ids = np.arange(10, 40)
    corners = camera.project(CHARUCO.object_points()[ids] + T[:3, 3])
    plane = plane_distance(corners, camera, CHARUCO, ids=ids)
    assert plane.distance_mm == pytest.approx(400.0, abs=1e-6) and plane.tilt_deg < 1e-6
