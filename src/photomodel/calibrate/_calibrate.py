"""Intrinsic and stereo calibration from views of a chessboard, through OpenCV.

One camera: ``cv2.calibrateCameraExtended`` over every view in which the board is found.
Distortion: ``distortion=4`` (the default) fits k1 k2 p1 p2 with k3 fixed at 0 (written as
the 5 coefficients of OpenCV's plumb-bob model), 5 fits k3 too, 8 is OpenCV's rational model.
k3 is fixed by default because a free k3 extrapolates the image's rim badly from views that
do not reach it (docs/method/calibrate.md); a lens with strong distortion seen to the image's
corners takes ``distortion=5`` or 8.

Two cameras: each camera's intrinsics from all of its own views, then
``cv2.stereoCalibrateExtended`` over the pairs in which both cameras found the board,
starting from them and refining them with ``R``, ``T`` (``refine_intrinsics=False`` keeps
them fixed, ``CALIB_FIX_INTRINSIC``). Refining is the default: the pairs' rig constraint pins
down what each camera's own views leave loose (docs/method/calibrate.md).
Camera 1 is the right camera (the reference): ``X2 = R X1 + T``, ``T`` in mm, as the
calibration file's contract says (docs/contracts.md).

Errors are RMS reprojection errors in pixels: overall (OpenCV's, over all corners of all used
views) and per view. A view in which the board is not found is listed with the reason and
skipped; fewer than :data:`MIN_VIEWS` usable views is an :class:`~photomodel.errors.InputError`.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import cv2
import numpy as np
from numpy.typing import NDArray

from photomodel.calibrate._detect import MIN_CHARUCO_CORNERS, find_corners, pose_from_corners
from photomodel.calibrate._pattern import Chessboard, Target
from photomodel.calibrate._views import ViewCorners, detect_views, list_images, list_pairs
from photomodel.camera import PinholeCamera, StereoRig
from photomodel.errors import InputError
from photomodel.geometry import make_transform
from photomodel.image import read_grey_image

__all__ = [
    "DEFAULT_DISTORTION",
    "DISTORTION_MODELS",
    "MIN_VIEWS",
    "CameraCalibration",
    "PlaneDistance",
    "SkippedView",
    "StereoCalibration",
    "calibrate_camera",
    "calibrate_camera_folder",
    "calibrate_stereo",
    "calibrate_station_folder",
    "calibrate_stereo_folder",
    "plane_distance",
    "plane_distance_from_image",
]

MIN_VIEWS = 3
"""Fewest views with the board found that a calibration takes (OpenCV's minimum for a
planar target; 10-20 well-spread views are what an accurate one needs)."""

DISTORTION_MODELS: dict[int, int] = {
    4: cv2.CALIB_FIX_K3,
    5: 0,
    8: cv2.CALIB_RATIONAL_MODEL,
}
"""Distortion coefficients fitted -> ``cv2.calibrateCamera`` flags (4: k3 fixed at 0)."""

DEFAULT_DISTORTION = 4
"""The distortion model fitted unless told otherwise (k1 k2 p1 p2; module docstring)."""

_COVERAGE_GRID = (8, 6)
_CRITERIA = (cv2.TERM_CRITERIA_COUNT + cv2.TERM_CRITERIA_EPS, 200, 1e-12)
_MAX_LISTED = 6


@dataclass(frozen=True)
class SkippedView:
    """A view left out of a calibration, and why."""

    name: str
    reason: str

    def to_json_dict(self) -> dict[str, str]:
        return {"view": self.name, "reason": self.reason}


@dataclass(frozen=True)
class CameraCalibration:
    """One camera's calibration.

    Parameters
    ----------
    camera : PinholeCamera
        Intrinsics, distortion and image size.
    rms_px : float
        RMS reprojection error over all corners of the used views, px.
    views : tuple of str
        The used views, in order.
    per_view_rms_px : ndarray (V,)
        RMS reprojection error of each used view, px.
    corners : tuple of ndarray (N, 2)
        The corners of each used view, px.
    T_cam_target : ndarray (V, 4, 4)
        The board's pose in each used view, mm.
    skipped : tuple of SkippedView
        Views without the board.
    std_intrinsics : ndarray (4,)
        Standard deviations of (fx, fy, cx, cy) OpenCV estimates, px.
    """

    camera: PinholeCamera
    rms_px: float
    views: tuple[str, ...]
    per_view_rms_px: NDArray[np.float64]
    corners: tuple[NDArray[np.float64], ...]
    T_cam_target: NDArray[np.float64]
    skipped: tuple[SkippedView, ...] = ()
    std_intrinsics: NDArray[np.float64] = field(default_factory=lambda: np.full(4, np.nan))

    @property
    def coverage(self) -> float:
        """Share of the cells of a 8 x 6 grid over the image that hold a corner of a used view
        (1 when the views reach every part of the image; the distortion is extrapolated
        where they do not)."""
        w, h = self.camera.image_size
        pts = np.concatenate(self.corners)
        col = np.clip((pts[:, 0] + 0.5) * _COVERAGE_GRID[0] // w, 0, _COVERAGE_GRID[0] - 1)
        row = np.clip((pts[:, 1] + 0.5) * _COVERAGE_GRID[1] // h, 0, _COVERAGE_GRID[1] - 1)
        cells = np.unique(row.astype(int) * _COVERAGE_GRID[0] + col.astype(int))
        return len(cells) / (_COVERAGE_GRID[0] * _COVERAGE_GRID[1])

    def to_json_dict(self, camera: PinholeCamera | None = None) -> dict[str, Any]:
        """The fit as JSON; ``camera`` replaces the intrinsics reported (a stereo fit's)."""
        camera = self.camera if camera is None else camera
        K = camera.K
        return {
            "rms_px": self.rms_px,
            "coverage": self.coverage,
            "image_size": list(camera.image_size),
            "fx": K[0, 0], "fy": K[1, 1], "cx": K[0, 2], "cy": K[1, 2],
            "std_fx_fy_cx_cy_px": [float(s) for s in self.std_intrinsics],
            "distortion": camera.dist.tolist(),
            "views": [{"view": n, "rms_px": float(e)}
                      for n, e in zip(self.views, self.per_view_rms_px, strict=True)],
            "skipped": [s.to_json_dict() for s in self.skipped],
        }


@dataclass(frozen=True)
class StereoCalibration:
    """A stereo rig's calibration (camera 1 = right = reference).

    Parameters
    ----------
    rig : StereoRig
        Both cameras and ``R``, ``T`` (``X2 = R X1 + T``, mm).
    rms_px : float
        RMS reprojection error of the stereo fit over both cameras, px.
    cam1, cam2 : CameraCalibration
        Each camera's own calibration (over all views in which it found the board; its
        ``camera`` and ``rms_px`` are those before the stereo fit refined them; the rig's
        cameras are the final ones).
    pairs : tuple of str
        The pairs used by the stereo fit.
    per_pair_rms_px : ndarray (P, 2)
        RMS reprojection error of each pair in camera 1 and camera 2, px.
    skipped : tuple of SkippedView
        Pairs left out of the stereo fit (the board missing in one or both images).
    refined_intrinsics : bool
        True when the stereo fit refined the intrinsics too.
    """

    rig: StereoRig
    rms_px: float
    cam1: CameraCalibration
    cam2: CameraCalibration
    pairs: tuple[str, ...]
    per_pair_rms_px: NDArray[np.float64]
    skipped: tuple[SkippedView, ...] = ()
    refined_intrinsics: bool = False

    @property
    def baseline_mm(self) -> float:
        """|T|, mm."""
        return float(np.linalg.norm(self.rig.T))

    def to_json_dict(self) -> dict[str, Any]:
        rvec = cv2.Rodrigues(self.rig.R)[0].ravel()
        return {
            "rms_px": self.rms_px,
            "right": self.cam1.to_json_dict(self.rig.cam1),
            "left": self.cam2.to_json_dict(self.rig.cam2),
            "K1": self.rig.cam1.K.tolist(), "D1": self.rig.cam1.dist.tolist(),
            "K2": self.rig.cam2.K.tolist(), "D2": self.rig.cam2.dist.tolist(),
            "R": self.rig.R.tolist(), "T": self.rig.T.tolist(),
            "baseline_mm": self.baseline_mm,
            "rotation_deg": float(np.degrees(np.linalg.norm(rvec))),
            "refined_intrinsics": self.refined_intrinsics,
            "pairs": [{"pair": n, "rms_px": [float(e[0]), float(e[1])]}
                      for n, e in zip(self.pairs, self.per_pair_rms_px, strict=True)],
            "skipped": [s.to_json_dict() for s in self.skipped],
        }


def _listed(skipped: list[SkippedView]) -> str:
    text = "; ".join(f"{s.name}: {s.reason}" for s in skipped[:_MAX_LISTED])
    more = len(skipped) - _MAX_LISTED
    return text + (f"; and {more} more" if more > 0 else "")


def _pattern_hint(views: list[ViewCorners], board: Target) -> str:
    """A hint when the board is never found: the counts given as squares, not inner corners."""
    if not isinstance(board, Chessboard):
        return ""
    cols, rows = board.inner_corners
    if min(cols, rows) <= 2 or not views:
        return ""
    smaller = Chessboard((cols - 1, rows - 1), board.square_mm)
    for view in views[:2]:
        grey = read_grey_image(view.path, "calibration image")
        if cv2.findChessboardCorners(grey, smaller.inner_corners,
                                     flags=cv2.CALIB_CB_ADAPTIVE_THRESH
                                     | cv2.CALIB_CB_NORMALIZE_IMAGE)[0]:
            return f" ({view.name} shows a {cols - 1}x{rows - 1} chessboard)"
    return ""


def _check_found(views: list[ViewCorners], board: Target, source: str | os.PathLike[str],
                 what: str = "views") -> None:
    found = [v for v in views if v.detection.found]
    if not found:
        counts = ("COLSxROWS counts inner corners, not squares" if isinstance(board, Chessboard)
                  else "COLSxROWS counts squares; the dictionary and sizes must match the "
                       "printed board")
        raise InputError(source, f"no view shows a {board.name}{_pattern_hint(views, board)}: "
                                 f"check --pattern ({counts})")
    if len(found) < MIN_VIEWS:
        missing = [SkippedView(v.name, v.detection.reason) for v in views
                   if not v.detection.found]
        listed = f": {_listed(missing)}" if missing else ""
        raise InputError(source, f"needs at least {MIN_VIEWS} {what} in which the "
                                 f"{board.name} is found; found in {len(found)} of "
                                 f"{len(views)}{listed}")


def _points(views: list[ViewCorners], board: Target
            ) -> tuple[list[NDArray[np.float32]], list[NDArray[np.float32]]]:
    """Object points (N, 1, 3) and image points (N, 1, 2) of each view, float32 for OpenCV."""
    obj, img = [], []
    for v in views:
        assert v.corners is not None
        obj.append(v.detection.object_points(board).astype(np.float32).reshape(-1, 1, 3))
        img.append(v.corners.astype(np.float32).reshape(-1, 1, 2))
    return obj, img


def calibrate_camera(views: list[ViewCorners], board: Target, *,
                     distortion: int = DEFAULT_DISTORTION,
                     source: str | os.PathLike[str] = "views") -> CameraCalibration:
    """One camera's intrinsics and distortion from the corners of its views.

    Parameters
    ----------
    views : list of ViewCorners
        All views (those without the board are skipped and listed); one image size.
    board : Chessboard or CharucoBoard
    distortion : int
        Distortion coefficients to fit: 4 (k1 k2 p1 p2, k3 fixed at 0 and written as the
        fifth; the default), 5 (k1 k2 p1 p2 k3) or 8 (rational).
    source : str or path-like
        What an error names (the folder).

    Raises
    ------
    InputError
        Fewer than :data:`MIN_VIEWS` views show the board (none: the pattern may be wrong).
    """
    if distortion not in DISTORTION_MODELS:
        raise ValueError(f"distortion: expected one of {sorted(DISTORTION_MODELS)}, got "
                         f"{distortion}")
    _check_found(views, board, source)
    used = [v for v in views if v.detection.found]
    skipped = tuple(SkippedView(v.name, v.detection.reason) for v in views
                    if not v.detection.found)
    size = used[0].size
    object_points, image_points = _points(used, board)
    rms, K, D, rvecs, tvecs, std_in, _, per_view = cv2.calibrateCameraExtended(
        object_points, image_points, size, None, None,
        flags=DISTORTION_MODELS[distortion], criteria=_CRITERIA)
    dist = np.asarray(D, dtype=np.float64).ravel()[:max(distortion, 5)].copy()
    if distortion == 4:
        dist[4] = 0.0
    try:
        camera = PinholeCamera(np.asarray(K, dtype=np.float64), dist, *size)
    except ValueError as exc:
        raise InputError(source, f"the calibration failed ({exc}); take views that show the "
                                 "board at different tilts over the whole image") from None
    poses = np.stack([make_transform(cv2.Rodrigues(r)[0], np.asarray(t, float).ravel())
                      for r, t in zip(rvecs, tvecs, strict=True)])
    return CameraCalibration(camera, float(rms), tuple(v.name for v in used),
                             np.asarray(per_view, dtype=np.float64).ravel(),
                             tuple(v.corners for v in used if v.corners is not None), poses,
                             skipped, np.asarray(std_in, dtype=np.float64).ravel()[:4])


def calibrate_camera_folder(folder: str | os.PathLike[str], board: Target, *,
                            distortion: int = DEFAULT_DISTORTION) -> CameraCalibration:
    """:func:`calibrate_camera` over the images directly in ``folder`` (name order)."""
    views = detect_views(list_images(folder), board)
    return calibrate_camera(views, board, distortion=distortion, source=folder)


def calibrate_stereo(right: list[ViewCorners], left: list[ViewCorners], board: Target, *,
                     distortion: int = DEFAULT_DISTORTION, refine_intrinsics: bool = True,
                     source: str | os.PathLike[str] = "pairs") -> StereoCalibration:
    """A stereo rig from simultaneous views: camera 1 = right (reference), camera 2 = left.

    Each camera's intrinsics come from every view in which it found the board; ``R``, ``T``
    from the pairs in which both did (``cv2.stereoCalibrate``, refining the intrinsics too
    unless ``refine_intrinsics`` is False).

    Parameters
    ----------
    right, left : list of ViewCorners
        The pairs' views, in the same order (``right[i]`` and ``left[i]`` are one pair).
    board : Chessboard or CharucoBoard
    distortion : int
        See :func:`calibrate_camera`.
    refine_intrinsics : bool
        Let the stereo fit refine both cameras' intrinsics and distortion (the default);
        False keeps each camera's own calibration.
    source : str or path-like
        What an error names (the pairs folder).

    Raises
    ------
    InputError
        Fewer than :data:`MIN_VIEWS` views of a camera, or pairs, show the board; a square
        board (its corners could be numbered differently by the two cameras).
    """
    if len(right) != len(left):
        raise ValueError(f"right, left: expected as many views, got {len(right)} and "
                         f"{len(left)}")
    cols, rows = board.inner_corners
    if isinstance(board, Chessboard) and cols == rows:
        raise InputError("--pattern", f"a {board.name} looks the same turned by 90 degrees, so "
                                      "the two cameras may number its corners differently: use "
                                      "a board with unequal counts (9x6)")
    _check_found(right, board, source, "right views")
    _check_found(left, board, source, "left views")
    cal1 = calibrate_camera(right, board, distortion=distortion, source=source)
    cal2 = calibrate_camera(left, board, distortion=distortion, source=source)
    both: list[tuple[ViewCorners, ViewCorners]] = []
    skipped = []
    for r, lf in zip(right, left, strict=True):
        missing = [n for n, v in (("right", r), ("left", lf)) if not v.detection.found]
        if missing:
            skipped.append(SkippedView(r.name, f"no {board.name} found in "
                                               f"{' and '.join(missing)}"))
            continue
        common = _common_corners(r, lf)
        if common is None:
            both.append((r, lf))
        elif len(common[0].detection.ids) < MIN_CHARUCO_CORNERS:  # type: ignore[arg-type]
            skipped.append(SkippedView(r.name, f"fewer than {MIN_CHARUCO_CORNERS} corners "
                                               "seen by both cameras"))
        else:
            both.append(common)
    if len(both) < MIN_VIEWS:
        raise InputError(source, f"needs at least {MIN_VIEWS} pairs in which both cameras find "
                                 f"the {board.name}; found in {len(both)} of {len(right)}: "
                                 f"{_listed(skipped)}")
    obj, img1 = _points([r for r, _ in both], board)
    _, img2 = _points([lf for _, lf in both], board)
    # the model's flags in both cases: with CALIB_FIX_INTRINSIC alone OpenCV would project
    # with 5 of the rational model's 8 coefficients
    flags = DISTORTION_MODELS[distortion] | (cv2.CALIB_USE_INTRINSIC_GUESS if refine_intrinsics
                                             else cv2.CALIB_FIX_INTRINSIC)
    c1, c2 = cal1.camera, cal2.camera
    D1 = np.zeros(max(5, distortion))
    D2 = np.zeros(max(5, distortion))
    D1[: c1.dist.size], D2[: c2.dist.size] = c1.dist, c2.dist
    out = cv2.stereoCalibrateExtended(
        obj, img1, img2, c1.K.copy(), D1, c2.K.copy(), D2,
        c1.image_size, None, None, flags=flags, criteria=_CRITERIA)
    rms, K1, D1o, K2, D2o, R, T = out[:7]
    per_view = np.asarray(out[-1], dtype=np.float64).reshape(-1, 2)
    n = c1.dist.size
    try:
        cam1 = PinholeCamera(np.asarray(K1, float), np.asarray(D1o, float).ravel()[:n],
                             *c1.image_size)
        cam2 = PinholeCamera(np.asarray(K2, float), np.asarray(D2o, float).ravel()[:n],
                             *c2.image_size)
        rig = StereoRig(cam1, cam2, np.asarray(R, float), np.asarray(T, float).ravel())
    except ValueError as exc:
        raise InputError(source, f"the stereo calibration failed ({exc})") from None
    return StereoCalibration(rig, float(rms), cal1, cal2, tuple(r.name for r, _ in both),
                             per_view, tuple(skipped), refine_intrinsics)


def _common_corners(right: ViewCorners, left: ViewCorners
                    ) -> tuple[ViewCorners, ViewCorners] | None:
    """A ChArUco pair cut down to the corners both cameras found (None for a chessboard,
    whose corners are all found in both)."""
    a, b = right.detection, left.detection
    if a.ids is None or b.ids is None or a.corners is None or b.corners is None:
        return None
    common, ia, ib = np.intersect1d(a.ids, b.ids, return_indices=True)
    cut = [replace(view, detection=replace(d, corners=d.corners[i], ids=common))
           for view, d, i in ((right, a, ia), (left, b, ib))]
    return cut[0], cut[1]


def calibrate_stereo_folder(folder: str | os.PathLike[str], board: Target, *,
                            distortion: int = DEFAULT_DISTORTION,
                            refine_intrinsics: bool = True) -> StereoCalibration:
    """:func:`calibrate_stereo` over ``folder/<id>/right.png`` and ``left.png`` (name order)."""
    pairs = list_pairs(folder)
    right = detect_views([(i, r) for i, r, _ in pairs], board)
    _check_found(right, board, folder, "right views")  # before reading the left ones
    left = detect_views([(i, lf) for i, _, lf in pairs], board, size=right[0].size)
    return calibrate_stereo(right, left, board, distortion=distortion,
                            refine_intrinsics=refine_intrinsics, source=folder)


@dataclass(frozen=True)
class PlaneDistance:
    """Where the model plane lies, from a view of the board lying flat on it.

    Parameters
    ----------
    distance_mm : float
        Depth of the plane on the camera's optical axis (the z at which the axis meets the
        plane): the ``distance_mm`` of the model station's file, the value
        :func:`~photomodel.model.build_photo_model` takes (it puts the plane at z =
        ``distance_mm``, square to the axis).
    normal_distance_mm : float
        Perpendicular distance from the camera centre to the plane.
    tilt_deg : float
        Angle between the plane's normal and the optical axis (0 when the camera faces the
        plane squarely, as the build assumes).
    rms_px : float
        RMS reprojection error of the board's pose.
    T_cam_target : ndarray (4, 4)
        The board's pose, mm.
    """

    distance_mm: float
    normal_distance_mm: float
    tilt_deg: float
    rms_px: float
    T_cam_target: NDArray[np.float64]

    def to_json_dict(self) -> dict[str, Any]:
        return {"distance_mm": self.distance_mm, "normal_distance_mm": self.normal_distance_mm,
                "tilt_deg": self.tilt_deg, "plane_rms_px": self.rms_px,
                "T_cam_target": self.T_cam_target.tolist()}


def plane_distance(corners: NDArray[np.float64], camera: PinholeCamera, board: Target,
                   thickness_mm: float = 0.0, source: str = "plane",
                   ids: NDArray[np.int64] | None = None) -> PlaneDistance:
    """The model plane's distance from the corners (N, 2) of a board lying flat on it.

    The board's pose comes from ``cv2.solvePnP``; its surface lies ``thickness_mm`` above the
    plane (towards the camera). With ``n`` the plane's unit normal pointing away from the
    camera and ``d`` the perpendicular distance, the plane meets the optical axis at
    ``z = d / n_z``. ``ids``: a ChArUco board's corner ids.
    """
    T = pose_from_corners(corners, camera, board, source, ids)
    n = T[:3, 2]
    d = float(n @ T[:3, 3])
    if d < 0:
        n, d = -n, -d
    d += float(thickness_mm)
    if n[2] <= 0.05:
        raise InputError(source, "the board's plane is almost parallel to the optical axis; "
                                 "lay the board flat on the model plane, under the camera")
    points = board.object_points() if ids is None else board.object_points()[ids]
    projected = camera.project(points @ T[:3, :3].T + T[:3, 3])
    rms = float(np.sqrt(np.mean(np.sum((projected - corners) ** 2, axis=-1))))
    return PlaneDistance(d / float(n[2]), d, float(np.degrees(np.arccos(min(n[2], 1.0)))), rms,
                         T)


def _plane_view(path: Path, board: Target) -> tuple[NDArray[np.float64],
                                                     NDArray[np.int64] | None, tuple[int, int]]:
    """The corners (and ChArUco ids) and image size of the plane view; InputError when it
    cannot be read or does not show the board."""
    grey = read_grey_image(path, "plane image")
    detection = find_corners(grey, board)
    if detection.corners is None:
        raise InputError(path, f"{detection.reason}: the plane view must show the whole board "
                               "lying flat on the model plane")
    return detection.corners, detection.ids, (grey.shape[1], grey.shape[0])


def _check_plane_size(path: Path, size: tuple[int, int], camera: PinholeCamera) -> None:
    if camera.width_px and size != camera.image_size:
        raise InputError(path, f"is {size[0]}x{size[1]} px but the calibration views are "
                               f"{camera.width_px}x{camera.height_px} px: all views must have "
                               "one size")


def plane_distance_from_image(path: str | os.PathLike[str], camera: PinholeCamera,
                              board: Target, thickness_mm: float = 0.0) -> PlaneDistance:
    """:func:`plane_distance` from the image file of the board lying on the plane.

    Raises
    ------
    InputError
        The image cannot be read, its size differs from the calibration's, or it does not
        show the board.
    """
    p = Path(path)
    corners, ids, size = _plane_view(p, board)
    _check_plane_size(p, size, camera)
    return plane_distance(corners, camera, board, thickness_mm, str(p), ids)


def calibrate_station_folder(folder: str | os.PathLike[str], plane: str | os.PathLike[str],
                             board: Target, *, distortion: int = DEFAULT_DISTORTION,
                             thickness_mm: float = 0.0
                             ) -> tuple[CameraCalibration, PlaneDistance]:
    """The model station's camera from the views in ``folder`` and its ``distance_mm`` from
    ``plane``, a view of the board lying flat on the model plane (:func:`plane_distance`).

    The plane view is searched first, so that a bad one is reported before the views are.
    """
    views = list_images(folder)
    p = Path(plane)
    corners, ids, size = _plane_view(p, board)
    calibration = calibrate_camera(detect_views(views, board), board, distortion=distortion,
                                   source=folder)
    _check_plane_size(p, size, calibration.camera)
    return calibration, plane_distance(corners, calibration.camera, board, thickness_mm, str(p),
                                       ids)
