"""``opencv:R,L``: two ``cv2.VideoCapture`` as the stereo pair (camera 1 = R, the right one).

Each of ``R`` and ``L`` is a device number (``0``: ``/dev/video0`` through V4L2 on Linux), a
path (``/dev/video2``, a video file) or a GStreamer pipeline (it holds ``!``); two pipelines
whose text holds commas are separated by ``;`` instead (``opencv:PIPE1;PIPE2``).

A pair is taken as OpenCV advises for several cameras: ``grab()`` on both first (each only
latches its newest frame, quickly), then ``retrieve()`` on both (the slower decode), so that
the two views are as close in time as the cameras allow. Timestamps:

- a device or pipeline: the source's clock just after each camera's ``grab()`` returned (the
  frame's arrival; cameras with a hardware trigger give the truest pairs). A buffer of one
  frame is asked for (``CAP_PROP_BUFFERSIZE``), so that a trigger does not get a stale one
  where the driver honours it;
- two video files: each file's own frame time (``CAP_PROP_POS_MSEC``) after the clock's time
  at opening, so that two files out of step show as skew (a file beside a device: the clock
  for both). Files are read frame after frame as fast as grabs come, and do not loop: the end
  of a file stops the source (and the service re-opens it, from its start).
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Iterator
from typing import Any

import cv2
import numpy as np
from numpy.typing import NDArray

from photomodel.camera import StereoRig
from photomodel.errors import InputError
from photomodel.service._source import Clock, SourceError, StereoGrab

__all__ = ["OpenCVSource", "split_pair"]

_WHICH = ("camera 1 (right)", "camera 2 (left)")


def split_pair(args: str) -> tuple[str, str]:
    """``R,L`` (or ``R;L``) as its two parts; InputError naming ``--source`` otherwise."""
    sep = ";" if ";" in args else ","
    parts = [p.strip() for p in args.split(sep)]
    if len(parts) != 2 or not all(parts):
        raise InputError("--source", f"opencv: expected two cameras, opencv:R,L (device "
                                     f"numbers, paths or pipelines; ';' between two pipelines "
                                     f"that hold commas), got {args!r}")
    return parts[0], parts[1]


@contextlib.contextmanager
def _quiet_opencv() -> Iterator[None]:
    """OpenCV's own warnings (a device that does not open) off while opening: the service
    says what went wrong in one line."""
    level = cv2.utils.logging.getLogLevel()
    cv2.utils.logging.setLogLevel(cv2.utils.logging.LOG_LEVEL_ERROR)
    try:
        yield
    finally:
        cv2.utils.logging.setLogLevel(level)


class _Camera:
    """One ``VideoCapture`` and what kind of input it reads."""

    def __init__(self, target: str, which: str) -> None:
        self.target = target
        self.which = which
        self.is_file = os.path.isfile(target)
        with _quiet_opencv():
            if target.isdigit():
                self.capture = cv2.VideoCapture(int(target))
            elif "!" in target:
                self.capture = cv2.VideoCapture(target, cv2.CAP_GSTREAMER)
            else:
                self.capture = cv2.VideoCapture(target)
        if not self.capture.isOpened():
            self.capture.release()
            kind = ("video file" if self.is_file else "GStreamer pipeline" if "!" in target
                    else "device")
            raise InputError("--source", f"opencv: {which} {target!r}: cannot open this "
                                         f"{kind} (missing, busy, or a format OpenCV cannot "
                                         "read)")
        if not self.is_file:
            self.capture.set(cv2.CAP_PROP_BUFFERSIZE, 1)

    def size(self) -> tuple[int, int]:
        """(width, height) the capture reports (0 when unknown)."""
        return (int(self.capture.get(cv2.CAP_PROP_FRAME_WIDTH)),
                int(self.capture.get(cv2.CAP_PROP_FRAME_HEIGHT)))

    def fps(self) -> float | None:
        fps = float(self.capture.get(cv2.CAP_PROP_FPS))
        return fps if np.isfinite(fps) and fps > 0 else None

    def position_s(self) -> float:
        """The grabbed frame's time in a file, s."""
        return float(self.capture.get(cv2.CAP_PROP_POS_MSEC)) / 1000.0

    def retrieve(self, name: str) -> NDArray[np.uint8]:
        ok, image = self.capture.retrieve()
        if not ok or image is None:
            raise SourceError(name, f"{self.which} {self.target!r}: the grabbed frame could not "
                                    "be decoded")
        if image.ndim == 2:
            image = cv2.cvtColor(image, cv2.COLOR_GRAY2BGR)
        return np.ascontiguousarray(image)

    def release(self) -> None:
        self.capture.release()


class OpenCVSource:
    """Two ``cv2.VideoCapture`` grabbed together (made by :meth:`open`).

    Attributes
    ----------
    name : str
    fps : float or None
        Camera 1's frame rate as OpenCV reports it (None when it does not).
    """

    def __init__(self, name: str, right: _Camera, left: _Camera, clock: Clock) -> None:
        self.name = name
        self._cameras = (right, left)
        self._clock = clock
        self._t0_s = clock()
        self._index = 0
        self._file_times = right.is_file and left.is_file   # a file and a device: the clock
        self.fps = right.fps()

    @classmethod
    def open(cls, args: str, rig: StereoRig, *, clock: Clock) -> OpenCVSource:
        """Open both cameras; checks the sizes they report against each other and ``rig``."""
        targets = split_pair(args)
        name = f"opencv:{args}"
        right = _Camera(targets[0], _WHICH[0])
        try:
            left = _Camera(targets[1], _WHICH[1])
        except BaseException:
            right.release()
            raise
        source = cls(name, right, left, clock)
        try:
            source._check_sizes(rig)
        except BaseException:
            source.close()
            raise
        return source

    def _check_sizes(self, rig: StereoRig) -> None:
        (w1, h1), (w2, h2) = (c.size() for c in self._cameras)
        if w1 and h1 and w2 and h2 and (w1, h1) != (w2, h2):
            raise SourceError(self.name, f"views of different sizes: {_WHICH[0]} {w1}x{h1} "
                                         f"px, {_WHICH[1]} {w2}x{h2} px")
        for camera, (w, h), which in ((rig.cam1, (w1, h1), _WHICH[0]),
                                      (rig.cam2, (w2, h2), _WHICH[1])):
            if w and h and camera.width_px and (w, h) != (camera.width_px, camera.height_px):
                raise SourceError(self.name, f"{which} gives {w}x{h} px but the calibration "
                                             f"is for {camera.width_px}x{camera.height_px} px")

    def grab(self, timeout_s: float, *, newest: bool = True) -> StereoGrab:
        """Grab both, then retrieve both (the timeout is the drivers'; OpenCV has none)."""
        stamps = []
        for camera in self._cameras:
            if not camera.capture.grab():
                end = "end of the video" if camera.is_file else "no frame (device gone?)"
                raise SourceError(self.name, f"{camera.which} {camera.target!r}: {end}")
            stamps.append(self._clock())
        right, left = (c.retrieve(self.name) for c in self._cameras)
        if self._file_times:
            t_right, t_left = (self._t0_s + c.position_s() for c in self._cameras)
        else:
            t_right, t_left = stamps
        index = self._index
        self._index += 1
        return StereoGrab(right, left, t_right, t_left, index)

    def close(self) -> None:
        for camera in self._cameras:
            camera.release()

    def describe(self) -> dict[str, Any]:
        right, left = self._cameras
        return {"kind": "opencv", "right": right.target, "left": left.target,
                "files": right.is_file and left.is_file, "fps": self.fps}
