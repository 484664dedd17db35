"""A garment riding a conveyor under a hand that moves as the caller commands: frames on demand.

What a servoed pick sees. Unlike a written sequence (:mod:`photomodel.sim._sequences`), whose
camera path is fixed in advance, the camera's pose here comes from the caller at each frame
(the arm's joints of a closed loop), so the frames are rendered one at a time as they are
asked for.

The table frame is the simulator's (:func:`~photomodel.sim.hand_table_pose`: z into the table);
a conveyor belt runs along its +y at ``speed_mm_s`` (the ``conveyor`` sequence's belt and
camera response, 4 ms exposure with motion blur); the garment lies on it, flat, at
``(x, y0 + speed * t, theta)``. At ``t = 0`` the garment lies whole inside both images of a
hand rig at the working distance above the table's origin (the photographing pose).
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

from photomodel.camera import StereoRig
from photomodel.sim._catalogue import catalogue_garment
from photomodel.sim._dataset import scene_rng
from photomodel.sim._render import Layer
from photomodel.sim._rigs import hand_stereo_rig, hand_table_pose
from photomodel.sim._scenes import THETA_RANGE_DEG, _inside_both
from photomodel.sim._sequences import (
    _BELT_PERIOD_MM,
    EXPOSURE_S,
    SequenceFrame,
    _area_samples,
    _belt,
    _on_table,
    _outline3,
    _Plan,
    _render_frame,
    _Smears,
    _State,
    _translation,
    _view_radius_mm,
)

__all__ = ["MAX_BELT_MM_S", "ConveyorView"]

MAX_BELT_MM_S = 1000.0
"""Fastest belt :class:`ConveyorView` takes, mm/s."""

_START_Y_MM = (-110.0, -50.0)  # where the garment's origin lies along the belt at t = 0
_START_X_MM = 60.0  # half range across the belt


class ConveyorView:
    """A garment on a moving belt, rendered from any hand pose at any instant.

    Parameters
    ----------
    garment : str
        A catalogue garment (:func:`~photomodel.sim.catalogue_garment`).
    speed_mm_s : float
        Belt speed along the table's +y, mm/s, 0 to :data:`MAX_BELT_MM_S`.
    seed : int
    key : tuple of str or int
        What else tells this scene from others of the same seed (an order's number); the
        placement, the belt, the light and the noise come from ``scene_rng(seed,
        "conveyor-view", garment, *key)``.
    rig : StereoRig, optional
        The hand rig (default :func:`~photomodel.sim.hand_stereo_rig`).
    exposure_s : float
        Exposure of a frame, s (motion blur).
    travel_mm : float
        How far the garment and the hand may move along the belt; the belt is drawn long
        enough for both, mm.
    """

    def __init__(self, garment: str, *, speed_mm_s: float, seed: int,
                 key: tuple[str | int, ...] = (), rig: StereoRig | None = None,
                 exposure_s: float = EXPOSURE_S, travel_mm: float = 800.0) -> None:
        if not (math.isfinite(speed_mm_s) and 0.0 <= speed_mm_s <= MAX_BELT_MM_S):
            raise ValueError(f"speed_mm_s: expected 0 to {MAX_BELT_MM_S:g} mm/s, "
                             f"got {speed_mm_s:g}")
        if not (math.isfinite(exposure_s) and 0.0 <= exposure_s <= 0.1):
            raise ValueError(f"exposure_s: expected 0 to 0.1 s, got {exposure_s:g}")
        self.rig = rig or hand_stereo_rig()
        self.speed_mm_s = float(speed_mm_s)
        self.exposure_s = float(exposure_s)
        self._seed, self._key, self._garment_name = seed, tuple(key), garment
        gen = scene_rng(seed, "conveyor-view", garment, *self._key)
        item = catalogue_garment(garment)
        elevation = np.radians(gen.uniform(50.0, 80.0))
        azimuth = gen.uniform(0.0, 2.0 * np.pi)
        light = np.array([np.cos(elevation) * np.cos(azimuth),
                          np.cos(elevation) * np.sin(azimuth), -np.sin(elevation)])
        T_cam1_table = hand_table_pose(self.rig)
        view = _view_radius_mm(self.rig, T_cam1_table)
        belt = _belt(gen, _BELT_PERIOD_MM + 2.0 * (view + travel_mm) + 50.0)
        outline = _outline3(item.texture)
        self.x_mm, self.y0_mm, self.theta_deg = self._start(gen, T_cam1_table, outline)
        self._texture = item.texture
        self._plan_parts = (belt, light, {id(item.texture): outline},
                            _area_samples(item.texture))
        self._smears = _Smears()
        self.facts = {"garment": garment, "x_mm": self.x_mm, "y0_mm": self.y0_mm,
                      "theta_deg": self.theta_deg, "conveyor_mm_s": self.speed_mm_s,
                      "direction_table": [0.0, 1.0, 0.0],
                      "light_elevation_deg": float(np.degrees(elevation)),
                      "light_azimuth_deg": float(np.degrees(azimuth))}

    def _start(self, gen: np.random.Generator, T_cam1_table: NDArray[np.float64],
               outline: NDArray[np.float64]) -> tuple[float, float, float]:
        """(x, y0, theta) at t = 0: upstream of the view's centre, whole in both images."""
        for _ in range(500):
            x = float(gen.uniform(-_START_X_MM, _START_X_MM))
            y0 = float(gen.uniform(*_START_Y_MM))
            theta = float(gen.uniform(*THETA_RANGE_DEG))
            if _inside_both(self.rig, T_cam1_table @ _on_table(x, y0, theta), outline[:, :2]):
                return x, y0, theta
        raise ValueError(f"garment: {self._garment_name} does not fit inside both images")

    def T_table_model(self, t_s: float) -> NDArray[np.float64]:
        """The garment's pose (4, 4) in the table frame at ``t_s``, mm."""
        return _on_table(self.x_mm, self.y0_mm + self.speed_mm_s * t_s, self.theta_deg)

    def frame(self, index: int, t_s: float,
              T_table_cam1_at: Callable[[float], NDArray[np.float64]]) -> SequenceFrame:
        """The stereo frame exposed around ``t_s``, with its truth.

        Parameters
        ----------
        index : int
            The frame's number (names it and seeds its sensor noise).
        t_s : float
            Middle of the exposure, s.
        T_table_cam1_at : callable
            Camera 1's pose (4, 4) in the table frame at any instant of the exposure
            (``t_s`` +- half of it), mm.

        Returns
        -------
        SequenceFrame
            As a written sequence's: images, ``T_cam1_model``, ``visible`` and ``info``.
        """
        belt, light, outlines, samples = self._plan_parts
        speed = self.speed_mm_s
        # The belt's texture jumps back by a period between frames, never within an exposure.
        turns = math.floor((speed * t_s + _BELT_PERIOD_MM / 2.0) / _BELT_PERIOD_MM)

        def state(t: float) -> _State:
            shift = speed * t - turns * _BELT_PERIOD_MM
            layer = Layer(self._texture, self.T_table_model(t))
            return _State(np.asarray(T_table_cam1_at(t), dtype=np.float64),
                          _translation([0.0, shift, 0.0]), (layer,), 0)

        plan = _Plan(self.rig, belt, light, state, outlines, samples, self.facts)
        gen = scene_rng(self._seed, "conveyor-view", self._garment_name, *self._key,
                        "frame", index)
        return _render_frame(plan, index, t_s, self.exposure_s, gen, self._smears)
