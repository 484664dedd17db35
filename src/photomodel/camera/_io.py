"""Calibration files: OpenCV ``FileStorage`` (YAML, XML, JSON) and ROS ``camera_info`` YAML.

Keys (docs/contracts.md): stereo rig ``K1``/``M1``, ``D1``, ``K2``/``M2``, ``D2``, ``R``, ``T`` and
optional ``image_width``, ``image_height``; single camera ``camera_matrix``/``K``,
``distortion_coefficients``/``D``, optional ``image_width``, ``image_height``, ``distance_mm``.
ROS ``camera_info`` stores matrices as mappings with a ``data`` list; both forms are read, and
a ``sensor_msgs/CameraInfo`` message's own ``width``, ``height`` (and ROS 2's lower-case ``k``,
``d``) are read too. A matrix may also be a plain list, flat or nested (``[[1], [2], [3]]``).

This module is the one place that reads a calibration a user gives: the file (at most
:data:`~photomodel._limits.MAX_CALIBRATION_FILE_BYTES`, UTF-8 text) is parsed from memory, every
value is checked for its type before it is read (OpenCV reads a string or a list asked for as
a number as 1.8e308), and the cameras and the rig are checked for plausibility
(:class:`~photomodel.camera.PinholeCamera`, :class:`~photomodel.camera.StereoRig`). Every problem
is raised as :class:`~photomodel.errors.InputError` naming the file and the key; what is
readable but suspect (a baseline that looks like metres) is an
:class:`~photomodel.errors.InputWarning`.
"""

from __future__ import annotations

import os
import re
import warnings
from pathlib import Path

import cv2
import numpy as np
from numpy.typing import NDArray

from photomodel._files import write_file_storage
from photomodel._limits import (
    MAX_CALIBRATION_FILE_BYTES,
    MAX_DISTANCE_MM,
    MAX_IMAGE_PIXELS,
    METRES_SUSPECT_MM,
    read_capped,
)
from photomodel.camera._pinhole import PinholeCamera
from photomodel.camera._stereo import StereoRig
from photomodel.errors import InputError, InputWarning

__all__ = ["load_camera", "load_distance_mm", "load_matrix", "load_stereo", "save_camera",
           "save_stereo"]

_MAX_VALUES = 64         # numbers in one key (the largest: a 3x4 projection matrix)
_MAX_NESTING = 2         # [[...], ...]: a matrix written as a list of rows
_METRES_SUSPECT_DISTANCE_MM = 10.0
_CV_REASON = re.compile(r"\((\d+)\): (.*?)'?$")


class _Calibration:
    """A parsed calibration file whose values are read with their types checked."""

    def __init__(self, path: str | os.PathLike[str]) -> None:
        p = Path(path)
        self.path = p
        raw = read_capped(p, "calibration file", MAX_CALIBRATION_FILE_BYTES,
                          " (a calibration is a few kB of YAML, XML or JSON)")
        try:
            text = raw.decode("utf-8").removeprefix("\ufeff")
        except UnicodeDecodeError:
            text = ""
        if "\x00" in text or (raw and not text):
            raise InputError(p, "not a text file (a calibration is YAML, XML or JSON text)")
        if not text.strip():
            raise InputError(p, "calibration file is empty")
        # A ROS 1 `rostopic echo` of a CameraInfo ends with a document marker OpenCV refuses.
        text = re.sub(r"\n---\s*$", "\n", text)
        try:
            fs = cv2.FileStorage(text, cv2.FILE_STORAGE_READ | cv2.FILE_STORAGE_MEMORY)
        except (cv2.error, SystemError) as exc:  # OpenCV 5 wraps cv2.error in SystemError
            cause = exc if isinstance(exc, cv2.error) else exc.__cause__
            reason = _cv_reason(cause) if isinstance(cause, cv2.error) else "parse error"
            raise InputError(p, f"not a readable OpenCV YAML/XML/JSON file ({reason})") from None
        if not fs.isOpened():
            raise InputError(p, "not a readable OpenCV YAML/XML/JSON file")
        self._fs = fs
        self.root = fs.root()
        if not self.root.isMap():
            raise InputError(p, "the file's top level is not a mapping of keys (such as K1, "
                                "D1, R, T)")

    def find(self, names: tuple[str, ...]) -> tuple[str, cv2.FileNode] | None:
        """The first of ``names`` that is present and not null, with its node."""
        for name in names:
            node = self.root.getNode(name)
            if not node.empty() and not node.isNone():
                return name, node
        return None

    def numbers(self, names: tuple[str, ...], counts: tuple[int, ...] | None = None,
                required: bool = True) -> tuple[str, NDArray[np.float64]] | None:
        """The finite numbers (flattened) of the first of ``names``: an ``!!opencv-matrix``,
        a ROS ``{rows, cols, data}`` map, a list (flat or nested) or a single number."""
        found = self.find(names)
        if found is None:
            if required:
                alternatives = f" (or {', '.join(names[1:])})" if len(names) > 1 else ""
                raise InputError(self.path, f"calibration lacks the key {names[0]}{alternatives}")
            return None
        name, node = found
        values = np.asarray(self._values(name, node), dtype=np.float64)
        if counts is not None and values.size not in counts:
            expected = " or ".join(str(c) for c in counts)
            raise InputError(self.path, f"key {name} has {values.size} values, expected "
                                        f"{expected}")
        if not np.isfinite(values).all():
            raise InputError(self.path, f"key {name} contains non-finite values")
        return name, values

    def number(self, names: tuple[str, ...]) -> tuple[str, float] | None:
        """A single finite number under the first of ``names`` (None when absent)."""
        found = self.find(names)
        if found is None:
            return None
        name, node = found
        if not (node.isInt() or node.isReal()):
            raise InputError(self.path, f"key {name} is {_kind(node)}, expected a number")
        value = float(node.real())
        if not np.isfinite(value):
            raise InputError(self.path, f"key {name} must be finite, got {value}")
        return name, value

    def _values(self, name: str, node: cv2.FileNode, depth: int = 0) -> list[float]:
        if node.isInt() or node.isReal():
            return [float(node.real())]
        if node.isMap():
            data = node.getNode("data")
            if data.empty() or data.isNone():
                raise InputError(self.path, f"key {name} is a mapping without a data list")
            if depth >= _MAX_NESTING:
                raise InputError(self.path, f"key {name} is nested too deeply")
            values = self._values(name, data, depth + 1)
            rows, cols = self._dimension(name, node, "rows"), self._dimension(name, node, "cols")
            if rows is not None and cols is not None:
                channels = _channels(node.getNode("dt"))
                if rows * cols * channels != len(values):
                    raise InputError(self.path, f"key {name} says {rows}x{cols} but its data "
                                                f"has {len(values)} values")
            return values
        if node.isSeq():
            size = node.size()
            if size > _MAX_VALUES:
                raise InputError(self.path, f"key {name} has {size} entries, more than a "
                                            "calibration matrix")
            out: list[float] = []
            widths = set()
            for i in range(size):
                item = node.at(i)
                if item.isInt() or item.isReal():
                    out.append(float(item.real()))
                    widths.add(None)
                elif item.isSeq() and depth < _MAX_NESTING:
                    row = self._values(name, item, depth + 1)
                    out.extend(row)
                    widths.add(len(row))
                else:
                    raise InputError(self.path, f"key {name} holds {_kind(item)}, expected "
                                                "numbers")
            if len(widths) > 1:
                raise InputError(self.path, f"key {name} is a ragged list (its rows differ in "
                                            "length)")
            if len(out) > _MAX_VALUES:
                raise InputError(self.path, f"key {name} has {len(out)} values, more than a "
                                            "calibration matrix")
            return out
        raise InputError(self.path, f"key {name} is {_kind(node)}, expected numbers")

    def _dimension(self, name: str, node: cv2.FileNode, key: str) -> int | None:
        dim = node.getNode(key)
        if dim.empty() or dim.isNone():
            return None
        value = float(dim.real()) if (dim.isInt() or dim.isReal()) else -1.0
        if not (0 <= value <= _MAX_VALUES and value == int(value)):
            raise InputError(self.path, f"key {name}: {key} must be a small whole number")
        return int(value)

    def image_size(self) -> tuple[int, int]:
        """(width, height) from ``image_width``/``image_height`` (or a CameraInfo's
        ``width``/``height``); (0, 0) when absent or 0 (unknown)."""
        size = []
        for names in (("image_width", "width"), ("image_height", "height")):
            found = self.number(names)
            if found is None:
                size.append(0)
                continue
            name, value = found
            if value < 0 or value != int(value) or value > MAX_IMAGE_PIXELS:
                raise InputError(self.path, f"key {name} must be a whole number of pixels "
                                            f"(0 for unknown), got {value:g}")
            size.append(int(value))
        width, height = size
        if (width == 0) != (height == 0):
            raise InputError(self.path, "the image size needs both image_width and "
                                        "image_height (or neither)")
        if width * height > MAX_IMAGE_PIXELS:
            raise InputError(self.path, f"image size {width}x{height} is more than the "
                                        f"{MAX_IMAGE_PIXELS / 1e6:.0f} megapixels photomodel "
                                        "reads")
        return width, height

    def camera(self, k_names: tuple[str, ...], d_names: tuple[str, ...],
               size: tuple[int, int]) -> PinholeCamera:
        found_k = self.numbers(k_names, (9,))
        assert found_k is not None
        k_name, K = found_k
        found_d = self.numbers(d_names, required=False)
        d_name, D = found_d if found_d is not None else (d_names[0], np.zeros(0))
        try:
            camera = PinholeCamera(K.reshape(3, 3), D, *size)
        except ValueError as exc:
            raise InputError(self.path, _renamed(str(exc), {"K": k_name, "dist": d_name})) \
                from None
        cx, cy = camera.K[0, 2], camera.K[1, 2]
        width, height = size
        if width and not (0 <= cx <= width and 0 <= cy <= height):
            warnings.warn(InputWarning(self.path, f"{k_name}: principal point ({cx:g}, {cy:g}) "
                                                  f"lies outside the {width}x{height} image"),
                          stacklevel=3)
        return camera


    def release(self) -> None:
        """Free the parsed file (the values read stay valid)."""
        self._fs.release()


def _cv_reason(exc: cv2.error) -> str:
    """The parser's complaint, short and on one line ('line 3: Key may not start ...')."""
    text = str(exc).strip().splitlines()
    last = text[-1] if text else ""
    found = _CV_REASON.search(last)
    reason = f"line {found.group(1)}: {found.group(2)}" if found else last.split(") ", 1)[-1]
    reason = reason.strip() or "parse error"
    return reason if len(reason) <= 100 else reason[:97] + "..."


def _kind(node: cv2.FileNode) -> str:
    """A node's type in words, for a message."""
    if node.isString():
        text = node.string()
        return f"the text {text[:20]!r}" + ("..." if len(text) > 20 else "")
    if node.isMap():
        return "a mapping"
    if node.isSeq():
        return "a list"
    return "empty" if node.empty() or node.isNone() else "not a number"


def _channels(dt: cv2.FileNode) -> int:
    """Channels of an ``!!opencv-matrix``'s ``dt`` ("d" = 1, "3f" = 3)."""
    if dt.empty() or not dt.isString():
        return 1
    digits = re.match(r"\d+", dt.string())
    return int(digits.group()) if digits and 0 < int(digits.group()) <= 4 else 1


def _renamed(message: str, names: dict[str, str]) -> str:
    """``PinholeCamera``'s "K: ..." / "dist: ..." with the file's own key names."""
    field, sep, rest = message.partition(": ")
    return f"{names[field]}: {rest}" if sep and field in names else message


def load_camera(path: str | os.PathLike[str]) -> PinholeCamera:
    """Read a single camera (``camera_matrix``/``K``, ``distortion_coefficients``/``D``).

    Parameters
    ----------
    path : path-like
        OpenCV YAML/XML/JSON written by ``cv2.FileStorage``, or a ROS ``camera_info`` YAML.

    Raises
    ------
    InputError
        The file is missing, unreadable, lacks the camera matrix or holds implausible values.
    """
    calibration = _Calibration(path)
    return calibration.camera(("camera_matrix", "K", "k"),
                              ("distortion_coefficients", "D", "d"),
                              calibration.image_size())


def load_distance_mm(path: str | os.PathLike[str]) -> float | None:
    """The optional ``distance_mm`` of a model-station camera file (None when absent).

    Raises
    ------
    InputError
        The value is not a number, not positive or beyond
        :data:`~photomodel._limits.MAX_DISTANCE_MM`.

    Warns
    -----
    InputWarning
        The distance is under 10 mm: it was probably given in metres.
    """
    calibration = _Calibration(path)
    found = calibration.number(("distance_mm",))
    if found is None:
        return None
    _, value = found
    if not 0 < value <= MAX_DISTANCE_MM:
        raise InputError(calibration.path, f"distance_mm must be positive and at most "
                                           f"{MAX_DISTANCE_MM:g} mm, got {value:g}")
    if value < _METRES_SUSPECT_DISTANCE_MM:
        warnings.warn(InputWarning(calibration.path, f"distance_mm = {value:g} looks like metres "
                                                     f"(it is in millimetres: "
                                                     f"{value * 1000:g}?)"), stacklevel=2)
    return value


def load_matrix(path: str | os.PathLike[str], key: str, shape: tuple[int, ...]
                ) -> NDArray[np.float64]:
    """The matrix under ``key`` of a calibration file that holds more than a camera (the
    hand-eye file's ``T_hand_cam1``, for instance), read and checked as a camera's are.

    Parameters
    ----------
    path : path-like
        OpenCV YAML/XML/JSON written by ``cv2.FileStorage`` (an ``!!opencv-matrix``, a ROS
        ``{rows, cols, data}`` mapping or a list, flat or nested).
    key : str
    shape : tuple of int
        The matrix's shape; the key must hold exactly ``prod(shape)`` numbers.

    Returns
    -------
    ndarray ``shape`` float64

    Raises
    ------
    InputError
        The file is missing or unreadable, lacks ``key``, or ``key`` holds other than
        ``prod(shape)`` finite numbers.
    """
    calibration = _Calibration(path)
    try:
        found = calibration.numbers((key,), (int(np.prod(shape)),))
    finally:
        calibration.release()
    assert found is not None   # required: raised when absent
    return found[1].reshape(shape)


def load_stereo(path: str | os.PathLike[str]) -> StereoRig:
    """Read the hand's stereo calibration (``K1``/``M1``, ``D1``, ``K2``/``M2``, ``D2``, ``R``,
    ``T``).

    Camera 1 is the reference (the paper's right camera); ``X2 = R X1 + T`` with ``T`` in mm.
    ``R`` may also be given as a Rodrigues vector (3 values).

    Raises
    ------
    InputError
        The file is missing, unreadable, lacks a key or holds implausible values (focal
        lengths, distortion, a non-rotation ``R``, a non-finite or huge ``T``).

    Warns
    -----
    InputWarning
        The baseline ``|T|`` is under 1 mm: ``T`` was probably given in metres.
    """
    calibration = _Calibration(path)
    p = calibration.path
    size = calibration.image_size()
    cam1 = calibration.camera(("K1", "M1"), ("D1",), size)
    cam2 = calibration.camera(("K2", "M2"), ("D2",), size)
    found_r, found_t = calibration.numbers(("R",), (9, 3)), calibration.numbers(("T",), (3,))
    assert found_r is not None and found_t is not None
    R, T = found_r[1], found_t[1]
    if R.size == 3:
        try:
            R = cv2.Rodrigues(R)[0]
        except (cv2.error, SystemError):
            raise InputError(p, "R: not a valid Rodrigues rotation vector") from None
    try:
        rig = StereoRig(cam1, cam2, R.reshape(3, 3), T)
    except ValueError as exc:
        raise InputError(p, str(exc)) from None
    baseline = float(np.linalg.norm(rig.T))
    if baseline < METRES_SUSPECT_MM:
        problem = ("T is zero: the two cameras are at the same place" if baseline == 0 else
                   f"T = ({', '.join(f'{t:g}' for t in rig.T)}): a baseline of {baseline:g} mm "
                   f"looks like metres (T is in millimetres: {baseline * 1000:g} mm?)")
        warnings.warn(InputWarning(p, problem), stacklevel=2)
    return rig


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

    write_file_storage(Path(path), write)


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

    write_file_storage(Path(path), write)
