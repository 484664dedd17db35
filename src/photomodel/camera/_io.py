"""Calibration files: OpenCV ``FileStorage`` (YAML, XML, JSON) and ROS ``camera_info`` YAML.

Keys (docs/contracts.md): stereo rig ``K1``/``M1``, ``D1``, ``K2``/``M2``, ``D2``, ``R``, ``T`` and
optional ``image_width``, ``image_height``; single camera ``camera_matrix``/``K``,
``distortion_coefficients``/``D``, optional ``image_width``, ``image_height``, ``distance_mm``.
ROS ``camera_info`` stores matrices as mappings with a ``data`` list; both forms are read.
Every problem is raised as :class:`~photomodel.errors.InputError` naming the file.
"""

from __future__ import annotations

import os
from pathlib import Path

import cv2
import numpy as np
from numpy.typing import NDArray

from photomodel.camera._pinhole import PinholeCamera
from photomodel.camera._stereo import StereoRig
from photomodel.errors import InputError

__all__ = ["load_camera", "load_distance_mm", "load_stereo", "save_camera", "save_stereo"]


def _open(path: str | os.PathLike[str]) -> cv2.FileStorage:
    p = Path(path)
    if not p.is_file():
        raise InputError(p, "calibration file not found")
    try:
        fs = cv2.FileStorage(str(p), cv2.FILE_STORAGE_READ)
    except (cv2.error, SystemError) as exc:  # OpenCV 5 wraps cv2.error in SystemError
        cause = exc if isinstance(exc, cv2.error) else exc.__cause__
        reason = _cv_reason(cause) if isinstance(cause, cv2.error) else "parse error"
        raise InputError(p, f"not a readable OpenCV YAML/XML/JSON file ({reason})") from None
    if not fs.isOpened():
        raise InputError(p, "not a readable OpenCV YAML/XML/JSON file")
    return fs


def _cv_reason(exc: cv2.error) -> str:
    text = str(exc).strip().splitlines()
    return text[-1].split(") ", 1)[-1].strip() if text else "parse error"


def _node(fs: cv2.FileStorage, names: tuple[str, ...]) -> tuple[str, cv2.FileNode] | None:
    for name in names:
        node = fs.getNode(name)
        if not node.empty() and not node.isNone():
            return name, node
    return None


def _matrix(path: Path, fs: cv2.FileStorage, names: tuple[str, ...], shape: tuple[int, ...] | None,
            required: bool = True) -> NDArray[np.float64] | None:
    """Read a matrix stored as ``!!opencv-matrix``, a ROS ``{rows, cols, data}`` map or a list."""
    found = _node(fs, names)
    if found is None:
        if required:
            raise InputError(path, f"calibration lacks the key {' (or '.join(names)}"
                             + (")" if len(names) > 1 else ""))
        return None
    name, node = found
    if node.isMap() and not node.getNode("data").empty():
        node = node.getNode("data")
    if node.isSeq():
        values = [node.at(i).real() for i in range(node.size())]
        arr = np.asarray(values, dtype=np.float64)
    else:
        mat = node.mat()
        if mat is None:
            raise InputError(path, f"key {name} is not a matrix")
        arr = np.asarray(mat, dtype=np.float64)
    if shape is not None:
        if arr.size != int(np.prod(shape)):
            raise InputError(path, f"key {name} has {arr.size} values, expected shape {shape}")
        arr = arr.reshape(shape)
    else:
        arr = arr.ravel()
    if not np.isfinite(arr).all():
        raise InputError(path, f"key {name} contains non-finite values")
    return arr


def _int(fs: cv2.FileStorage, name: str) -> int:
    node = fs.getNode(name)
    return 0 if node.empty() or node.isNone() else int(node.real())


def _camera(path: Path, fs: cv2.FileStorage, k_names: tuple[str, ...],
            d_names: tuple[str, ...]) -> PinholeCamera:
    K = _matrix(path, fs, k_names, (3, 3))
    D = _matrix(path, fs, d_names, None, required=False)
    try:
        return PinholeCamera(K, np.zeros(0) if D is None else D,
                             _int(fs, "image_width"), _int(fs, "image_height"))
    except ValueError as exc:
        raise InputError(path, str(exc)) from None


def load_camera(path: str | os.PathLike[str]) -> PinholeCamera:
    """Read a single camera (``camera_matrix``/``K``, ``distortion_coefficients``/``D``).

    Parameters
    ----------
    path : path-like
        OpenCV YAML/XML/JSON written by ``cv2.FileStorage``, or a ROS ``camera_info`` YAML.

    Raises
    ------
    InputError
        The file is missing, unreadable or lacks the camera matrix.
    """
    p = Path(path)
    fs = _open(p)
    try:
        return _camera(p, fs, ("camera_matrix", "K"), ("distortion_coefficients", "D"))
    finally:
        fs.release()


def load_distance_mm(path: str | os.PathLike[str]) -> float | None:
    """The optional ``distance_mm`` of a model-station camera file (None when absent)."""
    p = Path(path)
    fs = _open(p)
    try:
        node = fs.getNode("distance_mm")
        if node.empty() or node.isNone():
            return None
        value = float(node.real())
        if not value > 0:
            raise InputError(p, f"distance_mm must be positive, got {value}")
        return value
    finally:
        fs.release()


def load_stereo(path: str | os.PathLike[str]) -> StereoRig:
    """Read the hand's stereo calibration (``K1``/``M1``, ``D1``, ``K2``/``M2``, ``D2``, ``R``,
    ``T``).

    Camera 1 is the reference (the paper's right camera); ``X2 = R X1 + T`` with ``T`` in mm.
    ``R`` may also be given as a Rodrigues vector (3 values).
    """
    p = Path(path)
    fs = _open(p)
    try:
        cam1 = _camera(p, fs, ("K1", "M1"), ("D1",))
        cam2 = _camera(p, fs, ("K2", "M2"), ("D2",))
        R = _matrix(p, fs, ("R",), None)
        T = _matrix(p, fs, ("T",), (3,))
    finally:
        fs.release()
    assert R is not None and T is not None
    if R.size == 3:
        R = cv2.Rodrigues(R)[0]
    elif R.size == 9:
        R = R.reshape(3, 3)
    else:
        raise InputError(p, f"key R has {R.size} values, expected a 3x3 matrix")
    try:
        return StereoRig(cam1, cam2, R, T)
    except ValueError as exc:
        raise InputError(p, str(exc)) from None


def _write_atomic(path: Path, write: callable) -> None:  # type: ignore[valid-type]
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.stem}.tmp{path.suffix}")
    fs = cv2.FileStorage(str(tmp), cv2.FILE_STORAGE_WRITE)
    try:
        write(fs)
    finally:
        fs.release()
    os.replace(tmp, path)


def save_camera(path: str | os.PathLike[str], camera: PinholeCamera,
                distance_mm: float | None = None) -> None:
    """Write a single camera with ``cv2.FileStorage`` (format from the suffix: .yaml/.xml/.json)."""

    def write(fs: cv2.FileStorage) -> None:
        if camera.width_px:
            fs.write("image_width", camera.width_px)
            fs.write("image_height", camera.height_px)
        fs.write("camera_matrix", camera.K)
        fs.write("distortion_coefficients", camera.dist.reshape(1, -1))
        if distance_mm is not None:
            fs.write("distance_mm", float(distance_mm))

    _write_atomic(Path(path), write)


def save_stereo(path: str | os.PathLike[str], rig: StereoRig) -> None:
    """Write a stereo rig with ``cv2.FileStorage`` using the docs/contracts.md keys."""

    def write(fs: cv2.FileStorage) -> None:
        if rig.cam1.width_px:
            fs.write("image_width", rig.cam1.width_px)
            fs.write("image_height", rig.cam1.height_px)
        fs.write("K1", rig.cam1.K)
        fs.write("D1", rig.cam1.dist.reshape(1, -1))
        fs.write("K2", rig.cam2.K)
        fs.write("D2", rig.cam2.dist.reshape(1, -1))
        fs.write("R", rig.R)
        fs.write("T", rig.T.reshape(3, 1))

    _write_atomic(Path(path), write)
