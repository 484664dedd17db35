"""Hand-eye: the pose of camera 1 on the hand, its file, its calibration, the frame chain.

The calibration file is read and written with ``cv2.FileStorage`` (YAML, XML or JSON by the
suffix), key ``T_hand_cam1`` (4x4, mm; maps camera-1 coordinates to hand coordinates), plus the
calibration's residuals when it came from :func:`calibrate_hand_eye`.

The chain (the seed's eq. 2 with the world frame = the robot's base)::

    T_base_model = T_base_hand(q) @ T_hand_cam1 @ T_cam1_model

Pairs file of ``photomodel handeye`` (JSON; one object)::

    {"pairs": [{"joints_deg": [7 numbers]  or  "T_base_hand": 4x4 (mm),
                "T_cam1_target": 4x4 (mm)  or  "image": "path (relative to the file)"}, ...],
     "chessboard": {"inner_corners": [columns, rows], "square_mm": 25.0}}   (images only)

Images need the stereo calibration (camera 1's intrinsics) and the chessboard's geometry;
their target pose comes from :func:`photomodel.calibrate.chessboard_pose` (the corner detector
of ``photomodel calibrate``, then ``cv2.solvePnP``); ``Chessboard`` and ``chessboard_pose``
live in :mod:`photomodel.calibrate` and are re-exported here. The target's
frame is the chessboard's: origin at the first inner corner, x along its rows, z into the board.
"""

from __future__ import annotations

import json
import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import cv2
import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial.transform import Rotation

from photomodel._files import write_file_storage
from photomodel.calibrate import Chessboard, chessboard_pose
from photomodel.camera import PinholeCamera, load_matrix
from photomodel.errors import InputError
from photomodel.geometry import invert_transform, make_transform
from photomodel.image import read_color_image
from photomodel.robot._arm import ArmModel
from photomodel.robot._kinematics import forward_kinematics

__all__ = [
    "HAND_EYE_METHODS",
    "Chessboard",
    "HandEyePairs",
    "HandEyeResult",
    "base_from_camera",
    "calibrate_hand_eye",
    "chessboard_pose",
    "hand_eye_error",
    "load_hand_eye",
    "load_hand_eye_pairs",
    "save_hand_eye",
]

HAND_EYE_METHODS: dict[str, int] = {
    "tsai": cv2.CALIB_HAND_EYE_TSAI,
    "park": cv2.CALIB_HAND_EYE_PARK,
    "horaud": cv2.CALIB_HAND_EYE_HORAUD,
    "andreff": cv2.CALIB_HAND_EYE_ANDREFF,
    "daniilidis": cv2.CALIB_HAND_EYE_DANIILIDIS,
}
"""``cv2.calibrateHandEye`` methods by name."""


def _check_transform(T: ArrayLike, source: str) -> NDArray[np.float64]:
    arr = np.asarray(T, dtype=np.float64)
    if arr.shape != (4, 4) or not np.isfinite(arr).all():
        raise InputError(source, f"expected a finite 4x4 transform, got shape {arr.shape}")
    R = arr[:3, :3]
    if (not np.allclose(R.T @ R, np.eye(3), atol=1e-4) or np.linalg.det(R) < 0
            or not np.allclose(arr[3], [0, 0, 0, 1])):
        raise InputError(source, "not a rigid transform (rotation part not orthonormal, or "
                         "last row not 0 0 0 1)")
    return arr


def base_from_camera(T_base_hand: ArrayLike, T_hand_cam1: ArrayLike,
                     T_cam1_model: ArrayLike) -> NDArray[np.float64]:
    """``T_base_model = T_base_hand @ T_hand_cam1 @ T_cam1_model`` (4, 4), mm.

    Every argument is a (4, 4) rigid transform; works on stacks (..., 4, 4) too.
    """
    return (np.asarray(T_base_hand, dtype=np.float64) @ np.asarray(T_hand_cam1, dtype=np.float64)
            @ np.asarray(T_cam1_model, dtype=np.float64))


def load_hand_eye(path: str | os.PathLike[str]) -> NDArray[np.float64]:
    """``T_hand_cam1`` (4, 4), mm, from a ``cv2.FileStorage`` file (key ``T_hand_cam1``)."""
    p = Path(path)
    return _check_transform(load_matrix(p, "T_hand_cam1", (4, 4)), str(p))


def save_hand_eye(path: str | os.PathLike[str], T_hand_cam1: ArrayLike,
                  info: dict[str, float | int | str] | None = None) -> None:
    """Write ``T_hand_cam1`` (4, 4), mm, and scalar ``info`` items, atomically."""
    T = _check_transform(T_hand_cam1, "T_hand_cam1")
    p = Path(path)
    if p.suffix.lower() not in (".yaml", ".yml", ".xml", ".json"):
        raise InputError(p, "unknown calibration format; use .yaml, .xml or .json")

    def write(fs: cv2.FileStorage) -> None:
        fs.write("T_hand_cam1", T)
        for key, value in (info or {}).items():
            fs.write(key, value if isinstance(value, str) else float(value))

    write_file_storage(p, write)


@dataclass(frozen=True)
class HandEyePairs:
    """Robot poses and target observations of a hand-eye calibration.

    Parameters
    ----------
    T_base_hand : ndarray (N, 4, 4)
        Hand poses in the base frame, mm.
    T_cam1_target : ndarray (N, 4, 4)
        Target poses in camera 1's frame, mm.
    """

    T_base_hand: NDArray[np.float64]
    T_cam1_target: NDArray[np.float64]


def load_hand_eye_pairs(path: str | os.PathLike[str], arm: ArmModel,
                        camera: PinholeCamera | None = None) -> HandEyePairs:
    """Read a pairs file (module docstring) into hand and target poses.

    Parameters
    ----------
    path : path-like
        The JSON pairs file.
    arm : ArmModel
        Turns ``joints_deg`` into hand poses by forward kinematics.
    camera : PinholeCamera, optional
        Camera 1; needed only for pairs given as chessboard images.
    """
    p = Path(path)
    if not p.is_file():
        raise InputError(p, "pairs file not found")
    try:
        data: Any = json.loads(p.read_text())
    except (OSError, UnicodeDecodeError, ValueError) as exc:
        raise InputError(p, f"not a readable JSON file ({exc})") from None
    pairs = data.get("pairs") if isinstance(data, dict) else None
    if not isinstance(pairs, list) or len(pairs) < 3:
        raise InputError(p, "expected an object with a list 'pairs' of at least 3 pairs")
    board = None
    if isinstance(data.get("chessboard"), dict):
        try:
            cb = data["chessboard"]
            board = Chessboard(tuple(int(c) for c in cb["inner_corners"]),  # type: ignore[arg-type]
                               float(cb["square_mm"]))
        except (KeyError, TypeError, ValueError) as exc:
            raise InputError(p, f"bad 'chessboard' entry ({exc})") from None
    hands, targets = [], []
    for k, pair in enumerate(pairs):
        where = f"{p}: pair {k}"
        if not isinstance(pair, dict):
            raise InputError(where, "expected an object")
        if "joints_deg" in pair:
            q = arm.check_joints(np.radians(np.asarray(pair["joints_deg"], dtype=float)),
                                 f"{where}: joints_deg")
            hands.append(forward_kinematics(arm, q))
        elif "T_base_hand" in pair:
            hands.append(_check_transform(pair["T_base_hand"], f"{where}: T_base_hand"))
        else:
            raise InputError(where, "needs 'joints_deg' or 'T_base_hand'")
        if "T_cam1_target" in pair:
            targets.append(_check_transform(pair["T_cam1_target"], f"{where}: T_cam1_target"))
        elif "image" in pair:
            if camera is None or board is None:
                raise InputError(where, "an image pair needs --stereo and a 'chessboard' entry")
            image_path = p.parent / str(pair["image"])
            targets.append(chessboard_pose(read_color_image(image_path), camera, board,
                                           str(image_path)))
        else:
            raise InputError(where, "needs 'T_cam1_target' or 'image'")
    return HandEyePairs(np.stack(hands), np.stack(targets))


@dataclass(frozen=True)
class HandEyeResult:
    """Outcome of :func:`calibrate_hand_eye`.

    Parameters
    ----------
    T_hand_cam1 : ndarray (4, 4)
        Camera 1's pose on the hand, mm.
    method : str
    n_pairs : int
    residual_mm, residual_deg : float
        Consistency: RMS distance and RMS angle of the target's base-frame pose
        ``T_base_hand_i @ T_hand_cam1 @ T_cam1_target_i`` from their mean over the pairs (the
        target stands still, so a perfect calibration gives 0).
    backend : str
        ``"opencv"`` (``cv2.calibrateHandEye``) or ``"numpy"`` (:func:`_park_martin`, used where
        the installed OpenCV lacks it: OpenCV 5's main module dropped it).
    """

    T_hand_cam1: NDArray[np.float64]
    method: str
    n_pairs: int
    residual_mm: float
    residual_deg: float
    backend: str = "opencv"

    def to_json_dict(self) -> dict[str, Any]:
        return {"T_hand_cam1": self.T_hand_cam1.tolist(), "method": self.method,
                "backend": self.backend, "n_pairs": self.n_pairs,
                "residual_mm": self.residual_mm, "residual_deg": self.residual_deg}


def calibrate_hand_eye(T_base_hand: Sequence[ArrayLike] | NDArray[np.float64],
                       T_cam1_target: Sequence[ArrayLike] | NDArray[np.float64],
                       method: str = "park") -> HandEyeResult:
    """``T_hand_cam1`` from hand poses and target observations, by ``cv2.calibrateHandEye``.

    Where the installed OpenCV lacks ``cv2.calibrateHandEye`` (OpenCV 5.0's main module), the
    ``"park"`` method runs on numpy (:func:`_park_martin`, the same method; tested against
    OpenCV 4's result).

    Parameters
    ----------
    T_base_hand : ndarray (N, 4, 4)
        Hand poses in the base frame (forward kinematics of the joint readings), mm.
    T_cam1_target : ndarray (N, 4, 4)
        The fixed target's pose seen by camera 1 at each hand pose, mm.
    method : str
        A key of :data:`HAND_EYE_METHODS`.

    Returns
    -------
    HandEyeResult
    """
    if method not in HAND_EYE_METHODS:
        raise InputError("--method", f"unknown hand-eye method {method!r}; known: "
                         f"{', '.join(HAND_EYE_METHODS)}")
    hands = np.asarray(T_base_hand, dtype=np.float64)
    targets = np.asarray(T_cam1_target, dtype=np.float64)
    if hands.shape != targets.shape or hands.ndim != 3 or hands.shape[1:] != (4, 4):
        raise ValueError(f"T_base_hand, T_cam1_target: expected two (N, 4, 4) stacks, got "
                         f"{hands.shape} and {targets.shape}")
    if len(hands) < 3:
        raise InputError("pairs", f"hand-eye calibration needs at least 3 pairs, got {len(hands)}")
    if hasattr(cv2, "calibrateHandEye"):
        R, t = cv2.calibrateHandEye(list(hands[:, :3, :3]), list(hands[:, :3, 3]),
                                    list(targets[:, :3, :3]), list(targets[:, :3, 3]),
                                    method=HAND_EYE_METHODS[method])
        U, _, Vt = np.linalg.svd(np.asarray(R, dtype=np.float64))
        X = make_transform(U @ Vt, np.asarray(t, dtype=np.float64).ravel())
        backend = "opencv"
    elif method == "park":
        X = _park_martin(hands, targets)
        backend = "numpy"
    else:
        raise InputError("--method", f"{method!r} needs cv2.calibrateHandEye, which this OpenCV "
                         f"({cv2.__version__}) lacks; use 'park' (implemented here)")
    if not np.isfinite(X).all():
        raise InputError("pairs", "hand-eye calibration failed (degenerate motions: rotate the "
                         "hand about at least two different axes)")
    T_base_target = hands @ X @ targets
    mean_t = T_base_target[:, :3, 3].mean(axis=0)
    mean_R = Rotation.from_matrix(T_base_target[:, :3, :3]).mean()
    residual_mm = float(np.sqrt(np.mean(np.sum((T_base_target[:, :3, 3] - mean_t) ** 2, -1))))
    angles = (Rotation.from_matrix(T_base_target[:, :3, :3]) * mean_R.inv()).magnitude()
    return HandEyeResult(X, method, len(hands), residual_mm,
                         float(np.degrees(np.sqrt(np.mean(angles**2)))), backend)


def _park_martin(hands: NDArray[np.float64], targets: NDArray[np.float64]) -> NDArray[np.float64]:
    """``X = T_hand_cam1`` (4, 4) by Park and Martin's method over every pair of poses.

    F. C. Park, B. J. Martin, "Robot sensor calibration: solving AX = XB on the Euclidean
    group", IEEE T-RA 10(5), 1994 (OpenCV's ``CALIB_HAND_EYE_PARK``). With the target fixed,
    ``G_i X C_i = G_j X C_j``, so ``A X = X B`` for ``A = G_j^-1 G_i`` and ``B = C_j C_i^-1``.
    The rotation maps the rotation vectors of the B's onto those of the A's (least squares,
    by SVD); the translation solves ``(R_A - I) t_X = R_X t_B - t_A`` in least squares.
    """
    n = len(hands)
    i, j = np.triu_indices(n, k=1)
    A = invert_transform(hands[j]) @ hands[i]
    B = targets[j] @ invert_transform(targets[i])
    alpha = Rotation.from_matrix(A[:, :3, :3]).as_rotvec()
    beta = Rotation.from_matrix(B[:, :3, :3]).as_rotvec()
    M = beta.T @ alpha  # sum of beta alpha^T
    U, _, Vt = np.linalg.svd(M)
    D = np.diag([1.0, 1.0, np.sign(np.linalg.det(Vt.T @ U.T))])
    R_X = Vt.T @ D @ U.T
    lhs = (A[:, :3, :3] - np.eye(3)).reshape(-1, 3)
    rhs = (B[:, :3, 3] @ R_X.T - A[:, :3, 3]).reshape(-1)
    t_X = np.linalg.lstsq(lhs, rhs, rcond=None)[0]
    return make_transform(R_X, t_X)


def hand_eye_error(T_est: ArrayLike, T_true: ArrayLike) -> tuple[float, float]:
    """(translation error mm, rotation error deg) between two ``T_hand_cam1`` (4, 4)."""
    D = invert_transform(np.asarray(T_true, dtype=np.float64)) @ np.asarray(T_est, dtype=float)
    return (float(np.linalg.norm(D[:3, 3])),
            float(np.degrees(Rotation.from_matrix(D[:3, :3]).magnitude())))
