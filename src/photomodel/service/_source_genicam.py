"""``genicam:R,L[,cti=PRODUCER.cti]``: two GenICam cameras through ``harvesters`` (optional
extra ``genicam``: ``pip install 'photomodel[genicam]'``).

``R`` and ``L`` select camera 1 (right) and camera 2 (left) among the devices the GenTL
producers list: a serial number, a device id or a user-defined name, else a position in the
list (``0``, ``1``, ...). The producers are the ``cti=`` files of the spec (repeatable), else
the ``.cti`` files of the folders in ``GENICAM_GENTL64_PATH`` (the GenTL standard's variable).

Each camera is opened as it is configured (free-running or triggered; a GenICam tool sets
that), except: its ``Width`` and ``Height`` are set to the calibration's when they differ
and the camera allows it, and a camera whose ``PixelFormat`` photomodel does not read is
switched to one it reads where the camera offers one (:data:`PIXEL_FORMATS`; colour only:
a monochrome camera is refused). Each grab drops the frames already waiting, then waits for
both cameras' next frames at once (one thread each): each view's timestamp is the clock
when its frame arrived (the cameras' own clocks are not shared, unless PTP is set up, so
they are not used). A camera that sends no frame within the grab's timeout has stopped.
"""

from __future__ import annotations

import os
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

import cv2
import numpy as np
from numpy.typing import NDArray

from photomodel.camera import StereoRig
from photomodel.errors import InputError
from photomodel.service._source import Clock, SourceError, StereoGrab

__all__ = ["PIXEL_FORMATS", "GenICamSource", "to_bgr"]

PIXEL_FORMATS = {"BGR8": None, "RGB8": cv2.COLOR_RGB2BGR, "BGRa8": cv2.COLOR_BGRA2BGR,
                 "RGBa8": cv2.COLOR_RGBA2BGR}
"""The GenICam pixel formats read, with the OpenCV conversion to BGR (None: as it is)."""

_CHANNELS = {"BGR8": 3, "RGB8": 3, "BGRa8": 4, "RGBa8": 4}
_WHICH = ("camera 1 (right)", "camera 2 (left)")


def to_bgr(data: NDArray[np.uint8], width: int, height: int, pixel_format: str
           ) -> NDArray[np.uint8]:
    """A buffer's pixels (1-D, row after row) as a BGR (H, W, 3) uint8 image (a copy).

    Raises
    ------
    ValueError
        A pixel format not in :data:`PIXEL_FORMATS`, or data of another length.
    """
    if pixel_format not in PIXEL_FORMATS:
        raise ValueError(f"pixel format {pixel_format} is not read (expected one of "
                         f"{', '.join(PIXEL_FORMATS)})")
    channels = _CHANNELS[pixel_format]
    if data.size != width * height * channels:
        raise ValueError(f"{data.size} bytes for a {width}x{height} {pixel_format} image "
                         f"({width * height * channels} expected)")
    image = np.asarray(data, dtype=np.uint8).reshape(height, width, channels)
    code = PIXEL_FORMATS[pixel_format]
    return image.copy() if code is None else cv2.cvtColor(image, code)


def _options(args: str) -> tuple[list[str], list[Path]]:
    """(the two selectors, the producer files) of ``genicam:`` arguments."""
    selectors, producers = [], []
    for item in (a.strip() for a in args.split(",")):
        key, eq, value = item.partition("=")
        if eq and key == "cti":
            producers.append(Path(value).expanduser())
        elif eq:
            raise InputError("--source", f"genicam: unknown option {key!r} (expected cti=PATH)")
        elif item:
            selectors.append(item)
    if len(selectors) != 2:
        raise InputError("--source", f"genicam: expected two cameras, genicam:R,L[,cti=PATH] "
                                     f"(serial numbers, ids, names or positions), got {args!r}")
    if not producers:
        for folder in os.environ.get("GENICAM_GENTL64_PATH", "").split(os.pathsep):
            if folder and Path(folder).is_dir():
                producers += sorted(Path(folder).glob("*.cti"))
    if not producers:
        raise InputError("--source", "genicam: no GenTL producer: give cti=PATH or set "
                                     "GENICAM_GENTL64_PATH")
    for path in producers:
        if not path.is_file():
            raise InputError("--source", f"genicam: producer {path}: no such file")
    return selectors, producers


def _node(node_map: Any, name: str) -> Any:
    return getattr(node_map, name) if node_map.has_node(name) else None


class _Camera:
    """One opened ``ImageAcquirer``, acquiring."""

    def __init__(self, acquirer: Any, selector: str, which: str) -> None:
        self.acquirer = acquirer
        self.selector = selector
        self.which = which

    def configure(self, name: str, width: int, height: int) -> None:
        """The calibration's image size and a pixel format :func:`to_bgr` reads."""
        nodes = self.acquirer.remote_device.node_map
        for key, value in (("Width", width), ("Height", height)):
            node = _node(nodes, key)
            if node is None or not value or node.value == value:
                continue
            try:
                node.value = value
            except Exception as exc:  # noqa: BLE001 - the GenApi's own error types
                raise SourceError(name, f"{self.which} {self.selector!r}: {key} is "
                                        f"{node.value} px and cannot be set to the "
                                        f"calibration's {value} ({exc})") from None
        fmt = _node(nodes, "PixelFormat")
        if fmt is None or fmt.value in PIXEL_FORMATS:
            return
        usable = [s for s in fmt.symbolics if s in PIXEL_FORMATS]
        if not usable:
            raise SourceError(name, f"{self.which} {self.selector!r}: pixel format "
                                    f"{fmt.value}, and it offers no colour format photomodel "
                                    f"reads ({', '.join(PIXEL_FORMATS)}): the method needs "
                                    "colour")
        fmt.value = usable[0]

    def fps(self) -> float | None:
        node = _node(self.acquirer.remote_device.node_map, "AcquisitionFrameRate")
        try:
            return float(node.value) if node is not None and node.value > 0 else None
        except Exception:  # noqa: BLE001 - a rate the camera does not say
            return None

    def next_frame(self, name: str, timeout_s: float, clock: Clock
                   ) -> tuple[NDArray[np.uint8], float]:
        """The first frame that arrives from now: its BGR image and the clock at arrival."""
        while True:                          # drop what waits: a trigger wants a fresh frame
            held = self.acquirer.try_fetch(timeout=0.001)    # 0 would wait for one
            if held is None:
                break
            held.queue()
        try:
            buffer = self.acquirer.fetch(timeout=timeout_s)
        except Exception as exc:  # noqa: BLE001 - harvesters' timeout and transport errors
            raise SourceError(name, f"{self.which} {self.selector!r}: no frame within "
                                    f"{timeout_s:g} s ({type(exc).__name__}): camera gone "
                                    "or not triggered?") from None
        t_s = clock()
        with buffer:
            part = buffer.payload.components[0]
            try:
                image = to_bgr(part.data, part.width, part.height, part.data_format)
            except ValueError as exc:
                raise SourceError(name, f"{self.which} {self.selector!r}: {exc}",
                                  stopped=False) from None
        return image, t_s

    def close(self) -> None:
        try:
            self.acquirer.stop()
        finally:
            self.acquirer.destroy()


def _info(info: Any, key: str) -> str | None:
    """A device's ``key`` (serial_number, id_, user_defined_name), None where the producer
    does not say."""
    try:
        value = getattr(info, key)
    except Exception:  # noqa: BLE001 - GenTL's NotAvailableException and kin
        return None
    return None if value is None else str(value)


def _find(devices: list[Any], selector: str, which: str) -> int:
    """The position of the device that ``selector`` names."""
    for k, info in enumerate(devices):
        if selector in (_info(info, "serial_number"), _info(info, "id_"),
                        _info(info, "user_defined_name")):
            return k
    if selector.isdigit() and int(selector) < len(devices):
        return int(selector)
    names = ", ".join(f"{_info(info, 'serial_number')} ({_info(info, 'id_')})"
                      for info in devices) or "none"
    raise InputError("--source", f"genicam: {which} {selector!r}: no such device (found: "
                                 f"{names})")


class GenICamSource:
    """Two GenICam cameras (made by :meth:`open`).

    Attributes
    ----------
    name : str
    fps : float or None
        Camera 1's ``AcquisitionFrameRate``, None when it has none.
    """

    def __init__(self, name: str, harvester: Any, cameras: tuple[_Camera, _Camera],
                 clock: Clock) -> None:
        self.name = name
        self._harvester = harvester
        self._cameras = cameras
        self._clock = clock
        self._index = 0
        self._waiters = ThreadPoolExecutor(2, thread_name_prefix="photomodel-genicam")
        self.fps = cameras[0].fps()

    @classmethod
    def open(cls, args: str, rig: StereoRig, *, clock: Clock) -> GenICamSource:
        """Open both cameras through the producers; sizes and pixel formats as the module
        says."""
        selectors, producers = _options(args)
        try:
            from harvesters.core import Harvester
        except ImportError:
            raise InputError("--source", "genicam needs the optional extra: pip install "
                                         "'photomodel[genicam]' (harvesters)") from None
        name = f"genicam:{args}"
        harvester = Harvester()
        cameras: list[_Camera] = []
        try:
            for path in producers:
                harvester.add_file(str(path), check_existence=True)
            harvester.update()
            devices = list(harvester.device_info_list)
            positions = [_find(devices, s, w) for s, w in zip(selectors, _WHICH, strict=True)]
            if positions[0] == positions[1]:
                raise InputError("--source", f"genicam: {selectors[0]!r} and {selectors[1]!r} "
                                             "are the same camera")
            for position, selector, which, camera in zip(positions, selectors, _WHICH,
                                                         (rig.cam1, rig.cam2), strict=True):
                opened = _Camera(harvester.create(position), selector, which)
                cameras.append(opened)
                opened.configure(name, camera.width_px, camera.height_px)
            for opened in cameras:
                opened.acquirer.start()
        except BaseException:
            for opened in cameras:
                opened.close()
            harvester.reset()
            raise
        return cls(name, harvester, (cameras[0], cameras[1]), clock)

    def grab(self, timeout_s: float, *, newest: bool = True) -> StereoGrab:
        waits = [self._waiters.submit(c.next_frame, self.name, timeout_s, self._clock)
                 for c in self._cameras]
        (right, t_right), (left, t_left) = (w.result() for w in waits)
        index = self._index
        self._index += 1
        return StereoGrab(right, left, t_right, t_left, index)

    def close(self) -> None:
        try:
            for camera in self._cameras:
                try:
                    camera.close()
                except Exception:  # noqa: BLE001 - a camera gone cannot be stopped
                    pass
        finally:
            self._harvester.reset()
            self._waiters.shutdown(wait=False)

    def describe(self) -> dict[str, Any]:
        return {"kind": "genicam", "right": self._cameras[0].selector,
                "left": self._cameras[1].selector, "fps": self.fps}
