"""``sim``: the simulated cell's hand cameras as a camera source.

The hand rig stands at the photographing pose above the table (the working distance); a
catalogue garment lies on it, on a belt that runs at ``conveyor`` mm/s (0 by default), as
:class:`~photomodel.sim.ConveyorView` renders it. Each grab renders the view at the clock's
time: both views share one timestamp (the cameras are simulated as hardware-triggered).

The service's calibration must be the simulated hand rig's (what ``photomodel simulate``,
and so ``make serve`` and ``photomodel demo``, write as ``stereo.yaml``): the sim renders that
rig and refuses another, whose poses would not match its images.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

from photomodel.camera import StereoRig
from photomodel.errors import InputError
from photomodel.service._source import Clock, SourceError, StereoGrab

__all__ = ["LOOP_MM", "STILL_FRAMES", "SimSource", "matching_hand_rig"]

DEFAULT_GARMENT = "No.3"
"""The garment a bare ``sim`` shows (the paper's Table 1 garment)."""

LOOP_MM = 400.0
"""On a running belt the scene starts over after the garment has travelled this far, mm
(from upstream of the view to past its middle)."""

STILL_FRAMES = 4
"""On a stopped belt this many frames are rendered (each with its own sensor noise), then
shown in turn: the scene does not change, and a render takes about 0.2 s."""

_LENSES = ("standard", "wide", "none")


def _same_dist(a: NDArray[np.float64], b: NDArray[np.float64]) -> bool:
    """The same distortion coefficients (trailing zeros aside)."""
    a, b = np.ravel(a), np.ravel(b)
    n = max(len(a), len(b))
    a, b = np.pad(a, (0, n - len(a))), np.pad(b, (0, n - len(b)))
    return bool(np.allclose(a, b, atol=1e-9))


def matching_hand_rig(rig: StereoRig) -> str | None:
    """The lens (``"standard"``, ``"wide"``, ``"none"``) of the simulated hand rig that
    ``rig`` is, or None when it is another rig."""
    from photomodel.sim import hand_stereo_rig

    for lens in _LENSES:
        sim = hand_stereo_rig(lens=lens)
        same = all(
            (a.width_px, a.height_px) == (b.width_px, b.height_px)
            and np.allclose(a.K, b.K, atol=1e-6) and
            _same_dist(a.dist, b.dist)
            for a, b in ((rig.cam1, sim.cam1), (rig.cam2, sim.cam2)))
        if same and np.allclose(rig.R, sim.R, atol=1e-9) and np.allclose(rig.T, sim.T,
                                                                           atol=1e-6):
            return lens
    return None


def _options(args: str) -> tuple[str, float, int]:
    """(garment, conveyor mm/s, seed) of ``sim:`` arguments."""
    garment, speed, seed = DEFAULT_GARMENT, 0.0, 0
    named = False
    for item in (a.strip() for a in args.split(",") if args.strip()):
        key, eq, value = item.partition("=")
        if not eq:
            if named:
                raise InputError("--source", f"sim: two garments named ({garment!r} and "
                                             f"{item!r})")
            garment, named = item, True
        elif key == "conveyor":
            try:
                speed = float(value)
            except ValueError:
                speed = math.nan
            if not (math.isfinite(speed) and 0.0 <= speed <= 1000.0):
                raise InputError("--source", f"sim: conveyor={value!r}: expected a belt speed "
                                             "of 0 to 1000 mm/s")
        elif key == "seed":
            if not (value.isdigit() and int(value) <= 2**32 - 1):
                raise InputError("--source", f"sim: seed={value!r}: expected an integer from 0 "
                                             "to 4294967295")
            seed = int(value)
        else:
            raise InputError("--source", f"sim: unknown option {key!r} (expected conveyor=MM_S "
                                         "or seed=N)")
    return garment, speed, seed


class SimSource:
    """The simulated hand cameras over a garment on the table (made by :meth:`open`).

    Attributes
    ----------
    name : str
    fps : None
        Frames are rendered on demand.
    garment : str
    conveyor_mm_s : float
    last_T_cam1_model : ndarray (4, 4) or None
        The truth of the last pair: the garment's pose in camera 1's frame, mm.
    """

    fps: float | None = None

    def __init__(self, name: str, garment: str, conveyor_mm_s: float, seed: int,
                 rig: StereoRig, clock: Clock) -> None:
        from photomodel.geometry import invert_transform
        from photomodel.sim import ConveyorView, hand_table_pose

        self.name = name
        self.garment = garment
        self.conveyor_mm_s = conveyor_mm_s
        self._clock = clock
        try:
            self._view = ConveyorView(garment, speed_mm_s=conveyor_mm_s, seed=seed, rig=rig)
        except (KeyError, ValueError) as exc:
            raise InputError("--source", f"sim: {exc}") from None
        self._T_table_cam1 = invert_transform(hand_table_pose(rig))
        self._t0_s = clock()
        self._index = 0
        self._stills: list[tuple[NDArray[np.uint8], NDArray[np.uint8],
                                 NDArray[np.float64] | None]] = []
        self.last_T_cam1_model: NDArray[np.float64] | None = None

    @classmethod
    def open(cls, args: str, rig: StereoRig, *, clock: Clock) -> SimSource:
        """Open ``sim:ARGS`` for ``rig`` (which must be the simulated hand rig); renders the
        first pair to be sure it can."""
        garment, speed, seed = _options(args)
        if matching_hand_rig(rig) is None:
            raise InputError("--source", "sim renders the simulated hand rig, but the "
                                         "service's --stereo calibration is another rig: serve "
                                         "the stereo.yaml that photomodel simulate writes")
        name = "sim:" + garment + (f",conveyor={speed:g}" if speed else "")
        source = cls(name, garment, speed, seed, rig, clock)
        source._render(0, 0.0)
        return source

    def _render(self, index: int, t_s: float
                ) -> tuple[NDArray[np.uint8], NDArray[np.uint8], NDArray[np.float64] | None]:
        if self.conveyor_mm_s == 0.0 and len(self._stills) == STILL_FRAMES:
            return self._stills[index % STILL_FRAMES]
        frame = self._view.frame(index, t_s, lambda t: self._T_table_cam1)
        made = (frame.right_bgr, frame.left_bgr, frame.T_cam1_model)
        if self.conveyor_mm_s == 0.0:
            self._stills.append(made)
        return made

    def grab(self, timeout_s: float, *, newest: bool = True) -> StereoGrab:
        now = self._clock()
        elapsed = max(0.0, now - self._t0_s)
        loop_s = LOOP_MM / self.conveyor_mm_s if self.conveyor_mm_s else math.inf
        index = self._index
        self._index += 1
        try:
            right, left, T = self._render(index, elapsed % loop_s if loop_s < math.inf else 0.0)
        except (ValueError, RuntimeError) as exc:   # pragma: no cover - the renderer's own
            raise SourceError(self.name, f"rendering failed: {exc}") from None
        self.last_T_cam1_model = None if T is None else T.copy()
        return StereoGrab(right, left, now, now, index)

    def close(self) -> None:
        self._stills.clear()

    def describe(self) -> dict[str, Any]:
        return {"kind": "sim", "garment": self.garment, "conveyor_mm_s": self.conveyor_mm_s,
                "fps": None}
