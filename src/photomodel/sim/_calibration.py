"""Calibration data with known truth: chessboard views for the stereo rig, the model station
and the hand-eye calibration (what ``photomodel simulate --calibration-views N`` writes).

::

    DIR/calibration/pairs/<id>/right.png      camera 1 of the hand rig  } a board held in front
    DIR/calibration/pairs/<id>/left.png       camera 2                  } of the rig, N pairs
    DIR/calibration/station/views/<id>.png    the model-station camera, N boards held in front
    DIR/calibration/station/plane.png         the board lying flat ON the model plane
    DIR/calibration/handeye/pairs.json        joints (PA10-7C, deg) + camera-1 images, the
    DIR/calibration/handeye/images/<id>.png   format ``photomodel handeye --pairs`` reads
    DIR/calibration/handeye/photo_joints.json the joints at which the scenes were taken
                                              (``photomodel pick --joints-deg``)
    DIR/calibration/truth.json                cameras, T_hand_cam1, board, every T_cam_board
    DIR/calibration/README.txt                what is there and which commands read it

The board (:data:`CALIBRATION_BOARD`): 9 x 6 inner corners, 25 mm squares (10 x 7 squares,
250 x 175 mm) inside a white quiet zone one square wide (300 x 225 mm in all), the board's
frame OpenCV's: origin at the first inner corner (the top-left one of a board seen upright),
x along its rows, y along its columns, z into the board (the printed face is z = 0). 9 x 6 is
OpenCV's classic pattern and the one ``photomodel handeye``'s examples name; 25 mm squares
are 22 px wide at 900 mm (the far end of the hand rig's range: detection stays reliable),
while the whole board covers only about 60 % of the image width at 500 mm and 75 % of the
model station's at 400 mm, so it can be moved into the image corners and still fit. One
board serves every set, so one ``--pattern chessboard:9x6:25`` reads all of them.

Corner order: the square beyond the first inner corner is white, the one beyond the last
black. ``cv2.findChessboardCornersSB`` numbers this board's corners from the first inner corner
(the truth's order, whatever the board's roll); the classic ``cv2.findChessboardCorners``
numbers them from the other end (OpenCV's two detectors read an odd-by-even board from
opposite ends), so its corners must be reversed to match the truth.

Rendering: :func:`render_view_linear` (exact inverse mapping, 2 x 2 supersampling as scenes), the
board's squares drawn on texture pixel boundaries (an edge at texture ``u = k - 0.5``, where
bilinear sampling is symmetric, so the rendered corners sit exactly where
:meth:`PinholeCamera.project` puts them), then :func:`expose` with the paper's conditions
(vignetting, 0.6 px blur, sensor noise of 2 grey levels). Boards held in the air stand in front
of a plain grey wall; the hand-eye board lies on the grey work table.

The plane view: the board lies flat on the model plane with its **printed face in the plane**
(a printed sheet of no thickness), so the station's ``distance_mm`` measured from it is the
camera-to-plane distance, :data:`MODEL_DISTANCE_MM`. A real board of thickness ``t`` lying on
the plane puts its face ``t`` nearer the camera: add ``t`` to what is measured.

Every image has its own generator, ``scene_rng(seed, "calibration", set, index)``.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.spatial.transform import Rotation

from photomodel.calibrate import Chessboard
from photomodel.camera import PinholeCamera, StereoRig
from photomodel.geometry import invert_transform, make_transform
from photomodel.image import write_image
from photomodel.sim._conditions import Conditions, expose
from photomodel.sim._render import Layer, render_view_linear
from photomodel.sim._rigs import MODEL_DISTANCE_MM
from photomodel.sim._textures import TABLE_GREY_BGR, PlaneTexture, uniform_plane

__all__ = [
    "CALIBRATION_BOARD",
    "MAX_CALIBRATION_VIEWS",
    "MIN_CALIBRATION_VIEWS",
    "BoardSpec",
    "calibration_image_count",
    "chessboard_texture",
    "write_calibration",
]

MIN_CALIBRATION_VIEWS = 3
"""Fewest views per set (``photomodel handeye`` needs 3 pairs)."""
MAX_CALIBRATION_VIEWS = 200
"""Most views per set."""

_SUPERSAMPLE = 2
_BLACK, _WHITE = 28.0, 226.0
_HAND_RANGE_MM = (500.0, 900.0)
_STATION_RANGE_MM = (330.0, 600.0)
_MAX_TILT_DEG = 40.0
_MAX_ROLL_DEG = 20.0
_MAX_VIEW_DEG = 50.0  # largest angle between the board's normal and the line of sight
_BORDER_PX = 4.0  # the whole board (quiet zone included) stays this far inside the image


@dataclass(frozen=True)
class BoardSpec(Chessboard):
    """A printed chessboard target: the :class:`~photomodel.calibrate.Chessboard` that
    ``photomodel calibrate`` detects, with the white quiet zone the simulator prints around it.

    Parameters
    ----------
    inner_corners : (int, int)
        Inner corners per row and per column (``(columns, rows)``, OpenCV's ``patternSize``).
    square_mm : float
        Side of a square, mm.
    margin_squares : float
        Width of the white quiet zone around the squares, in squares.
    """

    inner_corners: tuple[int, int] = (9, 6)
    square_mm: float = 25.0
    margin_squares: float = 1.0

    def __post_init__(self) -> None:
        super().__post_init__()
        if not self.margin_squares >= 0:
            raise ValueError("board: expected a non-negative margin")

    def outline_mm(self) -> NDArray[np.float64]:
        """Points (M, 3) along the board's outer edge (quiet zone included), board frame."""
        cols, rows = self.inner_corners
        m = (1.0 + self.margin_squares) * self.square_mm
        x0, y0 = -m, -m
        x1, y1 = (cols - 1) * self.square_mm + m, (rows - 1) * self.square_mm + m
        t = np.linspace(0.0, 1.0, 9)[:, None]
        corners = np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]])
        edges = np.concatenate([a + t * (b - a) for a, b in
                                zip(corners, np.roll(corners, -1, axis=0), strict=True)])
        return np.column_stack([edges, np.zeros(len(edges))])


CALIBRATION_BOARD = BoardSpec()
"""The simulator's calibration target (module docstring)."""


def chessboard_texture(board: BoardSpec = CALIBRATION_BOARD,
                       px_per_square: int = 100) -> PlaneTexture:
    """The board as an opaque texture whose frame is the board's (origin at the first inner
    corner, x along the rows, z into the board).

    Square edges fall on texture pixel boundaries: square ``i`` covers pixels
    ``[m + i n, m + (i + 1) n)`` (``n`` pixels a square, ``m`` of margin), so the first inner
    corner is the boundary at texture ``(m + n - 0.5, m + n - 0.5)``. The square at the first
    inner corner's top left is white, the one beyond the last inner corner black: on such a
    9 x 6 board ``cv2.findChessboardCornersSB`` numbers the corners from the first inner corner
    (the board frame's order), while the classic ``cv2.findChessboardCorners`` numbers them
    from the other end (checked for rolls up to 170 degrees; the two detectors read an
    odd-by-even board from opposite ends whatever its colours).
    """
    if px_per_square < 2:
        raise ValueError(f"px_per_square: expected at least 2, got {px_per_square}")
    cols, rows = board.inner_corners
    n = int(px_per_square)
    m = int(round(board.margin_squares * n))
    squares = np.indices((rows + 1, cols + 1)).sum(axis=0) % 2  # 0 = white
    pattern = np.where(squares == 0, _WHITE, _BLACK).repeat(n, axis=0).repeat(n, axis=1)
    image = np.full(((rows + 1) * n + 2 * m, (cols + 1) * n + 2 * m), _WHITE)
    image[m:m + pattern.shape[0], m:m + pattern.shape[1]] = pattern
    bgr = np.repeat(np.rint(image)[..., None], 3, axis=-1).astype(np.uint8)
    return PlaneTexture(bgr, np.ones(image.shape, np.float32), board.square_mm / n,
                        np.array([m + n - 0.5, m + n - 0.5]))


def calibration_image_count(views: int) -> int:
    """Images :func:`write_calibration` writes for ``views`` views per set."""
    return 0 if views == 0 else 4 * views + 1


# --- Poses ------------------------------------------------------------------------------------


def _fits_many(camera: PinholeCamera, T_cam_board: NDArray[np.float64],
               board: BoardSpec) -> NDArray[np.bool_]:
    """Whether each board pose (..., 4, 4) shows the whole board (quiet zone included) inside
    the image, :data:`_BORDER_PX` from its edges, at most :data:`_MAX_VIEW_DEG` from square on.
    """
    R, t = T_cam_board[..., :3, :3], T_cam_board[..., :3, 3]
    pts = np.einsum("...ij,mj->...mi", R, board.outline_mm()) + t[..., None, :]
    centre = R @ board.centre_mm + t
    cos_view = np.einsum("...i,...i->...", R[..., :, 2], centre) / np.linalg.norm(centre, axis=-1)
    with np.errstate(invalid="ignore"):
        uv = camera.project(pts)
        inside = ((uv >= _BORDER_PX - 0.5)
                  & (uv <= np.array([camera.width_px, camera.height_px]) - 0.5 - _BORDER_PX))
    return (np.all(pts[..., 2] > 50.0, axis=-1) & (cos_view >= np.cos(np.radians(_MAX_VIEW_DEG)))
            & np.all(inside, axis=(-2, -1)))


def _fits(camera: PinholeCamera, T_cam_board: NDArray[np.float64], board: BoardSpec) -> bool:
    """:func:`_fits_many` of one pose (4, 4)."""
    return bool(_fits_many(camera, T_cam_board, board))


def _rays(camera: PinholeCamera, uv: NDArray[np.float64]) -> NDArray[np.float64]:
    """Unit rays (N, 3) through pixels (N, 2)."""
    xy = camera.undistort_pixels(np.asarray(uv, dtype=np.float64).reshape(-1, 2))
    r = np.column_stack([xy, np.ones(len(xy))])
    return r / np.linalg.norm(r, axis=1, keepdims=True)


def _ray(camera: PinholeCamera, uv: NDArray[np.float64]) -> NDArray[np.float64]:
    return _rays(camera, uv)[0]


def _held_pose(camera: PinholeCamera, board: BoardSpec, rng: np.random.Generator, k: int,
               distance_mm: tuple[float, float], n_views: int,
               others: tuple[tuple[PinholeCamera, NDArray[np.float64]], ...] = ()
               ) -> NDArray[np.float64]:
    """``T_cam_board`` (4, 4) of a board held in front of ``camera``, whole in every image.

    View ``k`` of ``n_views``: its distance (camera to the board's centre) in the ``k``-th of
    ``n_views`` strata of ``distance_mm`` (visited in a scrambled order), so the set spans the
    range; tilts up to :data:`_MAX_TILT_DEG` about the board's x and y axes and a roll up to
    :data:`_MAX_ROLL_DEG` about its normal. Among the candidate poses that fit (400 drawn, the
    board's centre aimed at a uniform random pixel), the one pushed farthest towards the
    ``k``-th of the 8 directions to the image's corners and edges (every 9th view: a random
    one), so the set covers the image, corners included. Where no candidate of the stratum fits
    (a board too large for the image at that distance), the distance is drawn from the whole
    range. ``others``: further cameras ``(camera, T_other_cam)`` that must see the board whole
    too.
    """
    lo, hi = distance_mm
    size = np.array([camera.width_px, camera.height_px], dtype=np.float64)
    stratum = (k * 7) % n_views
    ranges = [(lo + (hi - lo) * stratum / n_views, lo + (hi - lo) * (stratum + 1) / n_views)]
    for d_lo, d_hi in ranges + [(lo, hi)] * 10:
        n = 400
        d = rng.uniform(d_lo, d_hi, n)
        uv = rng.uniform(0.0, 1.0, (n, 2)) * size - 0.5
        tilt = rng.uniform(-_MAX_TILT_DEG, _MAX_TILT_DEG, (n, 2))
        roll = rng.uniform(-_MAX_ROLL_DEG, _MAX_ROLL_DEG, n)
        R = (Rotation.from_rotvec(np.column_stack([np.zeros((n, 2)), np.radians(roll)]))
             * Rotation.from_euler("xy", np.radians(tilt))).as_matrix()
        T = np.zeros((n, 4, 4))
        T[:, :3, :3] = R
        T[:, :3, 3] = d[:, None] * _rays(camera, uv) - R @ board.centre_mm
        T[:, 3, 3] = 1.0
        ok = _fits_many(camera, T, board)
        for cam, T_other in others:
            ok &= _fits_many(cam, T_other @ T, board)
        good = np.flatnonzero(ok)
        if len(good):
            break
    else:
        raise RuntimeError("no board pose fits the image (the board is too large for the camera)")
    if k % 9 == 8:
        return T[good[0]]
    angle = 2.0 * np.pi * (k % 9) / 8.0
    direction = np.array([np.cos(angle), np.sin(angle)])
    reach = ((uv[good] + 0.5) / size - 0.5) @ direction
    return T[good[int(np.argmax(reach))]]


# --- Rendering --------------------------------------------------------------------------------


def _wall(distance_mm: float, rng: np.random.Generator) -> tuple[NDArray[np.float64],
                                                                   PlaneTexture]:
    """A plain grey wall facing the camera ``distance_mm`` away: (T_cam_wall, texture)."""
    size = 4.0 * distance_mm
    texture = uniform_plane(TABLE_GREY_BGR, (size, 0.8 * size), mm_per_px=size / 1200.0,
                            rng=rng, noise=2.0, mottle=4.0)
    return make_transform(np.eye(3), [0.0, 0.0, distance_mm]), texture


def _render(camera: PinholeCamera, T_cam_plane: NDArray[np.float64], plane: PlaneTexture,
            T_cam_board: NDArray[np.float64], board_texture: PlaneTexture,
            conditions: Conditions, rng: np.random.Generator) -> NDArray[np.uint8]:
    T_plane_board = invert_transform(T_cam_plane) @ T_cam_board
    view = render_view_linear(camera, T_cam_plane, plane, [Layer(board_texture, T_plane_board)],
                              supersample=_SUPERSAMPLE)
    return expose(view.image, camera, conditions, rng)


# --- Hand-eye ---------------------------------------------------------------------------------


@dataclass(frozen=True)
class _HandEyeView:
    joints_deg: list[float]
    T_base_hand: NDArray[np.float64]
    T_cam1_board: NDArray[np.float64]


def _hand_eye_views(rig: StereoRig, board: BoardSpec, n_views: int, seed: int
                    ) -> tuple[NDArray[np.float64], NDArray[np.float64], list[_HandEyeView],
                               NDArray[np.float64], NDArray[np.float64]]:
    """The simulated cell's mount, the board on the table and ``n_views`` reachable hand poses.

    The board lies on the work table (:class:`CellLayout`'s centre), its x along the table's x;
    camera 1 looks at it from 550-800 mm, its axis tilted up to 35 deg from the table's normal
    in a direction that turns from view to view, rolled up to 25 deg about its axis, the board
    aimed at a random pixel near the image centre. Each camera pose gives a hand pose through
    the true mount; the arm's IK (seeded at the photographing configuration) must reach it and
    camera 1 must see the whole board.

    Returns
    -------
    T_hand_cam1, T_base_board : ndarray (4, 4)
    views : list of _HandEyeView
    T_base_table : ndarray (4, 4)
    q_photo : ndarray (7,)
        The joints (rad) at which the scenes are photographed.
    """
    from photomodel.robot import (
        CellLayout,
        IKSettings,
        forward_kinematics,
        inverse_kinematics,
        load_arm,
    )
    from photomodel.sim._cell_geometry import default_hand_eye, photo_configuration, table_in_base
    from photomodel.sim._dataset import scene_rng
    from photomodel.sim._rigs import hand_table_pose

    arm = load_arm("pa10-7c")
    layout = CellLayout()
    X = default_hand_eye(rig)
    q_photo = photo_configuration(arm, layout, rig, X)
    T_base_table = table_in_base(layout)
    yaw = np.radians(4.0)
    T_table_board = make_transform(Rotation.from_rotvec([0.0, 0.0, yaw]).as_matrix(),
                                   -Rotation.from_rotvec([0.0, 0.0, yaw]).as_matrix()
                                   @ board.centre_mm)
    T_base_board = T_base_table @ T_table_board
    R_photo = (T_base_table @ invert_transform(hand_table_pose(rig)))[:3, :3]  # base <- cam1
    centre_base = T_base_board[:3, :3] @ board.centre_mm + T_base_board[:3, 3]
    cam1 = rig.cam1
    settings = IKSettings(restarts=3)
    views: list[_HandEyeView] = []
    k = 0
    while len(views) < n_views:
        if k > 200 * n_views:
            raise RuntimeError("hand-eye: too few reachable hand poses see the board")
        rng = scene_rng(seed, "calibration", "handeye-pose", k)
        k += 1
        azimuth = 2.0 * np.pi * (len(views) * 0.381966 + rng.uniform(-0.05, 0.05))
        tilt = np.radians(rng.uniform(12.0, 35.0))
        roll = np.radians(rng.uniform(-25.0, 25.0))
        axis = np.array([np.cos(azimuth), np.sin(azimuth), 0.0])
        R = R_photo @ (Rotation.from_rotvec(tilt * axis)
                       * Rotation.from_rotvec([0.0, 0.0, roll])).as_matrix()
        uv = np.array([cam1.width_px, cam1.height_px]) * 0.5 + rng.uniform(-60.0, 60.0, 2)
        d = rng.uniform(550.0, 800.0)
        position = centre_base - d * (R @ _ray(cam1, uv))
        T_base_cam1 = make_transform(R, position)
        if not _fits(cam1, invert_transform(T_base_cam1) @ T_base_board, board):
            continue
        result = inverse_kinematics(arm, T_base_cam1 @ invert_transform(X), q_photo, settings,
                                    rng=rng)
        if not result.success:
            continue
        joints_deg = [float(a) for a in np.degrees(result.q)]
        T_base_hand = forward_kinematics(arm, np.radians(joints_deg))
        T_cam1_board = invert_transform(T_base_hand @ X) @ T_base_board
        if not _fits(cam1, T_cam1_board, board):
            continue
        views.append(_HandEyeView(joints_deg, T_base_hand, T_cam1_board))
    return X, T_base_board, views, T_base_table, q_photo


# --- Writer -----------------------------------------------------------------------------------


def _camera_json(camera: PinholeCamera) -> dict[str, Any]:
    return {"K": camera.K.tolist(), "D": camera.dist.tolist(),
            "image_size": [camera.width_px, camera.height_px]}


_README = """\
Simulated calibration data with its truth (photomodel simulate --calibration-views {n}).

Target: a chessboard of {cols} x {rows} inner corners, {square:g} mm squares, inside a white
quiet zone one square wide; its frame is OpenCV's (origin at the first inner corner, x along
the rows, z into the board). Pattern option: --pattern {pattern}
Corner order: cv2.findChessboardCornersSB reports the corners in the truth's order; the classic
cv2.findChessboardCorners reports them from the other end (reverse them).

pairs/<id>/right.png, left.png    the board held in front of the hand rig (camera 1 = right),
                                  {n} pairs, 500-900 mm, tilted up to 40 deg, over the image
station/views/<id>.png            the board held in front of the model-station camera, {n} views
station/plane.png                 the board lying flat ON the model plane, its printed face in
                                  the plane: the station's distance_mm is measured from it
                                  (a real board of thickness t: add t)
handeye/pairs.json, images/       PA10-7C joint angles (deg) and camera 1's image of a board
                                  lying on the work table, fixed in the base frame, {n} pairs
handeye/photo_joints.json         the arm's joints (deg) when the scenes were photographed
truth.json                        the true cameras (K, D, R, T, image size), T_hand_cam1 (mm),
                                  the board, and every view's true T_cam_board (mm)

Commands that read it (DIR = the dataset directory):
  photomodel calibrate stereo --pairs DIR/calibration/pairs --pattern {pattern} --out stereo.yaml
  photomodel calibrate camera --images DIR/calibration/station/views \\
      --plane DIR/calibration/station/plane.png --pattern {pattern} --out cam.yaml
  photomodel handeye --pairs DIR/calibration/handeye/pairs.json --stereo DIR/stereo.yaml \\
      --out hand_eye.yaml
  photomodel pick --hand-eye hand_eye.yaml --joints-deg <handeye/photo_joints.json> ...
Compare their results with truth.json (and with DIR/stereo.yaml, DIR/model_camera.yaml).
"""


def write_calibration(
    out: str | Path,
    rig: StereoRig,
    station: PinholeCamera,
    views: int,
    seed: int,
    *,
    board: BoardSpec = CALIBRATION_BOARD,
    progress: Callable[[str], None] | None = None,
) -> dict[str, Any]:
    """Write ``out/calibration/`` (module docstring): ``views`` views in each set.

    Parameters
    ----------
    out : path
        The dataset directory (``calibration/`` is made in it).
    rig : StereoRig
        The hand rig (its true calibration; e.g. :func:`hand_stereo_rig`).
    station : PinholeCamera
        The model-station camera (e.g. :func:`model_station_camera`), at
        :data:`MODEL_DISTANCE_MM` from the model plane.
    views : int
        Views per set, :data:`MIN_CALIBRATION_VIEWS` to :data:`MAX_CALIBRATION_VIEWS`.
    seed : int
        The dataset's seed.
    board : BoardSpec
    progress : callable(label), optional
        Called after every image written.

    Returns
    -------
    dict
        The truth (what ``calibration/truth.json`` holds).
    """
    from photomodel.sim._dataset import dumps_json, scene_rng

    if not MIN_CALIBRATION_VIEWS <= views <= MAX_CALIBRATION_VIEWS:
        raise ValueError(f"calibration_views: expected an integer from {MIN_CALIBRATION_VIEWS} "
                         f"to {MAX_CALIBRATION_VIEWS}, got {views}")
    root = Path(out) / "calibration"
    texture = chessboard_texture(board)
    conditions = Conditions()  # the paper's: vignetting, blur, sensor noise

    def done(label: str) -> None:
        if progress is not None:
            progress(label)

    T_cam2_cam1 = rig.T_cam2_cam1
    T_cam1_wall, wall = _wall(1600.0, scene_rng(seed, "calibration", "pairs-wall"))
    pairs: dict[str, Any] = {}
    for k in range(views):
        vid = f"{k:04d}"
        rng = scene_rng(seed, "calibration", "pairs", k)
        T1 = _held_pose(rig.cam1, board, rng, k, _HAND_RANGE_MM, views,
                        ((rig.cam2, T_cam2_cam1),))
        for name, camera, T_c_c1 in (("right", rig.cam1, np.eye(4)),
                                     ("left", rig.cam2, T_cam2_cam1)):
            image = _render(camera, T_c_c1 @ T_cam1_wall, wall, T_c_c1 @ T1, texture,
                            conditions, rng)
            write_image(root / "pairs" / vid / f"{name}.png", image)
        pairs[vid] = {"T_cam1_board": T1.tolist(), "T_cam2_board": (T_cam2_cam1 @ T1).tolist()}
        done(f"calibration pair {vid}")

    T_cam_wall, wall = _wall(1000.0, scene_rng(seed, "calibration", "station-wall"))
    station_views: dict[str, Any] = {}
    for k in range(views):
        vid = f"{k:04d}"
        rng = scene_rng(seed, "calibration", "station", k)
        T = _held_pose(station, board, rng, k, _STATION_RANGE_MM, views)
        image = _render(station, T_cam_wall, wall, T, texture, conditions, rng)
        write_image(root / "station" / "views" / f"{vid}.png", image)
        station_views[vid] = {"T_cam_board": T.tolist()}
        done(f"station view {vid}")

    rng = scene_rng(seed, "calibration", "plane")
    T_cam_plane = make_transform(np.eye(3), [0.0, 0.0, MODEL_DISTANCE_MM])
    plane = uniform_plane(rng=rng)  # the model station's green plane, as in its photos
    angle = np.radians(rng.uniform(-5.0, 5.0))
    R = Rotation.from_rotvec([0.0, 0.0, angle]).as_matrix()
    T_plane_board = make_transform(R, np.append(rng.uniform(-10.0, 10.0, 2), 0.0)
                                   - R @ board.centre_mm)
    T_cam_board = T_cam_plane @ T_plane_board
    write_image(root / "station" / "plane.png",
                _render(station, T_cam_plane, plane, T_cam_board, texture, conditions, rng))
    done("station plane")

    X, T_base_board, he_views, T_base_table, q_photo = _hand_eye_views(rig, board, views,
                                                                        seed)
    table = uniform_plane(TABLE_GREY_BGR, (3000.0, 3000.0), mm_per_px=2.0,
                          rng=scene_rng(seed, "calibration", "handeye-table"), noise=2.0,
                          mottle=5.0)
    handeye_truth: dict[str, Any] = {}
    he_pairs = []
    for k, view in enumerate(he_views):
        vid = f"{k:04d}"
        rng = scene_rng(seed, "calibration", "handeye", k)
        T_cam1_table = invert_transform(view.T_base_hand @ X) @ T_base_table
        image = _render(rig.cam1, T_cam1_table, table, view.T_cam1_board, texture,
                        conditions, rng)
        write_image(root / "handeye" / "images" / f"{vid}.png", image)
        he_pairs.append({"joints_deg": view.joints_deg, "image": f"images/{vid}.png"})
        handeye_truth[vid] = {"joints_deg": view.joints_deg,
                              "T_base_hand": view.T_base_hand.tolist(),
                              "T_cam1_board": view.T_cam1_board.tolist()}
        done(f"hand-eye view {vid}")
    (root / "handeye" / "pairs.json").write_text(dumps_json(
        {"pairs": he_pairs, "chessboard": board.to_json_dict()}))
    photo_joints = [float(a) for a in np.degrees(q_photo)]
    (root / "handeye" / "photo_joints.json").write_text(dumps_json(
        {"joints_deg": photo_joints, "arm": "pa10-7c",
         "note": "the arm's joints when the scenes were photographed (what the robot "
                 "controller reports): photomodel pick --joints-deg"}))

    truth = {
        "board": {**board.to_json_dict(), "margin_squares": board.margin_squares,
                  "pattern": board.pattern,
                  "frame": "origin at the first inner corner, x along the rows, z into the "
                           "board; the printed face is z = 0"},
        "rig": {"K1": rig.cam1.K.tolist(), "D1": rig.cam1.dist.tolist(),
                "K2": rig.cam2.K.tolist(), "D2": rig.cam2.dist.tolist(),
                "R": rig.R.tolist(), "T": rig.T.tolist(),
                "image_size": [rig.cam1.width_px, rig.cam1.height_px]},
        "station": {**_camera_json(station), "distance_mm": MODEL_DISTANCE_MM},
        "T_hand_cam1": X.tolist(),
        "photo_joints_deg": photo_joints,
        "T_base_board": T_base_board.tolist(),
        "arm": "pa10-7c",
        "pairs": pairs,
        "station_views": station_views,
        "station_plane": {"T_cam_board": T_cam_board.tolist(),
                          "distance_mm": MODEL_DISTANCE_MM,
                          "note": "the board lies flat on the model plane, its printed face "
                                  "in the plane"},
        "handeye": handeye_truth,
    }
    (root / "truth.json").write_text(dumps_json(truth))
    cols, rows = board.inner_corners
    (root / "README.txt").write_text(_README.format(n=views, cols=cols, rows=rows,
                                                    square=board.square_mm,
                                                    pattern=board.pattern))
    return truth
