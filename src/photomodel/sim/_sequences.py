"""Simulated stereo sequences with per-frame truth: what a pose tracker is tested on.

A sequence is one event of the cell filmed by the hand cameras at a frame rate
(:data:`SEQUENCE_KINDS`; docs/method/sequences.md says what each models and why):

- ``approach``: the hand descends from the working distance (685 mm) to 300 mm above the
  garment along the pick's approach path, with a small vibration; the garment lies still.
- ``conveyor``: a fixed hand; the garment rides across the view on a moving belt.
- ``occluder``: a fixed hand, a still garment; a gripper sweeps across the view over it.
- ``lost``: the garment is lifted out of view, is gone for a while, and is put down elsewhere.

Every event spans the sequence's ``seconds`` (so a short sequence shows all of it, faster);
the conveyor's speed is fixed instead (``conveyor_mm_s``). Frame ``k`` is taken at
``t_s = k / fps``, the middle of a 4 ms exposure, and blurred by the motion during it:

- while the hand moves (``approach``), the frame is the average in linear light of sub-frames
  spread over the exposure, as many as keep the image motion between two of them at most
  1 px (one when the motion is smaller; after the 0.6 px optical blur the copies merge);
- while the hand stands, what moves slides in its own plane (the belt, the garment on it, the
  gripper, a carried garment) and is rendered once, its texture averaged (in linear light,
  weighted by opacity) over its copies along its slide during the exposure: the same as the
  sub-frames' average for a slide at constant velocity, at the cost of one rendering. A
  carried garment's rise during the exposure (at most 3.6 mm in a 2 s sequence) is left out
  of its blur.

The cameras' response (light, vignetting, optical blur, noise) is the ``paper`` condition's
(:func:`expose`).

Truth per frame: ``T_cam1_model`` (the garment's pose in camera 1, the right camera; null
while the garment is not in the cell at all), ``visible`` (the share of the garment's area that
camera 1 sees: inside its image and not hidden; 0 when it is outside) and ``t_s``; also the hand
pose ``T_table_cam1``, the garment's pose on the table ``T_table_model``, ``visible_cam2``,
``motion_blur_px`` (the largest image motion during the exposure) and ``subframes``.

The motion and the textures are drawn from ``scene_rng(seed, "sequence", garment, kind)``, so
the 30 and 60 fps sequences of one kind show the same motion; each frame's sensor noise from
``scene_rng(seed, "sequence", garment, kind, fps, frame)``. The same settings give
byte-identical images.

On disk (docs/contracts.md)::

    SEQ/<frame>/right.png, left.png     frames in name order (000000, 000001, ...)
    SEQ/truth.json                      {"model", "fps", "kind", "frames": {"<frame>": {...}}}

and :func:`write_sequences` puts several beside what a tracker needs::

    OUT/stereo.yaml                     stereo calibration (camera 1 = right.png)
    OUT/models/<garment>.npz            the garment's photo-model (:func:`station_model`)
    OUT/<kind>-<fps>fps/                one sequence each
    OUT/sequences.json                  how they were made
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import cv2
import numpy as np
from numpy.typing import NDArray

from photomodel.camera import PinholeCamera, StereoRig, save_stereo
from photomodel.geometry import invert_transform, make_transform
from photomodel.image import write_image
from photomodel.sim._catalogue import _spec as _garment_spec
from photomodel.sim._catalogue import catalogue_garment, expand_garments
from photomodel.sim._conditions import Conditions, _srgb_decode, expose
from photomodel.sim._dataset import MAX_SEED, dumps_json, scene_rng
from photomodel.sim._folders import build_folder, check_out
from photomodel.sim._garments import Garment
from photomodel.sim._mesh import field_of_view_radius
from photomodel.sim._objects import gripper
from photomodel.sim._render import Layer, render_view_linear
from photomodel.sim._rigs import WORK_DISTANCE_MM, hand_stereo_rig, hand_table_pose
from photomodel.sim._scenes import THETA_RANGE_DEG, _footprint_mm, _inside_both, _radius_mm
from photomodel.sim._tables import make_table
from photomodel.sim._textures import PlaneTexture

__all__ = [
    "APPROACH_END_MM",
    "CONVEYOR_MM_S_RANGE",
    "EXPOSURE_S",
    "MAX_FPS",
    "MAX_FRAMES",
    "SEQUENCE_KINDS",
    "SequenceFrame",
    "SequenceSettings",
    "SequencesSummary",
    "simulate_sequence",
    "write_sequence",
    "write_sequences",
]

SEQUENCE_KINDS: tuple[str, ...] = ("approach", "conveyor", "occluder", "lost")
"""The simulated events, in the order ``simulate --sequences`` lists them."""

EXPOSURE_S = 0.004
"""Exposure time of a frame, s (motion blur = speed x exposure)."""

APPROACH_END_MM = 300.0
"""Height of the hand (middle of the baseline) above the garment where an approach ends, mm."""

CONVEYOR_MM_S_RANGE: tuple[float, float] = (100.0, 300.0)
"""Conveyor speeds the simulator takes, mm/s (garment-handling belts)."""

MAX_FPS = 240.0
"""Highest frame rate, frames per second (the exposure fits in the frame period)."""

MAX_FRAMES = 10_000
"""Most frames per sequence (``seconds * fps``)."""

MAX_SECONDS = 600.0

_FORMAT_SEQUENCE = "photomodel-sequence"
_FORMAT_SET = "photomodel-sequences"
_FORMAT_VERSION = 1

# Largest image motion between two sub-frames of an exposure: copies less than two optical
# blur sigmas (2 x 0.6 px) apart merge into one single-peaked smear.
_SUBFRAME_STEP_PX = 1.0
_MAX_SUBFRAMES = 16
_SUPERSAMPLE = 2
_VIBRATION_MM = (0.3, 0.5)  # amplitude range of the hand's vibration during an approach
_VIBRATION_HZ = (3.0, 6.0)
_BELT_PERIOD_MM = 1002.0  # the belt's texture repeats after this (a multiple of its 6 mm tread)
_LIFT_MM = 150.0  # how high a lost garment is carried
_GRIPPER_HEIGHT_MM = (40.0, 120.0)
_SWEEP = (0.15, 0.75)  # share of the sequence during which the gripper crosses the view
_LOST_PHASES = (0.2, 0.4, 0.6, 0.8)  # carried out, gone, carried in, down again
_MIN_MOVE_MM = 60.0  # a lost garment is put down at least this far from where it lay


# --- settings ------------------------------------------------------------------------------


@dataclass(frozen=True)
class SequenceSettings:
    """What one simulated sequence shows and how it is filmed.

    Parameters
    ----------
    kind : str
        One of :data:`SEQUENCE_KINDS`.
    fps : float
        Frame rate, frames per second, in (0, :data:`MAX_FPS`].
    seconds : float
        Length, s, in (0, 600]; ``round(seconds * fps)`` frames (at least 1, at most
        :data:`MAX_FRAMES`).
    garment : str
        A garment :func:`catalogue_garment` knows (default ``"No.1"``, the paper's first).
    seed : int
        Seed, 0 to 2**32 - 1.
    conveyor_mm_s : float
        Belt speed of a ``conveyor`` sequence, mm/s, within :data:`CONVEYOR_MM_S_RANGE`.
    exposure_s : float
        Exposure time, s, from 0 (no motion blur) to one frame period.
    """

    kind: str
    fps: float = 30.0
    seconds: float = 2.0
    garment: str = "No.1"
    seed: int = 0
    conveyor_mm_s: float = 200.0
    exposure_s: float = EXPOSURE_S

    def __post_init__(self) -> None:
        if self.kind not in SEQUENCE_KINDS:
            raise ValueError(f"kind: expected one of {', '.join(SEQUENCE_KINDS)}, "
                             f"got {self.kind!r}")
        if not (math.isfinite(self.fps) and 0 < self.fps <= MAX_FPS):
            raise ValueError(f"fps: expected a frame rate greater than 0 and at most "
                             f"{MAX_FPS:g}, got {self.fps:g}")
        if not (math.isfinite(self.seconds) and 0 < self.seconds <= MAX_SECONDS):
            raise ValueError(f"seconds: expected a length greater than 0 and at most "
                             f"{MAX_SECONDS:g} s, got {self.seconds:g}")
        if self.frames > MAX_FRAMES:
            raise ValueError(f"seconds: {self.seconds:g} s at {self.fps:g} fps is "
                             f"{self.frames} frames; at most {MAX_FRAMES} per sequence")
        if not 0 <= self.seed <= MAX_SEED:
            raise ValueError(f"seed: expected an integer from 0 to {MAX_SEED}, got {self.seed}")
        lo, hi = CONVEYOR_MM_S_RANGE
        if not (math.isfinite(self.conveyor_mm_s) and lo <= self.conveyor_mm_s <= hi):
            raise ValueError(f"conveyor_mm_s: expected a speed from {lo:g} to {hi:g} mm/s, "
                             f"got {self.conveyor_mm_s:g}")
        if not (math.isfinite(self.exposure_s) and 0 <= self.exposure_s <= 1.0 / self.fps):
            raise ValueError(f"exposure_s: expected 0 to one frame period "
                             f"({1.0 / self.fps:g} s), got {self.exposure_s:g}")
        if _garment_spec(self.garment) is None:
            try:
                expand_garments(self.garment)
            except ValueError as exc:
                raise ValueError(f"garment: {exc}") from None
            raise ValueError(f"garment: expected one garment's name, got {self.garment!r}")

    @property
    def frames(self) -> int:
        """Number of frames, ``round(seconds * fps)`` but at least 1."""
        return max(1, round(self.seconds * self.fps))

    @property
    def name(self) -> str:
        """Directory name of the sequence, ``<kind>-<fps>fps`` (``approach-30fps``)."""
        return f"{self.kind}-{self.fps:g}fps"


@dataclass(frozen=True)
class SequenceFrame:
    """One simulated frame of a sequence with its truth.

    Parameters
    ----------
    index : int
        Frame number from 0.
    name : str
        Its directory name, ``f"{index:06d}"``.
    t_s : float
        Time of the frame (middle of its exposure), ``index / fps``, s.
    right_bgr, left_bgr : ndarray (H, W, 3) uint8
        Camera 1's (the right camera, the reference) and camera 2's images.
    T_cam1_model : ndarray (4, 4) or None
        The garment's pose in camera 1's frame, mm; None while it is not in the cell.
    visible : float
        Share of the garment's area camera 1 sees (inside its image, not hidden), in [0, 1].
    info : dict
        JSON-ready additions to the frame's truth: ``T_table_cam1`` (camera 1's pose in the
        table frame, mm), ``T_table_model`` (the garment on the table, or None),
        ``visible_cam2``, ``motion_blur_px`` (largest image motion of anything in view during
        the exposure, pixels) and ``subframes`` (renderings averaged).
    """

    index: int
    name: str
    t_s: float
    right_bgr: NDArray[np.uint8]
    left_bgr: NDArray[np.uint8]
    T_cam1_model: NDArray[np.float64] | None
    visible: float
    info: dict[str, Any] = field(default_factory=dict)

    def truth(self) -> dict[str, Any]:
        """The frame's entry of ``truth.json``: ``T_cam1_model`` (4x4 list or None),
        ``visible``, ``t_s``, then :attr:`info`."""
        return {"T_cam1_model": None if self.T_cam1_model is None else self.T_cam1_model.tolist(),
                "visible": self.visible, "t_s": self.t_s, **self.info}


@dataclass(frozen=True)
class SequencesSummary:
    """What :func:`write_sequences` wrote.

    Parameters
    ----------
    out : Path
        The output directory.
    stereo : Path
        Its stereo calibration, ``out/stereo.yaml``.
    model : Path
        The garment's photo-model, ``out/models/<garment>.npz``.
    sequences : tuple of str
        The sequences' directory names (``approach-30fps``), in the order written.
    frames : int
        Frames written in all.
    """

    out: Path
    stereo: Path
    model: Path
    sequences: tuple[str, ...]
    frames: int


# --- the motion of each kind ---------------------------------------------------------------


@dataclass(frozen=True)
class _State:
    """The cell at one instant: poses in the table frame (z into the table), mm."""

    T_table_cam1: NDArray[np.float64]
    T_table_plane: NDArray[np.float64]  # the background texture (the belt moves)
    layers: tuple[Layer, ...]  # items in the table frame, bottom to top
    garment: int | None  # index of the garment in ``layers``; None when it is not there


@dataclass(frozen=True)
class _Plan:
    """A sequence's fixed parts and its motion: ``state(t_s)``."""

    rig: StereoRig
    background: PlaneTexture
    light_dir_table: NDArray[np.float64]
    state: Callable[[float], _State]
    outlines: dict[int, NDArray[np.float64]]  # id(texture) -> outline (N, 3) in its frame
    samples: tuple[NDArray[np.float64], NDArray[np.float64]]  # garment points (N, 3), weights
    facts: dict[str, Any]


def _translation(xyz: Sequence[float]) -> NDArray[np.float64]:
    return make_transform(np.eye(3), np.asarray(xyz, dtype=np.float64))


def _on_table(x_mm: float, y_mm: float, theta_deg: float, z_mm: float = 0.0
              ) -> NDArray[np.float64]:
    """``T_table_item``: rotated by ``theta_deg`` about z, at (x, y, z) (z < 0 is above)."""
    c, s = np.cos(np.radians(theta_deg)), np.sin(np.radians(theta_deg))
    return make_transform([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]], [x_mm, y_mm, z_mm])


def _min_jerk(s: float) -> float:
    """Minimum-jerk profile on [0, 1] (zero speed and acceleration at both ends)."""
    s = min(max(s, 0.0), 1.0)
    return s * s * s * (10.0 - 15.0 * s + 6.0 * s * s)


def _outline3(texture: PlaneTexture) -> NDArray[np.float64]:
    xy = _footprint_mm(texture)
    return np.column_stack([xy, np.zeros(len(xy))])


def _area_samples(texture: PlaneTexture, step_mm: float = 2.0
                  ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Points (N, 3) on a grid of ``step_mm`` over the texture, in its frame, and their
    opacity (N,): the garment's area, for its visible share."""
    step = max(1, round(step_mm / texture.mm_per_px))
    alpha = texture.alpha[::step, ::step]
    v, u = np.nonzero(alpha > 0)
    xy = texture.mm_from_px(np.column_stack([u * step, v * step]).astype(np.float64))
    return np.column_stack([xy, np.zeros(len(xy))]), alpha[v, u].astype(np.float64)


def _view_radius_mm(rig: StereoRig, T_cam1_table: NDArray[np.float64]) -> float:
    """Largest distance from the table's origin of a table point either camera sees, mm."""
    radius = 0.0
    for camera, T_cam_cam1 in ((rig.cam1, np.eye(4)), (rig.cam2, rig.T_cam2_cam1)):
        w, h = camera.width_px - 0.5, camera.height_px - 0.5
        border = np.array([[-0.5, -0.5], [w, -0.5], [w, h], [-0.5, h], [w / 2, -0.5],
                           [w / 2, h], [-0.5, h / 2], [w, h / 2]])
        rays = np.column_stack([camera.undistort_pixels(border), np.ones(len(border))])
        T_table_cam = invert_transform(T_cam_cam1 @ T_cam1_table)
        d = rays @ T_table_cam[:3, :3].T
        o = T_table_cam[:3, 3]
        pts = o + d * (-o[2] / d[:, 2])[:, None]
        radius = max(radius, float(np.hypot(pts[:, 0], pts[:, 1]).max()))
    return radius


def _placement(gen: np.random.Generator, rig: StereoRig, T_cam1_table: NDArray[np.float64],
               outline: NDArray[np.float64], half_range_mm: tuple[float, float],
               name: str, avoid: tuple[float, float] | None = None) -> tuple[float, float, float]:
    """(x_mm, y_mm, theta_deg) on the table, drawn until the garment lies whole inside both
    images (and at least :data:`_MIN_MOVE_MM` from ``avoid``)."""
    for _ in range(500):
        x = float(gen.uniform(-half_range_mm[0], half_range_mm[0]))
        y = float(gen.uniform(-half_range_mm[1], half_range_mm[1]))
        theta = float(gen.uniform(*THETA_RANGE_DEG))
        if avoid is not None and np.hypot(x - avoid[0], y - avoid[1]) < _MIN_MOVE_MM:
            continue
        if _inside_both(rig, T_cam1_table @ _on_table(x, y, theta), outline[:, :2]):
            return x, y, theta
    raise ValueError(f"garment: {name} does not fit inside both images")


def _plan(settings: SequenceSettings, rig: StereoRig) -> _Plan:
    gen = scene_rng(settings.seed, "sequence", settings.garment, settings.kind)
    garment = catalogue_garment(settings.garment)
    elevation = np.radians(gen.uniform(50.0, 80.0))
    azimuth = gen.uniform(0.0, 2.0 * np.pi)
    light = np.array([np.cos(elevation) * np.cos(azimuth),
                      np.cos(elevation) * np.sin(azimuth), -np.sin(elevation)])
    outline = _outline3(garment.texture)
    outlines = {id(garment.texture): outline}
    T_cam1_table = hand_table_pose(rig)
    builders = {"approach": _approach, "conveyor": _conveyor, "occluder": _occluder,
                "lost": _lost}
    background, state, facts = builders[settings.kind](settings, rig, garment, T_cam1_table,
                                                      outlines, gen)
    facts = {"light_elevation_deg": float(np.degrees(elevation)),
             "light_azimuth_deg": float(np.degrees(azimuth)), **facts}
    return _Plan(rig, background, light, state, outlines, _area_samples(garment.texture),
                 facts)


_Built = tuple[PlaneTexture, Callable[[float], _State], dict[str, Any]]


def _approach(settings: SequenceSettings, rig: StereoRig, garment: Garment,
              T_cam1_table: NDArray[np.float64], outlines: dict[int, NDArray[np.float64]],
              gen: np.random.Generator) -> _Built:
    """The hand descends from the working distance to :data:`APPROACH_END_MM` above the
    garment's origin on a straight line (minimum-jerk timing over the sequence), vibrating."""
    table = make_table("grey", gen)
    x, y, theta = _placement(gen, rig, T_cam1_table, outlines[id(garment.texture)],
                             (100.0, 70.0), garment.name)
    T_table_garment = _on_table(x, y, theta)
    T_table_cam1_start = invert_transform(T_cam1_table)
    travel = np.array([x, y, WORK_DISTANCE_MM - APPROACH_END_MM])
    amplitude = float(gen.uniform(*_VIBRATION_MM))
    frequency = float(gen.uniform(*_VIBRATION_HZ))
    phase = float(gen.uniform(0.0, 2.0 * np.pi))
    direction = gen.standard_normal(3)
    direction /= np.linalg.norm(direction)
    layer = Layer(garment.texture, T_table_garment)
    identity = np.eye(4)

    def state(t_s: float) -> _State:
        shake = amplitude * np.sin(2.0 * np.pi * frequency * t_s + phase) * direction
        offset = _min_jerk(t_s / settings.seconds) * travel + shake
        return _State(_translation(offset) @ T_table_cam1_start, identity, (layer,), 0)

    facts = {"x_mm": x, "y_mm": y, "theta_deg": theta,
             "start_height_mm": WORK_DISTANCE_MM, "end_height_mm": APPROACH_END_MM,
             "vibration_mm": amplitude, "vibration_hz": frequency,
             "vibration_phase_rad": phase, "vibration_direction": direction.tolist()}
    return table, state, facts


def _belt(gen: np.random.Generator, length_mm: float) -> PlaneTexture:
    """A conveyor belt (:func:`make_table` ``"conveyor"``, running along y) whose texture
    repeats every :data:`_BELT_PERIOD_MM`, ``length_mm`` long: a loop, joined at its splice."""
    period = round(_BELT_PERIOD_MM)
    base = make_table("conveyor", gen, size_mm=(1000.0, float(period)))
    splice = int(np.argmin(base.image_bgr.mean(axis=(1, 2))))  # the darkest row
    image = np.roll(base.image_bgr, -splice, axis=0)  # the loop's joint at the splice
    reps = int(np.ceil(length_mm / period))
    tiled = np.concatenate([image] * reps, axis=0)[:round(length_mm)]
    h, w = tiled.shape[:2]
    return PlaneTexture(np.ascontiguousarray(tiled), np.ones((h, w), np.float32), 1.0,
                        np.array([(w - 1) / 2.0, (h - 1) / 2.0]))


def _conveyor(settings: SequenceSettings, rig: StereoRig, garment: Garment,
              T_cam1_table: NDArray[np.float64], outlines: dict[int, NDArray[np.float64]],
              gen: np.random.Generator) -> _Built:
    """A fixed hand at the working distance; the garment lies on a belt running along the
    table's +y at ``conveyor_mm_s``, its origin crossing y = 0 at the sequence's middle."""
    view = _view_radius_mm(rig, T_cam1_table)
    belt = _belt(gen, _BELT_PERIOD_MM + 2.0 * view + 50.0)
    x = float(gen.uniform(-60.0, 60.0))
    theta = float(gen.uniform(*THETA_RANGE_DEG))
    speed = settings.conveyor_mm_s
    T_table_cam1 = invert_transform(T_cam1_table)

    def state(t_s: float) -> _State:
        travel = speed * (t_s - settings.seconds / 2.0)
        # The belt's texture jumps back by a period between frames, never within an exposure.
        at_frame = round(t_s * settings.fps) / settings.fps
        turns = np.floor((speed * at_frame + _BELT_PERIOD_MM / 2.0) / _BELT_PERIOD_MM)
        shift = speed * t_s - turns * _BELT_PERIOD_MM
        layer = Layer(garment.texture, _on_table(x, travel, theta))
        return _State(T_table_cam1, _translation([0.0, shift, 0.0]), (layer,), 0)

    facts = {"x_mm": x, "theta_deg": theta, "conveyor_mm_s": speed,
             "direction_table": [0.0, 1.0, 0.0],
             "y_mm_at_start": -speed * settings.seconds / 2.0}
    return belt, state, facts


def _occluder(settings: SequenceSettings, rig: StereoRig, garment: Garment,
              T_cam1_table: NDArray[np.float64], outlines: dict[int, NDArray[np.float64]],
              gen: np.random.Generator) -> _Built:
    """A fixed hand, a still garment; a gripper (:func:`gripper`), its fingertips past the
    garment's origin, sweeps sideways at constant speed from outside the view, over the
    garment, to outside the view, during the middle of the sequence (:data:`_SWEEP`)."""
    table = make_table("grey", gen)
    outline = outlines[id(garment.texture)]
    x, y, theta = _placement(gen, rig, T_cam1_table, outline, (150.0, 100.0), garment.name)
    grip = gripper(gen)[0][0]
    outlines[id(grip.texture)] = _outline3(grip.texture)
    direction = float(gen.uniform(-np.pi, np.pi))
    along = np.array([np.cos(direction), np.sin(direction)])
    across = np.array([-along[1], along[0]])
    reach = float(gen.uniform(0.1, 0.5)) * _radius_mm(garment.texture)
    height = float(gen.uniform(*_GRIPPER_HEIGHT_MM))
    tip0 = np.array([x, y]) + reach * along
    half_width = grip.texture.size_mm[1] / 2.0
    span = _view_radius_mm(rig, T_cam1_table) + half_width + abs(float(tip0 @ across))
    start, end = (settings.seconds * f for f in _SWEEP)
    garment_layer = Layer(garment.texture, _on_table(x, y, theta))
    T_table_cam1 = invert_transform(T_cam1_table)
    identity = np.eye(4)

    def state(t_s: float) -> _State:
        if not start <= t_s <= end:
            return _State(T_table_cam1, identity, (garment_layer,), 0)
        u = span * (2.0 * (t_s - start) / (end - start) - 1.0)
        tip = tip0 + u * across
        T = _on_table(tip[0], tip[1], float(np.degrees(direction)), -height)
        return _State(T_table_cam1, identity,
                      (garment_layer, Layer(grip.texture, T @ grip.T_plane_item)), 0)

    facts = {"x_mm": x, "y_mm": y, "theta_deg": theta, "gripper_height_mm": height,
             "gripper_direction_deg": float(np.degrees(direction)),
             "sweep_s": [start, end], "sweep_mm_s": 2.0 * span / (end - start)}
    return table, state, facts


def _lost(settings: SequenceSettings, rig: StereoRig, garment: Garment,
          T_cam1_table: NDArray[np.float64], outlines: dict[int, NDArray[np.float64]],
          gen: np.random.Generator) -> _Built:
    """A fixed hand. The garment lies still at A, is lifted :data:`_LIFT_MM` while carried
    sideways out of both views, is gone, is carried in from a side and put down at B, lies
    still (phases :data:`_LOST_PHASES` of the sequence, minimum-jerk moves)."""
    table = make_table("grey", gen)
    outline = outlines[id(garment.texture)]
    a = _placement(gen, rig, T_cam1_table, outline, (150.0, 100.0), garment.name)
    b = _placement(gen, rig, T_cam1_table, outline, (150.0, 100.0), garment.name,
                   avoid=(a[0], a[1]))
    away = _view_radius_mm(rig, T_cam1_table) + _radius_mm(garment.texture) + 20.0
    side_out, side_in = (float(gen.choice([-1.0, 1.0])) for _ in range(2))
    t_out, t_gone, t_in, t_down = (settings.seconds * f for f in _LOST_PHASES)
    T_table_cam1 = invert_transform(T_cam1_table)
    identity = np.eye(4)

    def carried(p: tuple[float, float, float], x_far: float, s: float, rising: bool
                ) -> NDArray[np.float64]:
        lift = 1.0 - (1.0 - s) ** 2 if rising else 1.0 - s * s
        x = p[0] + (s if rising else 1.0 - s) * (x_far - p[0])
        return _on_table(x, p[1], p[2], -_LIFT_MM * lift)

    def state(t_s: float) -> _State:
        if t_gone <= t_s <= t_in:
            return _State(T_table_cam1, identity, (), None)
        if t_s < t_out:
            T = _on_table(*a)
        elif t_s < t_gone:
            T = carried(a, side_out * away, _min_jerk((t_s - t_out) / (t_gone - t_out)), True)
        elif t_s < t_down:
            T = carried(b, side_in * away, _min_jerk((t_s - t_in) / (t_down - t_in)), False)
        else:
            T = _on_table(*b)
        return _State(T_table_cam1, identity, (Layer(garment.texture, T),), 0)

    facts = {"placement_before": list(a), "placement_after": list(b), "lift_mm": _LIFT_MM,
             "carried_out_s": [t_out, t_gone], "gone_s": [t_gone, t_in],
             "carried_in_s": [t_in, t_down]}
    return table, state, facts


# --- rendering -----------------------------------------------------------------------------


def _T_cam_table(rig: StereoRig, camera_index: int, state: _State) -> NDArray[np.float64]:
    T_cam1_table = invert_transform(state.T_table_cam1)
    return T_cam1_table if camera_index == 0 else rig.T_cam2_cam1 @ T_cam1_table


def _image_motion_px(plan: _Plan, start: _State, end: _State) -> float:
    """Largest image displacement, pixels, of a point of anything in view (the background
    under a grid of pixels, the outlines of the layers) between two instants, in either
    camera."""
    motion = 0.0
    for c, camera in enumerate(plan.rig.cameras):
        T0, T1 = _T_cam_table(plan.rig, c, start), _T_cam_table(plan.rig, c, end)
        bodies = [(_background_points(camera, T0 @ start.T_table_plane), start.T_table_plane,
                   end.T_table_plane)]
        for a, b in zip(start.layers, end.layers, strict=False):
            if a.texture is b.texture:
                bodies.append((plan.outlines[id(a.texture)], a.T_plane_item, b.T_plane_item))
        for pts, A, B in bodies:
            uv0 = _project(camera, T0 @ A, pts)
            uv1 = _project(camera, T1 @ B, pts)
            seen = np.isfinite(uv0).all(axis=1) & np.isfinite(uv1).all(axis=1)
            if seen.any():
                motion = max(motion, float(np.linalg.norm(uv1[seen] - uv0[seen], axis=1).max()))
    return motion


def _background_points(camera: PinholeCamera, T_cam_plane: NDArray[np.float64]
                       ) -> NDArray[np.float64]:
    """Points (N, 3) of the background plane, in its frame, under a 5 x 4 grid of pixels."""
    u = np.linspace(0.0, camera.width_px - 1.0, 5)
    v = np.linspace(0.0, camera.height_px - 1.0, 4)
    grid = np.stack(np.meshgrid(u, v), axis=-1).reshape(-1, 2)
    rays = np.column_stack([camera.undistort_pixels(grid), np.ones(len(grid))])
    normal, p0 = T_cam_plane[:3, 2], T_cam_plane[:3, 3]
    depth = (normal @ p0) / (rays @ normal)
    pts = rays[depth > 0] * depth[depth > 0, None]
    return (pts - p0) @ T_cam_plane[:3, :3]


def _project(camera: PinholeCamera, T_cam_item: NDArray[np.float64],
             pts: NDArray[np.float64]) -> NDArray[np.float64]:
    """Pixels (N, 2) of item points (N, 3); NaN for points behind the camera or outside its
    field of view (where the distortion polynomial is not trusted)."""
    p = pts @ T_cam_item[:3, :3].T + T_cam_item[:3, 3]
    with np.errstate(divide="ignore", invalid="ignore"):
        radius = np.hypot(p[:, 0], p[:, 1]) / p[:, 2]
    uv = camera.project(p)
    uv[~((p[:, 2] > 0) & (radius <= field_of_view_radius(camera)))] = np.nan
    return uv


def _in_image_share(camera: PinholeCamera, T_cam_item: NDArray[np.float64],
                    samples: tuple[NDArray[np.float64], NDArray[np.float64]]) -> float:
    """Share (by area) of an item's sample points that fall inside the image."""
    pts, weight = samples
    uv = _project(camera, T_cam_item, pts)
    with np.errstate(invalid="ignore"):
        inside = ((uv[:, 0] >= -0.5) & (uv[:, 0] <= camera.width_px - 0.5)
                  & (uv[:, 1] >= -0.5) & (uv[:, 1] <= camera.height_px - 0.5))
    return float(weight[inside].sum() / weight.sum())


def _srgb_encode_255(linear: NDArray[np.float32]) -> NDArray[np.float32]:
    """sRGB-encode linear light (values above 1, from shading, kept), on the 0-255 scale."""
    v = np.maximum(linear, 0.0)
    return (255.0 * np.where(v <= 0.0031308, 12.92 * v,
                             1.055 * np.power(v, 1.0 / 2.4) - 0.055)).astype(np.float32)


def _linear_mean(images: Sequence[NDArray[np.float32]]) -> NDArray[np.float32]:
    """Mean of sRGB-encoded images (0-255 scale) in linear light, encoded again."""
    if len(images) == 1:
        return images[0]
    total = np.zeros(images[0].shape, np.float32)
    for image in images:
        total += _srgb_decode(image / np.float32(255.0)).astype(np.float32)
    return _srgb_encode_255(total / np.float32(len(images)))


class _Smears:
    """Textures smeared along a displacement (:func:`_smear`), the last few kept: a constant
    velocity (the belt, the gripper) smears every frame alike."""

    def __init__(self, size: int = 6) -> None:
        self._size = size
        self._kept: dict[tuple[int, float, float], PlaneTexture] = {}

    def __call__(self, texture: PlaneTexture, shift_mm: NDArray[np.float64]) -> PlaneTexture:
        key = (id(texture), round(float(shift_mm[0]), 4), round(float(shift_mm[1]), 4))
        if key not in self._kept:
            if len(self._kept) >= self._size:
                self._kept.pop(next(iter(self._kept)))
            self._kept[key] = _smear(texture, shift_mm)
        return self._kept[key]


def _smear(texture: PlaneTexture, shift_mm: NDArray[np.float64]) -> PlaneTexture:
    """The texture averaged, in linear light and premultiplied by its opacity, over its copies
    shifted along ``shift_mm`` (2,) (texture frame, mm; from -1/2 to +1/2 of it): what a camera
    sees of an item that slides by ``shift_mm`` during the exposure. Padded so nothing is cut;
    its frame is unchanged."""
    step = np.asarray(shift_mm, dtype=np.float64) / texture.mm_per_px
    length = float(np.hypot(*step))
    if length < 0.25:
        return texture
    taps = max(2, int(np.ceil(length / 0.5)))
    pad = int(np.ceil(length / 2.0)) + 2
    linear = _srgb_decode(texture.image_bgr.astype(np.float32) / np.float32(255.0))
    alpha = texture.alpha[..., None]
    layer = np.concatenate([linear.astype(np.float32) * alpha, alpha], axis=-1)
    layer = cv2.copyMakeBorder(layer, pad, pad, pad, pad, cv2.BORDER_CONSTANT, value=0)
    h, w = layer.shape[:2]
    total = np.zeros_like(layer)
    for k in range(taps):
        du, dv = step * ((k + 0.5) / taps - 0.5)
        total += cv2.warpAffine(layer, np.array([[1.0, 0.0, du], [0.0, 1.0, dv]]), (w, h),
                                flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT)
    total /= np.float32(taps)
    a = np.clip(total[..., 3], 0.0, 1.0)
    colour = total[..., :3] / np.maximum(a, 1e-6)[..., None]
    image = np.clip(np.rint(_srgb_encode_255(colour)), 0, 255).astype(np.uint8)
    return PlaneTexture(image, a.astype(np.float32), texture.mm_per_px,
                        texture.origin_px + pad)


def _slide_mm(T_start: NDArray[np.float64], T_end: NDArray[np.float64]) -> NDArray[np.float64]:
    """In-plane part (2,) of an item's displacement between two poses, in its own frame, mm."""
    return (T_start[:3, :3].T @ (T_end[:3, 3] - T_start[:3, 3]))[:2]


@dataclass(frozen=True)
class _Exposure:
    """How one frame is rendered: the instants of its sub-frames (the camera moves) or one
    instant with the moving textures smeared (``start``/``end`` set: the camera stands)."""

    times: tuple[float, ...]
    motion_px: float
    start: _State | None = None
    end: _State | None = None


def _exposure_of(plan: _Plan, exposure_s: float, t_s: float) -> _Exposure:
    """The exposure (``exposure_s`` long) centred on ``t_s``. While the hand moves, sub-frames
    at most :data:`_SUBFRAME_STEP_PX` of image motion apart; while it stands, things slide past
    it and their textures are smeared instead (exact for a slide at constant velocity)."""
    half = exposure_s / 2.0
    if half <= 0:
        return _Exposure((t_s,), 0.0)
    start, end = plan.state(t_s - half), plan.state(t_s + half)
    motion = _image_motion_px(plan, start, end)
    if np.allclose(start.T_table_cam1, end.T_table_cam1, atol=1e-9):
        return _Exposure((t_s,), motion, start, end)
    n = int(min(max(np.ceil(motion / _SUBFRAME_STEP_PX), 1), _MAX_SUBFRAMES))
    return _Exposure(tuple(t_s + exposure_s * ((k + 0.5) / n - 0.5) for k in range(n)), motion)


def _scene(plan: _Plan, exposure: _Exposure, state: _State, smears: _Smears
           ) -> tuple[PlaneTexture, list[Layer]]:
    """The background and the layers (poses in the background's frame) to render for
    ``state``; smeared along their slides when the exposure says so."""
    background = plan.background
    textures = [layer.texture for layer in state.layers]
    if exposure.start is not None and exposure.end is not None:
        start, end = exposure.start, exposure.end
        background = smears(background, _slide_mm(start.T_table_plane, end.T_table_plane))
        for k, (a, b) in enumerate(zip(start.layers, end.layers, strict=False)):
            if k < len(textures) and a.texture is b.texture is textures[k]:
                textures[k] = smears(a.texture, _slide_mm(a.T_plane_item, b.T_plane_item))
    T_plane_table = invert_transform(state.T_table_plane)
    return background, [Layer(texture, T_plane_table @ layer.T_plane_item, layer.wrinkles,
                              layer.cull_back)
                        for texture, layer in zip(textures, state.layers, strict=True)]


def _render_camera(plan: _Plan, camera_index: int, exposure: _Exposure,
                   states: Sequence[_State], smears: _Smears
                   ) -> tuple[NDArray[np.float32], float, float]:
    """One camera's frame: its colours (sRGB-encoded, sub-frames averaged in linear light)
    and the garment's visible and covered areas in the image, pixels (summed over the
    sub-frames)."""
    camera = plan.rig.cameras[camera_index]
    images, seen, covered = [], 0.0, 0.0
    for state in states:
        background, layers = _scene(plan, exposure, state, smears)
        T_cam_plane = _T_cam_table(plan.rig, camera_index, state) @ state.T_table_plane
        view = render_view_linear(camera, T_cam_plane, background, layers,
                                  supersample=_SUPERSAMPLE, track=state.garment,
                                  light_dir_plane=plan.light_dir_table)
        images.append(view.image)
        if view.visible is not None and view.coverage is not None:
            seen += float(view.visible.sum())
            covered += float(view.coverage.sum())
    return _linear_mean(images), seen, covered


def simulate_sequence(settings: SequenceSettings) -> Iterator[SequenceFrame]:
    """Render a sequence frame by frame, with its truth.

    The hand rig is :func:`hand_stereo_rig` (standard lens), the one whose ``stereo.yaml``
    :func:`write_sequences` writes; the table is the ``paper`` condition's grey one (a conveyor
    belt for ``conveyor``); the cameras respond as under the ``paper`` condition.

    Parameters
    ----------
    settings : SequenceSettings

    Yields
    ------
    SequenceFrame
        ``settings.frames`` frames in order. ``visible`` = the share of the garment's area
        inside camera 1's image (area samples 2 mm apart) times the share of its pixels there
        that nothing hides (as :func:`simulate_scene`'s ``visible_fraction``), over the
        exposure.

    Raises
    ------
    ValueError
        The garment cannot be placed whole in both images (``garment: ...``).
    """
    return _frames(settings, _plan(settings, hand_stereo_rig()))


def _frames(settings: SequenceSettings, plan: _Plan) -> Iterator[SequenceFrame]:
    """:func:`simulate_sequence` of a built plan."""
    smears = _Smears()
    fps_key = f"{settings.fps:g}"
    for k in range(settings.frames):
        gen = scene_rng(settings.seed, "sequence", settings.garment, settings.kind, fps_key, k)
        yield _render_frame(plan, k, k / settings.fps, settings.exposure_s, gen, smears)


def _render_frame(plan: _Plan, index: int, t_s: float, exposure_s: float,
                  gen: np.random.Generator, smears: _Smears) -> SequenceFrame:
    """Frame ``index`` of a plan, exposed for ``exposure_s`` around ``t_s``, with its truth;
    ``gen`` draws its sensor noise."""
    rig = plan.rig
    exposure = _exposure_of(plan, exposure_s, t_s)
    states = [plan.state(t) for t in exposure.times]
    truth = plan.state(t_s)
    images, fractions = [], []
    for c, camera in enumerate(rig.cameras):
        image, seen, covered = _render_camera(plan, c, exposure, states, smears)
        images.append(expose(image, camera, Conditions(), gen))
        share = 0.0
        if truth.garment is not None and covered > 0:
            T_cam_item = (_T_cam_table(rig, c, truth)
                          @ truth.layers[truth.garment].T_plane_item)
            share = _in_image_share(camera, T_cam_item, plan.samples) * seen / covered
        fractions.append(float(min(max(share, 0.0), 1.0)))
    T_table_model = (None if truth.garment is None
                     else truth.layers[truth.garment].T_plane_item)
    T_cam1_model = (None if T_table_model is None
                    else invert_transform(truth.T_table_cam1) @ T_table_model)
    info = {"T_table_cam1": truth.T_table_cam1.tolist(),
            "T_table_model": None if T_table_model is None else T_table_model.tolist(),
            "visible_cam2": fractions[1], "motion_blur_px": exposure.motion_px,
            "subframes": len(exposure.times)}
    return SequenceFrame(index, f"{index:06d}", t_s, images[0], images[1], T_cam1_model,
                         fractions[0], info)


# --- writing -------------------------------------------------------------------------------


def _header(settings: SequenceSettings, facts: dict[str, Any]) -> dict[str, Any]:
    from importlib.metadata import version

    return {"model": settings.garment, "fps": settings.fps, "kind": settings.kind,
            "format": _FORMAT_SEQUENCE, "format_version": _FORMAT_VERSION,
            "generator": f"photomodel {version('photomodel')} (simulated)",
            "seed": int(settings.seed), "garment": settings.garment,
            "seconds": settings.seconds, "frame_count": settings.frames,
            "exposure_s": settings.exposure_s, "camera1": "right.png", "events": facts}


def _write_frames(folder: Path, settings: SequenceSettings,
                  progress: Callable[[str], None] | None) -> int:
    """Render ``settings``' frames into ``folder`` (new), then its ``truth.json``; the count."""
    plan = _plan(settings, hand_stereo_rig())
    frames: dict[str, Any] = {}
    for frame in _frames(settings, plan):
        write_image(folder / frame.name / "right.png", frame.right_bgr)
        write_image(folder / frame.name / "left.png", frame.left_bgr)
        frames[frame.name] = frame.truth()
        if progress is not None:
            progress(f"{settings.name}/{frame.name}")
    (folder / "truth.json").write_text(dumps_json({**_header(settings, plan.facts),
                                                   "frames": frames}))
    return len(frames)


def write_sequence(out: str | os.PathLike[str], settings: SequenceSettings, *,
                   overwrite: bool = False,
                   progress: Callable[[int, int, str], None] | None = None) -> Path:
    """Write one sequence: ``out/<frame>/right.png``, ``left.png`` and ``out/truth.json``.

    Parameters
    ----------
    out : path
        Directory to create (atomically: built beside it, then moved into place).
    settings : SequenceSettings
    overwrite : bool
        Replace ``out`` if it is a sequence this function wrote; a non-empty ``out`` is
        otherwise an error, and a file or another directory always is.
    progress : callable(done, total, label), optional
        Called after every frame.

    Returns
    -------
    Path
        ``out``.

    Raises
    ------
    InputError
        ``out`` cannot be replaced or written.
    """
    out = Path(out)
    check_out(out, overwrite, "truth.json", _FORMAT_SEQUENCE, "a sequence")
    done = 0

    def step(label: str) -> None:
        nonlocal done
        done += 1
        if progress is not None:
            progress(done, settings.frames, label)

    build_folder(out, "truth.json", _FORMAT_SEQUENCE,
                 lambda tmp: _write_frames(tmp, settings, step), "the sequences")
    return out


def write_sequences(
    out: str | os.PathLike[str],
    kinds: Sequence[str],
    fps: Sequence[float] = (30.0,),
    *,
    seconds: float = 2.0,
    garment: str = "No.1",
    seed: int = 0,
    conveyor_mm_s: float = 200.0,
    overwrite: bool = False,
    progress: Callable[[int, int, str], None] | None = None,
) -> SequencesSummary:
    """Write sequences of several kinds and frame rates with what a tracker needs to run on
    them (what ``photomodel simulate --sequences`` runs).

    ::

        out/stereo.yaml              stereo calibration (camera 1 = right.png)
        out/models/<garment>.npz     the garment's photo-model, built from its simulated
                                     model-station photos (:func:`station_model`, ``seed``)
        out/<kind>-<fps>fps/         a sequence each (:func:`write_sequence`'s layout)
        out/sequences.json           seed, garment, kinds, rates, length, versions

    Parameters
    ----------
    out : path
        Directory to create (atomically).
    kinds : sequence of str
        Of :data:`SEQUENCE_KINDS`, at least one.
    fps : sequence of float
        Frame rates, each in (0, :data:`MAX_FPS`].
    seconds, garment, seed, conveyor_mm_s
        As in :class:`SequenceSettings`.
    overwrite : bool
        Replace ``out`` if this function wrote it (``sequences.json``); never anything else.
    progress : callable(done, total, label), optional
        Called after the model and after every frame.

    Returns
    -------
    SequencesSummary

    Raises
    ------
    ValueError
        A bad argument; the message starts with its name (``kinds: ...``, ``fps: ...``).
    InputError
        ``out`` cannot be replaced or written.
    """
    from photomodel.model import save_model
    from photomodel.sim._station import station_model

    out = Path(out)
    kinds = list(dict.fromkeys(kinds))
    rates = list(dict.fromkeys(float(f) for f in fps))
    if not kinds:
        raise ValueError(f"kinds: expected at least one of {', '.join(SEQUENCE_KINDS)}")
    if not rates:
        raise ValueError("fps: expected at least one frame rate")
    for kind in kinds:
        if kind not in SEQUENCE_KINDS:
            raise ValueError(f"kinds: expected {', '.join(SEQUENCE_KINDS)}, got {kind!r}")
    plans = [SequenceSettings(kind, rate, seconds, garment, seed, conveyor_mm_s)
             for kind in kinds for rate in rates]
    if len({s.name for s in plans}) < len(plans):
        raise ValueError(f"fps: {', '.join(f'{r!r}' for r in rates)} name the same rate "
                         "twice (sequences are named by the rate to 6 digits)")
    check_out(out, overwrite, "sequences.json", _FORMAT_SET, "a set of sequences")
    total = 1 + sum(s.frames for s in plans)
    done = 0
    model_path = Path("models") / f"{garment}.npz"

    def step(label: str) -> None:
        nonlocal done
        done += 1
        if progress is not None:
            progress(done, total, label)

    def build(tmp: Path) -> None:
        from importlib.metadata import version

        save_stereo(tmp / "stereo.yaml", hand_stereo_rig())
        save_model(station_model(garment, seed), tmp / model_path)
        step(f"model {garment}")
        for settings in plans:
            (tmp / settings.name).mkdir()
            _write_frames(tmp / settings.name, settings, step)
        manifest = {"format": _FORMAT_SET, "format_version": _FORMAT_VERSION,
                    "generator": f"photomodel {version('photomodel')} (simulated)",
                    "seed": int(seed), "garment": garment, "model": model_path.as_posix(),
                    "stereo": "stereo.yaml", "kinds": kinds, "fps": rates,
                    "seconds": seconds, "conveyor_mm_s": conveyor_mm_s,
                    "exposure_s": EXPOSURE_S,
                    "sequences": {s.name: {"kind": s.kind, "fps": s.fps, "frames": s.frames}
                                  for s in plans}}
        (tmp / "sequences.json").write_text(dumps_json(manifest))

    build_folder(out, "sequences.json", _FORMAT_SET, build, "the sequences")
    return SequencesSummary(out, out / "stereo.yaml", out / model_path,
                            tuple(s.name for s in plans), total - 1)
