"""Camera sources: where the service's stereo pairs come from when it owns the cameras.

One small interface in the manner of OpenCV's ``VideoCapture`` (:class:`CameraSource`:
``grab(timeout_s) -> StereoGrab``, ``close()``), one module per kind, chosen by a spec string
(:func:`open_source`, ``photomodel serve --source SPEC``):

- ``sim[:GARMENT][,conveyor=MM_S][,seed=N]``: the simulated hand cameras above a catalogue
  garment on the table (:mod:`._source_sim`);
- ``replay:DIR``: a recorded sequence or a folder of stereo pairs, at its frame rate, looping
  (:mod:`._source_replay`);
- ``opencv:R,L``: two ``cv2.VideoCapture`` (device numbers, paths, GStreamer pipelines,
  video files; ``;`` between two pipelines that hold commas) (:mod:`._source_opencv`);
- ``genicam:R,L[,cti=PRODUCER]``: two GenICam cameras through ``harvesters`` (optional
  extra ``genicam``) (:mod:`._source_genicam`).

Every pair passes the same checks (:class:`CheckedSource`): two colour views of the
calibration's sizes whose timestamps lie at most ``max_skew_ms`` apart; otherwise a
:class:`SourceError` says why (docs/method/sources.md).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Protocol, runtime_checkable

import numpy as np
from numpy.typing import NDArray

from photomodel.camera import StereoRig
from photomodel.errors import InputError

__all__ = ["DEFAULT_MAX_SKEW_MS", "SOURCE_KINDS", "CameraSource", "CheckedSource",
           "SourceError", "StereoGrab", "open_source", "parse_source_spec"]

DEFAULT_MAX_SKEW_MS = 5.0
"""Largest difference between a pair's two timestamps, ms (``--max-skew-ms``): at the
servo's 200 mm/s belt the garment moves 1 mm in 5 ms, about the method's accuracy."""

MAX_SKEW_BOUND_MS = 10_000.0
"""Largest ``max_skew_ms`` taken (anything above checks nothing)."""

SOURCE_KINDS = ("sim", "replay", "opencv", "genicam")
"""The kinds a spec may name."""

Clock = Callable[[], float]


class SourceError(InputError):
    """A camera source that cannot deliver a pair (HTTP 503).

    Parameters
    ----------
    source : str
        The source's name (its spec) or the option that named it.
    problem : str
        What went wrong, in words an operator can act on.
    stopped : bool
        True when the source itself stopped (end of a file, a folder or device gone): the
        service closes it and re-opens it in the background. False when only this pair was
        refused (the cameras' timestamps too far apart, views of another size).
    """

    def __init__(self, source: str, problem: str, *, stopped: bool = True) -> None:
        super().__init__(source, problem)
        self.stopped = stopped

    def __reduce__(self) -> tuple[Any, ...]:
        return _source_error, (self.source, self.problem, self.stopped)


def _source_error(source: str, problem: str, stopped: bool) -> SourceError:
    return SourceError(source, problem, stopped=stopped)


@dataclass(frozen=True)
class StereoGrab:
    """One stereo pair from a source.

    Attributes
    ----------
    right_bgr, left_bgr : ndarray (H, W, 3) uint8
        Camera 1's (the right camera, the reference) and camera 2's views, BGR.
    t_right_s, t_left_s : float
        When each camera's view was taken (unix seconds on the source's clock).
    index : int
        The pair's number since the source was opened (from 0; a paced source skips the
        numbers of the frames nobody asked for).
    """

    right_bgr: NDArray[np.uint8]
    left_bgr: NDArray[np.uint8]
    t_right_s: float
    t_left_s: float
    index: int

    @property
    def t_s(self) -> float:
        """The pair's time: the mean of its two timestamps, unix seconds."""
        return 0.5 * (self.t_right_s + self.t_left_s)

    @property
    def skew_ms(self) -> float:
        """How far apart the two views were taken, ms (>= 0)."""
        return abs(self.t_right_s - self.t_left_s) * 1000.0


@runtime_checkable
class CameraSource(Protocol):
    """What the service grabs stereo pairs from.

    Attributes
    ----------
    name : str
        The spec it was opened from (``replay:/data/seq``), for messages and answers.
    fps : float or None
        Its frame rate, None when pairs are made on demand (a triggered camera, the sim).
    """

    name: str
    fps: float | None

    def grab(self, timeout_s: float, *, newest: bool = True) -> StereoGrab:
        """The next pair, taken after the call began (waits at most about ``timeout_s``);
        :class:`SourceError` when none can be had.

        ``newest``: the newest frame (a trigger; GenICam's ``NewestOnly`` buffer handling);
        False: the oldest frame not given yet that the source still holds in its buffers (a
        stream; ``OldestFirst``), so that a reader late for a moment loses no frame. A
        source without buffers (the sim, OpenCV's capture) takes a pair when asked either
        way."""
        ...

    def close(self) -> None:
        """Release the cameras or files (idempotent)."""
        ...

    def describe(self) -> dict[str, Any]:
        """JSON-ready facts about the source (kind, files, frame rate) for ``/health``."""
        ...


def parse_source_spec(spec: str) -> tuple[str, str]:
    """Split ``KIND[:ARGS]`` into its kind and arguments.

    Raises
    ------
    InputError
        Naming ``--source``: an empty spec, an unknown kind, a kind without its arguments.
    """
    if not isinstance(spec, str) or not spec.strip():
        raise InputError("--source", "expected a camera source: sim, replay:DIR, opencv:R,L "
                                     "or genicam:R,L")
    kind, sep, args = spec.strip().partition(":")
    if kind not in SOURCE_KINDS:
        raise InputError("--source", f"unknown kind {kind!r} in {spec!r} (expected sim, "
                                     "replay:DIR, opencv:R,L or genicam:R,L)")
    if kind != "sim" and not args.strip():
        example = {"replay": "replay:DIR", "opencv": "opencv:R,L"}.get(kind, "genicam:R,L")
        raise InputError("--source", f"{kind} needs its arguments: {example}")
    if kind == "sim" and sep and not args.strip():
        raise InputError("--source", "sim: expected sim, sim:GARMENT or "
                                     "sim:GARMENT,conveyor=MM_S")
    return kind, args.strip()


def open_source(spec: str, rig: StereoRig, *, max_skew_ms: float = DEFAULT_MAX_SKEW_MS,
                clock: Clock = time.time) -> CheckedSource:
    """Open the camera source ``spec`` for the rig ``rig``.

    Parameters
    ----------
    spec : str
        ``sim[:GARMENT][,conveyor=MM_S][,seed=N]``, ``replay:DIR``, ``opencv:R,L`` or
        ``genicam:R,L[,cti=PRODUCER]``.
    rig : StereoRig
        The service's stereo calibration: every pair must have its image sizes (and the sim
        renders only the simulated hand rig).
    max_skew_ms : float
        Largest difference between a pair's two timestamps, ms (0 to 10000).
    clock : callable
        The source's clock, unix seconds (tests give their own).

    Returns
    -------
    CheckedSource
        The source, its pairs checked.

    Raises
    ------
    InputError
        A bad spec (naming ``--source``), or a source that cannot be opened
        (:class:`SourceError`: a missing folder, a device that does not open, views of
        other sizes than the calibration's).
    """
    if not (np.isfinite(max_skew_ms) and 0.0 <= max_skew_ms <= MAX_SKEW_BOUND_MS):
        raise InputError("--max-skew-ms", f"expected 0 to {MAX_SKEW_BOUND_MS:g} ms, got "
                                          f"{max_skew_ms:g}")
    kind, args = parse_source_spec(spec)
    source: CameraSource
    if kind == "sim":
        from photomodel.service._source_sim import SimSource

        source = SimSource.open(args, rig, clock=clock)
    elif kind == "replay":
        from photomodel.service._source_replay import ReplaySource

        source = ReplaySource.open(args, rig, clock=clock)
    elif kind == "genicam":
        from photomodel.service._source_genicam import GenICamSource

        source = GenICamSource.open(args, rig, clock=clock)
    else:
        from photomodel.service._source_opencv import OpenCVSource

        source = OpenCVSource.open(args, rig, clock=clock)
    return CheckedSource(source, rig, max_skew_ms)


class CheckedSource:
    """A source whose every pair is checked: two (H, W, 3) uint8 views of the calibration's
    sizes, taken at most ``max_skew_ms`` apart (:class:`SourceError` with ``stopped=False``
    otherwise: the pair is refused, the source goes on).

    Parameters
    ----------
    source : CameraSource
    rig : StereoRig
    max_skew_ms : float
    """

    def __init__(self, source: CameraSource, rig: StereoRig,
                 max_skew_ms: float = DEFAULT_MAX_SKEW_MS) -> None:
        self.source = source
        self.rig = rig
        self.max_skew_ms = float(max_skew_ms)
        self.name = source.name
        self.fps = source.fps

    def grab(self, timeout_s: float, *, newest: bool = True) -> StereoGrab:
        grab = self.source.grab(timeout_s, newest=newest)
        self.check(grab)
        return grab

    def check(self, grab: StereoGrab) -> None:
        """Raise :class:`SourceError` (``stopped=False``) for a pair the search cannot use."""
        shapes = []
        for image, which in ((grab.right_bgr, "camera 1 (right)"),
                             (grab.left_bgr, "camera 2 (left)")):
            if not (isinstance(image, np.ndarray) and image.dtype == np.uint8 and
                    image.ndim == 3 and image.shape[2] == 3):
                got = (f"{image.dtype} {image.shape}" if isinstance(image, np.ndarray)
                       else type(image).__name__)
                raise SourceError(self.name, f"{which} gave a {got} image; expected colour "
                                             "(H, W, 3) uint8", stopped=False)
            shapes.append(image.shape)
        if shapes[0] != shapes[1]:
            (h1, w1, _), (h2, w2, _) = shapes
            raise SourceError(self.name, f"views of different sizes: camera 1 (right) "
                                         f"{w1}x{h1} px, camera 2 (left) {w2}x{h2} px",
                              stopped=False)
        for camera, image, which in ((self.rig.cam1, grab.right_bgr, "camera 1 (right)"),
                                     (self.rig.cam2, grab.left_bgr, "camera 2 (left)")):
            try:
                camera.check_image(image, which)
            except InputError as exc:
                raise SourceError(self.name, str(exc), stopped=False) from None
        skew_ms = grab.skew_ms
        if not np.isfinite(skew_ms) or skew_ms > self.max_skew_ms:
            raise SourceError(self.name, f"unsynchronised cameras: the views were taken "
                                         f"{skew_ms:.1f} ms apart, above --max-skew-ms "
                                         f"{self.max_skew_ms:g}", stopped=False)

    def close(self) -> None:
        self.source.close()

    def describe(self) -> dict[str, Any]:
        return {**self.source.describe(), "max_skew_ms": self.max_skew_ms}
