"""Rendered chessboard (and ChArUco) views with exact truth, for the calibration tests.

The board is a :class:`~photomodel.sim.PlaneTexture` whose frame is the board's (origin at
the first inner corner, x along the rows, y along the columns) rendered by the simulator's
exact inverse-mapping renderer through distorted cameras, so every corner lands where
:meth:`PinholeCamera.project` puts it, to a small fraction of a pixel.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from photomodel.calibrate import CharucoBoard, Chessboard, Target
from photomodel.camera import PinholeCamera, StereoRig
from photomodel.image import write_image
from photomodel.sim import PlaneTexture, blur, render_view
from photomodel.sim._render import add_sensor_noise

BOARD = Chessboard((9, 6), 25.0)
STATION_DISTANCE_MM = 400.0
CHARUCO_PATTERN = "charuco:9x7:30:22:DICT_4X4_50"
CHARUCO_BOARD = CharucoBoard((9, 7), 30.0, 22.0, "DICT_4X4_50")


@dataclass(frozen=True)
class StereoData:
    pairs: Path
    rig: StereoRig
    poses: list[np.ndarray]


@dataclass(frozen=True)
class StationData:
    images: Path
    plane: Path
    camera: PinholeCamera
    T_cam_plane: np.ndarray




def chessboard_texture(board: Chessboard, px_per_square: int = 32, margin: float = 1.0,
                       surround: int = 4) -> PlaneTexture:
    """The board: black and white squares, a white margin of ``margin`` squares, then
    ``surround`` squares of mid grey. The square beyond the first inner corner is white
    (for 9x6, the one beyond the last black), so :func:`photomodel.calibrate.find_corners`
    numbers the corners as :meth:`Chessboard.object_points` does."""
    cols, rows = board.inner_corners
    p = px_per_square
    pad = int(round((margin + surround) * p))
    white = int(round(margin * p))
    w, h = (cols + 1) * p + 2 * pad, (rows + 1) * p + 2 * pad
    image = np.full((h, w), 128, np.uint8)
    image[pad - white:h - pad + white, pad - white:w - pad + white] = 235
    j, i = np.mgrid[0:rows + 1, 0:cols + 1]
    black = np.kron(((i + j) % 2 == 1).astype(np.uint8), np.ones((p, p), np.uint8))
    board_px = image[pad:h - pad, pad:w - pad]
    board_px[black == 1] = 20
    first = pad + p - 0.5  # the first inner corner: between texture pixels pad + p - 1 and pad + p
    return PlaneTexture(np.repeat(image[..., None], 3, axis=2), np.ones((h, w), np.float32),
                        board.square_mm / p, np.array([first, first]))


def charuco_texture(board: CharucoBoard, px_per_square: int = 60, surround: int = 4
                    ) -> PlaneTexture:
    """A ChArUco board (``cv2.aruco.CharucoBoard.generateImage``, a white margin of one
    square) amid ``surround`` squares of mid grey; its frame is the board's (origin at its
    outer top-left corner)."""
    cols, rows = board.squares
    p = px_per_square
    image = board.cv_board().generateImage(((cols + 2) * p, (rows + 2) * p), marginSize=p)
    image = (20 + (215 / 255) * image.astype(np.float64)).astype(np.uint8)
    image = np.pad(image, surround * p, constant_values=128)
    first = (surround + 1) * p - 0.5  # the board's outer corner, between two texture pixels
    h, w = image.shape
    return PlaneTexture(np.repeat(image[..., None], 3, axis=2), np.ones((h, w), np.float32),
                        board.square_mm / p, np.array([first, first]))


def board_in_view(camera: PinholeCamera, T_cam_board: np.ndarray, board: Target,
                  margin_px: float) -> np.ndarray:
    """Whether the board's inner corners and half a square beyond them lie in the image, the
    board facing the camera; for poses (..., 4, 4), a boolean (...)."""
    corners = board.object_points()
    (x0, y0), (x1, y1) = corners[:, :2].min(axis=0), corners[:, :2].max(axis=0)
    pad = 0.7 * board.square_mm
    outline = np.array([[x0 - pad, y0 - pad, 0], [x1 + pad, y0 - pad, 0],
                        [x1 + pad, y1 + pad, 0], [x0 - pad, y1 + pad, 0]])
    T = np.asarray(T_cam_board, dtype=np.float64)
    pts = np.einsum("...ij,nj->...ni", T[..., :3, :3], np.vstack([outline, corners]))
    pts = pts + T[..., None, :3, 3]
    distance = np.linalg.norm(T[..., :3, 3], axis=-1)
    facing = np.einsum("...i,...i->...", T[..., :3, 2], T[..., :3, 3]) / distance
    with np.errstate(invalid="ignore"):
        uv = camera.project(pts)
    w, h = camera.image_size
    inside = np.all((uv >= margin_px) & (uv <= [w - 1 - margin_px, h - 1 - margin_px]),
                    axis=(-1, -2))
    return inside & np.all(pts[..., 2] > 100, axis=-1) & (facing > np.cos(np.radians(60)))


def board_poses(cameras: list[tuple[PinholeCamera, np.ndarray]], board: Target, n: int,
                rng: int, depth_mm: tuple[float, float] = (450.0, 900.0),
                tilt_deg: float = 40.0) -> list[np.ndarray]:
    """``n`` poses ``T_ref_board`` of the board, well spread, that every camera
    (camera, ``T_cam_ref``) sees whole.

    The board's centre is aimed, in turn for each camera, at the cells of a 3 x 3 grid over
    its image (the corners and edges too, so that the distortion is seen where it is
    largest); tilted by 0.4-1 x ``tilt_deg`` about an axis in the board's plane (steep views
    pin the focal length and the principal point down), turned in-plane up to 25 deg. A cell
    that none of 256 candidates reaches (an image corner the other camera misses) is passed.
    """
    gen = np.random.default_rng(rng)
    centre = board.object_points().mean(axis=0)
    poses: list[np.ndarray] = []
    batch = 256
    for slot in range(50 * n):
        if len(poses) == n:
            break
        aim, T_aim_ref = cameras[slot % len(cameras)]
        w, h = aim.image_size
        cell = (slot // len(cameras)) % 9
        u = w * (0.14 + 0.36 * (cell % 3) + gen.uniform(-0.08, 0.08, batch))
        v = h * (0.14 + 0.36 * (cell // 3) + gen.uniform(-0.08, 0.08, batch))
        z = gen.uniform(*depth_mm, batch)
        rays = np.column_stack([aim.undistort_pixels(np.column_stack([u, v])), np.ones(batch)])
        axis = gen.uniform(0.0, 2 * np.pi, batch)
        tilt = np.radians(gen.uniform(0.4, 1.0, batch) * tilt_deg)[:, None] * np.column_stack(
            [np.cos(axis), np.sin(axis), np.zeros(batch)])
        R = (Rotation.from_rotvec(tilt)
             * Rotation.from_euler("z", gen.uniform(-25.0, 25.0, (batch, 1)), degrees=True)
             ).as_matrix()
        T_aim_board = np.tile(np.eye(4), (batch, 1, 1))
        T_aim_board[:, :3, :3] = R
        T_aim_board[:, :3, 3] = rays * z[:, None] - R @ centre
        T = np.linalg.inv(T_aim_ref) @ T_aim_board
        ok = np.ones(batch, bool)
        for cam, T_cam_ref in cameras:
            ok &= board_in_view(cam, T_cam_ref @ T, board, 3.0)
        if ok.any():
            poses.append(T[int(np.argmax(ok))])
    assert len(poses) == n, f"only {len(poses)} poses found"
    return poses


def render_board(camera: PinholeCamera, T_cam_board: np.ndarray, texture: PlaneTexture,
                 rng: int, noise: float = 1.0, blur_px: float = 0.5) -> np.ndarray:
    """The board as the camera sees it (BGR uint8), with optical blur and sensor noise."""
    image = render_view(camera, T_cam_board, texture, supersample=2)
    return add_sensor_noise(blur(image, blur_px), noise, rng)


def board_texture(board: Target) -> PlaneTexture:
    """The texture of a chessboard or a ChArUco board."""
    return charuco_texture(board) if isinstance(board, CharucoBoard) else chessboard_texture(board)


def write_stereo_pairs(folder: Path, rig: StereoRig, poses: list[np.ndarray],
                       board: Target = BOARD, rng: int = 0) -> Path:
    """``folder/<id>/right.png`` (camera 1) and ``left.png`` of the board at ``poses``
    (``T_cam1_board``)."""
    texture = board_texture(board)
    for k, T in enumerate(poses):
        pair = folder / f"{k:03d}"
        write_image(pair / "right.png", render_board(rig.cam1, T, texture, rng + 2 * k))
        write_image(pair / "left.png", render_board(rig.cam2, rig.T_cam2_cam1 @ T, texture,
                                                    rng + 2 * k + 1))
    return folder


def write_views(folder: Path, camera: PinholeCamera, poses: list[np.ndarray],
                board: Target = BOARD, rng: int = 0) -> Path:
    """``folder/view_<k>.png`` of the board at ``poses`` (``T_cam_board``)."""
    texture = board_texture(board)
    for k, T in enumerate(poses):
        write_image(folder / f"view_{k:03d}.png", render_board(camera, T, texture, rng + k))
    return folder
