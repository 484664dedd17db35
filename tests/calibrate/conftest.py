"""Rendered calibration data shared by the calibration tests (made once per session)."""

from __future__ import annotations

import numpy as np
import pytest
from calib_helpers import (
    BOARD,
    CHARUCO_BOARD,
    STATION_DISTANCE_MM,
    StationData,
    StereoData,
    board_poses,
    chessboard_texture,
    render_board,
    write_stereo_pairs,
)
from calib_helpers import write_views as write_camera_views

from photomodel.geometry import make_transform
from photomodel.image import write_image
from photomodel.sim import hand_stereo_rig, model_station_camera


@pytest.fixture(scope="session")
def stereo_data(tmp_path_factory: pytest.TempPathFactory) -> StereoData:
    """15 pairs of a 9x6 board (25 mm squares) through the simulated hand rig (distorted)."""
    rig = hand_stereo_rig()
    poses = board_poses([(rig.cam1, np.eye(4)), (rig.cam2, rig.T_cam2_cam1)], BOARD, 15, 3)
    folder = write_stereo_pairs(tmp_path_factory.mktemp("calibration") / "pairs", rig, poses,
                                rng=300)
    return StereoData(folder, rig, poses)


@pytest.fixture(scope="session")
def charuco_data(tmp_path_factory: pytest.TempPathFactory) -> StereoData:
    """15 pairs of a 9x7 ChArUco board (30 mm squares, 22 mm 4x4 markers) through the rig."""
    rig = hand_stereo_rig()
    poses = board_poses([(rig.cam1, np.eye(4)), (rig.cam2, rig.T_cam2_cam1)], CHARUCO_BOARD,
                        15, 3, depth_mm=(400.0, 750.0))
    folder = write_stereo_pairs(tmp_path_factory.mktemp("charuco") / "pairs", rig, poses,
                                CHARUCO_BOARD, rng=300)
    return StereoData(folder, rig, poses)


@pytest.fixture(scope="session")
def station_data(tmp_path_factory: pytest.TempPathFactory) -> StationData:
    """12 views of the board through the model station's camera, and the board lying on a
    plane 400 mm away on the optical axis, tilted 4 deg (so that the distance along the axis
    and the perpendicular one differ)."""
    camera = model_station_camera()
    poses = board_poses([(camera, np.eye(4))], BOARD, 12, 5, depth_mm=(300.0, 550.0))
    root = tmp_path_factory.mktemp("station")
    images = write_camera_views(root / "views", camera, poses, rng=500)
    tilt = np.radians(4.0)
    R = np.array([[1.0, 0.0, 0.0], [0.0, np.cos(tilt), -np.sin(tilt)],
                  [0.0, np.sin(tilt), np.cos(tilt)]])
    T_cam_plane = make_transform(R, [0.0, 0.0, STATION_DISTANCE_MM])
    centre = np.array([4 * BOARD.square_mm, 2.5 * BOARD.square_mm, 0.0])
    c, s = np.cos(0.3), np.sin(0.3)
    R_plane_board = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    T_plane_board = make_transform(R_plane_board, np.array([15.0, -10.0, 0.0])
                                   - R_plane_board @ centre)
    plane = root / "plane.png"
    write_image(plane, render_board(camera, T_cam_plane @ T_plane_board,
                                    chessboard_texture(BOARD), 999))
    return StationData(images, plane, camera, T_cam_plane)
