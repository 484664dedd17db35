"""Finding a chessboard's inner corners in an image, to a fraction of a pixel.

:func:`find_corners` finds the board with OpenCV's sector-based detector
(``cv2.findChessboardCornersSB`` with ``CALIB_CB_EXHAUSTIVE | CALIB_CB_ACCURACY``, the more
robust of the two, to blur, noise and steep views), falling back on the classic
``cv2.findChessboardCorners``; either's corners are then refined by ``cv2.cornerSubPix`` (a
window of about 0.4 square), which brings even the sector detector's corners several times
closer to the truth (docs/method/calibrate.md). Corners are (u, v) pixels with the origin at
the centre of the top-left pixel, in the order of :meth:`Chessboard.object_points`.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
from numpy.typing import NDArray

from photomodel.calibrate._pattern import CharucoBoard, Chessboard, Target
from photomodel.camera import PinholeCamera
from photomodel.errors import InputError
from photomodel.geometry import make_transform

__all__ = ["MIN_CHARUCO_CORNERS", "Detection", "chessboard_pose", "find_corners",
           "pose_from_corners"]

MIN_CHARUCO_CORNERS = 6
"""Fewest identified corners a ChArUco view needs to count (a pose needs 4 not on a line)."""

_SB_FLAGS = cv2.CALIB_CB_EXHAUSTIVE | cv2.CALIB_CB_ACCURACY | cv2.CALIB_CB_NORMALIZE_IMAGE
_CLASSIC_FLAGS = cv2.CALIB_CB_ADAPTIVE_THRESH | cv2.CALIB_CB_NORMALIZE_IMAGE
_SUBPIX_CRITERIA = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 50, 1e-4)


@dataclass(frozen=True)
class Detection:
    """The outcome of looking for a board in one image.

    Parameters
    ----------
    corners : ndarray (N, 2) or None
        The inner corners, (u, v) px, in :meth:`Chessboard.object_points` order; None when the
        board was not found.
    method : str
        The detector that found the board, ``"sb"`` (``findChessboardCornersSB``) or
        ``"classic"`` (``findChessboardCorners``), or ``""`` when not found.
    reason : str
        Why the board was not found ("" when found).
    ids : ndarray (N,) int or None
        For a ChArUco board, the ids of the corners found (a part of the board may be
        hidden); None for a chessboard, whose corners are all found, in order.
    """

    corners: NDArray[np.float64] | None
    method: str = ""
    reason: str = ""
    ids: NDArray[np.int64] | None = None

    def object_points(self, board: Target) -> NDArray[np.float64]:
        """The board-frame points (N, 3), mm, of the corners found."""
        points = board.object_points()
        return points if self.ids is None else points[self.ids]

    @property
    def found(self) -> bool:
        return self.corners is not None


def _as_grey(image: NDArray[np.uint8]) -> NDArray[np.uint8]:
    if image.ndim == 3:
        return cv2.cvtColor(image, cv2.COLOR_BGR2GRAY)
    return np.ascontiguousarray(image)


def _outer_square_grey(grey: NDArray[np.uint8], corner: NDArray[np.float64],
                       inner: NDArray[np.float64]) -> float | None:
    """Mean grey level of the board's square diagonally beyond ``corner`` (away from its
    diagonal neighbour ``inner``), sampled over a patch; None when it lies off the image."""
    centre = corner + 0.5 * (corner - inner)
    half = max(1, int(0.15 * np.linalg.norm(corner - inner)))
    h, w = grey.shape
    u, v = int(round(centre[0])), int(round(centre[1]))
    if not (half <= u < w - half and half <= v < h - half):
        return None
    return float(grey[v - half:v + half + 1, u - half:u + half + 1].mean())


def _canonical(grey: NDArray[np.uint8], corners: NDArray[np.float64],
               board: Chessboard) -> NDArray[np.float64]:
    """The corners in one order whichever detector found them.

    A board with one odd and one even count is numbered from the inner corner whose outer
    square (diagonally beyond it) is white, the one beyond the last corner being black: the
    order ``findChessboardCornersSB`` reports (the classic detector reports the reverse).
    A symmetric board is numbered from the end nearer the image's top-left.
    """
    if board.symmetric:
        return corners[::-1].copy() if corners[0].sum() > corners[-1].sum() else corners
    cols, rows = board.inner_corners
    grid = corners.reshape(rows, cols, 2)
    first = _outer_square_grey(grey, grid[0, 0], grid[1, 1])
    last = _outer_square_grey(grey, grid[-1, -1], grid[-2, -2])
    if first is not None and last is not None and first < last:
        return corners[::-1].copy()
    return corners


def _subpix_window(corners: NDArray[np.float32], board: Chessboard) -> int:
    """Half-width of ``cornerSubPix``'s window: 0.4 of the smallest corner spacing, 2-11 px."""
    cols, rows = board.inner_corners
    grid = corners.reshape(rows, cols, 2)
    spacing = min(float(np.linalg.norm(np.diff(grid, axis=1), axis=-1).min()),
                  float(np.linalg.norm(np.diff(grid, axis=0), axis=-1).min()))
    return int(np.clip(0.4 * spacing, 2, 11))


def _find_charuco(grey: NDArray[np.uint8], board: CharucoBoard) -> Detection:
    """A ChArUco board's identified corners (``cv2.aruco.CharucoDetector``), refined by
    ``cornerSubPix`` in a window that stays clear of the markers."""
    detector = cv2.aruco.CharucoDetector(board.cv_board())
    corners, ids, _, marker_ids = detector.detectBoard(grey)
    n = 0 if ids is None else len(ids)
    if n < MIN_CHARUCO_CORNERS:
        markers = 0 if marker_ids is None else len(marker_ids)
        found = f"{n} corners and {markers} markers" if markers else "no markers"
        return Detection(None, "", f"no {board.name} found ({found}; {MIN_CHARUCO_CORNERS} "
                                   "corners needed)")
    pts = np.asarray(corners, dtype=np.float32).reshape(-1, 2)
    gaps = np.linalg.norm(pts[:, None] - pts[None], axis=-1)
    np.fill_diagonal(gaps, np.inf)
    spacing = float(np.median(gaps.min(axis=1)))
    # the window stays inside the white band between a corner's squares and their markers
    half = int(np.clip(0.9 * spacing * (1 - board.marker_mm / board.square_mm) / 2, 1, 11))
    pts = cv2.cornerSubPix(grey, pts.reshape(-1, 1, 2), (half, half), (-1, -1),
                           _SUBPIX_CRITERIA).reshape(-1, 2).astype(np.float64)
    order = np.argsort(np.asarray(ids).ravel())
    return Detection(pts[order], "charuco", "",
                     np.asarray(ids, dtype=np.int64).ravel()[order])


def find_corners(image: NDArray[np.uint8], board: Target) -> Detection:
    """The board's inner corners in a grey (H, W) or BGR (H, W, 3) image.

    A chessboard is found whole or not at all; a ChArUco board's corners are those whose
    markers are seen (at least :data:`MIN_CHARUCO_CORNERS`), with their ids.

    Returns
    -------
    Detection
        ``corners`` (N, 2) float64 when found, else a ``reason``.
    """
    grey = _as_grey(image)
    if isinstance(board, CharucoBoard):
        return _find_charuco(grey, board)
    size = board.inner_corners
    found, corners = cv2.findChessboardCornersSB(grey, size, flags=_SB_FLAGS)
    method = "sb"
    if not found or corners is None:
        found, corners = cv2.findChessboardCorners(grey, size, flags=_CLASSIC_FLAGS)
        method = "classic"
    if found and corners is not None and len(corners) == board.n_corners:
        half = _subpix_window(corners, board)
        corners = cv2.cornerSubPix(grey, np.ascontiguousarray(corners, dtype=np.float32),
                                   (half, half), (-1, -1), _SUBPIX_CRITERIA)
    if not found or corners is None or len(corners) != board.n_corners:
        return Detection(None, "", f"no {board.name} found")
    pts = np.asarray(corners, dtype=np.float64).reshape(-1, 2)
    if not np.isfinite(pts).all():
        return Detection(None, "", f"no {board.name} found (corners not finite)")
    return Detection(_canonical(grey, pts, board), method)


def chessboard_pose(image_bgr: NDArray[np.uint8], camera: PinholeCamera, board: Target,
                    source: str = "image") -> NDArray[np.float64]:
    """``T_cam_target`` (4, 4), mm, of a chessboard seen in one image.

    Raises :class:`InputError` naming ``source`` when the board is not found.
    """
    detection = find_corners(image_bgr, board)
    if detection.corners is None:
        raise InputError(source, detection.reason)
    return pose_from_corners(detection.corners, camera, board, source, detection.ids)


def pose_from_corners(corners: NDArray[np.float64], camera: PinholeCamera, board: Target,
                      source: str = "image", ids: NDArray[np.int64] | None = None
                      ) -> NDArray[np.float64]:
    """``T_cam_target`` (4, 4), mm, from a board's detected corners (N, 2) (ChArUco: with
    their ``ids``): ``cv2.solvePnP`` (IPPE for a plane, then Levenberg-Marquardt)."""
    obj = board.object_points() if ids is None else board.object_points()[ids]
    img = corners.reshape(-1, 1, 2)
    ok, rvec, tvec = cv2.solvePnP(obj, img, camera.K, camera.dist, flags=cv2.SOLVEPNP_IPPE)
    if not ok:
        ok, rvec, tvec = cv2.solvePnP(obj, img, camera.K, camera.dist)
    if not ok:
        raise InputError(source, "solvePnP failed on the chessboard corners")
    rvec, tvec = cv2.solvePnPRefineLM(obj, img, camera.K, camera.dist, rvec, tvec)
    return make_transform(cv2.Rodrigues(rvec)[0], np.asarray(tvec, dtype=np.float64).ravel())
