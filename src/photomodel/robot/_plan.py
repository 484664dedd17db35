"""Grasp and place planning: from the garment's pose in the base frame to joint waypoints.

Frames: ``base`` (the arm's), ``hand`` (tool flange), ``tcp`` (the gripper's closing point,
:attr:`Gripper.tcp_mm` along the hand's z), ``model`` (the garment), ``box`` (the 220 x 220 mm
box of the seed's Fig. 1: origin at the centre of its floor, z up). Lengths in mm.

The grasp: the TCP at the grasp point of the garment (default the model origin, i.e. the area
centroid of the silhouette), its z along the model's z (into the garment plane, i.e. down onto the
cloth), its x along the model's x (the gripper's yaw follows the garment's in-plane angle), the
sign of x chosen so that the wrist turns least from the current hand pose (a two-finger gripper is
symmetric under a half turn). Waypoints: ``start`` (the given joints), ``pre_grasp``
(``approach_mm`` back along the TCP's z), ``grasp``, ``lift`` (``retreat_mm`` straight up in the
base frame), ``pre_place`` (above the box centre, TCP x along the box's x up to a half turn),
``place`` (``release_mm`` above the box floor), ``retreat`` (back to ``pre_place``). Straight
segments (approach, lift, descent into the box, retreat) are checked at intermediate poses.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial.transform import Rotation, Slerp

from photomodel.errors import PhotomodelError
from photomodel.geometry import invert_transform, make_transform, quat_wxyz_from_matrix
from photomodel.robot._arm import ArmModel
from photomodel.robot._kinematics import IKSettings, forward_kinematics, inverse_kinematics

__all__ = [
    "CellLayout",
    "Gripper",
    "PickPlan",
    "PickSettings",
    "UnreachableError",
    "Waypoint",
    "grasp_pose",
    "plan_pick",
]


class UnreachableError(PhotomodelError):
    """A pose of the plan cannot be reached within the joint limits (or at all)."""


@dataclass(frozen=True)
class Gripper:
    """The gripper on the flange.

    Parameters
    ----------
    tcp_mm : float
        Distance of the closing point (TCP) from the flange along the hand's z, mm.
    """

    tcp_mm: float = 150.0

    @property
    def T_hand_tcp(self) -> NDArray[np.float64]:
        """``T_hand_tcp`` (4, 4): a pure offset along the hand's z."""
        return make_transform(np.eye(3), [0.0, 0.0, self.tcp_mm])


@dataclass(frozen=True)
class CellLayout:
    """Where the box and the work table are, in the base frame.

    Parameters
    ----------
    box_centre_mm : (float, float, float)
        Centre of the box's floor in the base frame, mm.
    box_yaw_deg : float
        Rotation of the box about the base's z, degrees.
    box_size_mm : float
        Inner side of the square box (the seed's 220 mm).
    box_depth_mm : float
        Height of its walls, mm.
    table_centre_mm : (float, float, float)
        Centre of the work table's top in the base frame (where the hand cameras look), mm.
    table_size_mm : (float, float)
        Extent of the table top along base x and y (drawing only), mm.
    """

    box_centre_mm: tuple[float, float, float] = (150.0, -600.0, 0.0)
    box_yaw_deg: float = 0.0
    box_size_mm: float = 220.0
    box_depth_mm: float = 100.0
    table_centre_mm: tuple[float, float, float] = (600.0, 0.0, 0.0)
    table_size_mm: tuple[float, float] = (600.0, 700.0)

    def __post_init__(self) -> None:
        if self.box_size_mm <= 0 or self.box_depth_mm < 0:
            raise ValueError("box_size_mm > 0 and box_depth_mm >= 0 expected")

    @property
    def T_base_box(self) -> NDArray[np.float64]:
        """``T_base_box`` (4, 4): box floor centre, z up."""
        R = Rotation.from_euler("z", np.radians(self.box_yaw_deg)).as_matrix()
        return make_transform(R, self.box_centre_mm)


@dataclass(frozen=True)
class PickSettings:
    """Settings of :func:`plan_pick`.

    Parameters
    ----------
    grasp_point_mm : (float, float)
        Grasp point in the model frame (x, y), mm; (0, 0) = the garment's centroid.
    approach_mm : float
        Height of the pre-grasp pose above the grasp point (along the TCP's z), mm.
    retreat_mm : float
        Height of the lift after grasping, straight up in the base frame, mm.
    release_mm : float
        Height of the TCP above the box floor when releasing, mm.
    place_clearance_mm : float
        Height of ``pre_place`` above the box's rim, mm.
    segment_steps : int
        Intermediate poses checked on each straight segment.
    gripper : Gripper
    ik : IKSettings
    """

    grasp_point_mm: tuple[float, float] = (0.0, 0.0)
    approach_mm: float = 100.0
    retreat_mm: float = 150.0
    release_mm: float = 30.0
    place_clearance_mm: float = 100.0
    segment_steps: int = 4
    gripper: Gripper = field(default_factory=Gripper)
    ik: IKSettings = field(default_factory=lambda: IKSettings(restarts=20))

    def __post_init__(self) -> None:
        if self.approach_mm < 0 or self.retreat_mm < 0 or self.release_mm < 0:
            raise ValueError("approach_mm, retreat_mm, release_mm: expected non-negative heights")
        if self.segment_steps < 0:
            raise ValueError("segment_steps: expected >= 0")


@dataclass(frozen=True)
class Waypoint:
    """One pose of the plan: ``T_base_tcp`` and the joints ``q`` (n,) radians that reach it."""

    name: str
    T_base_tcp: NDArray[np.float64]
    q: NDArray[np.float64]

    def to_json_dict(self) -> dict[str, Any]:
        return {"name": self.name, "T_base_tcp": self.T_base_tcp.tolist(),
                "position_mm": self.T_base_tcp[:3, 3].tolist(),
                "quat_wxyz": quat_wxyz_from_matrix(self.T_base_tcp[:3, :3]).tolist(),
                "joints_deg": np.degrees(self.q).tolist()}


@dataclass(frozen=True)
class PickPlan:
    """A pick-and-place plan in the base frame.

    Parameters
    ----------
    T_base_model : ndarray (4, 4)
        The garment's pose in the base frame, mm.
    grasp_point_mm : ndarray (3,)
        The grasp point in the base frame, mm.
    gripper_yaw_deg : float
        Yaw of the gripper's x about the base's z at the grasp, degrees.
    waypoints : tuple of Waypoint
        ``start``, ``pre_grasp``, ``grasp``, ``lift``, ``pre_place``, ``place``, ``retreat``.
    path_q : ndarray (M, n)
        The joint path through every waypoint and the checked intermediate poses of the
        straight segments, radians (for execution or drawing; joint-space interpolation between
        consecutive rows).
    within_limits : bool
        Every row of ``path_q`` lies within the joint limits (always True for a returned plan).
    waypoint_rows : tuple of int
        Row of ``path_q`` of each waypoint.
    """

    T_base_model: NDArray[np.float64]
    grasp_point_mm: NDArray[np.float64]
    gripper_yaw_deg: float
    waypoints: tuple[Waypoint, ...]
    path_q: NDArray[np.float64]
    within_limits: bool
    waypoint_rows: tuple[int, ...] = ()

    def waypoint(self, name: str) -> Waypoint:
        for w in self.waypoints:
            if w.name == name:
                return w
        raise KeyError(name)

    def to_json_dict(self) -> dict[str, Any]:
        return {"T_base_model": self.T_base_model.tolist(),
                "grasp_point_mm": self.grasp_point_mm.tolist(),
                "gripper_yaw_deg": self.gripper_yaw_deg,
                "reachable": True, "within_limits": self.within_limits,
                "waypoints": [w.to_json_dict() for w in self.waypoints],
                "path_points": int(len(self.path_q))}


def _down_frame(origin: ArrayLike, z: ArrayLike, x_hint: ArrayLike,
                x_prefer: ArrayLike) -> NDArray[np.float64]:
    """A frame at ``origin`` with axis z, x = x_hint made orthogonal, flipped towards x_prefer."""
    zz = np.asarray(z, dtype=np.float64)
    zz = zz / np.linalg.norm(zz)
    x = np.asarray(x_hint, dtype=np.float64) - (np.asarray(x_hint, dtype=np.float64) @ zz) * zz
    x /= np.linalg.norm(x)
    if x @ np.asarray(x_prefer, dtype=np.float64) < 0:
        x = -x
    return make_transform(np.column_stack([x, np.cross(zz, x), zz]), origin)


def grasp_pose(T_base_model: ArrayLike, grasp_point_mm: tuple[float, float] = (0.0, 0.0),
               x_prefer: ArrayLike = (1.0, 0.0, 0.0)) -> NDArray[np.float64]:
    """``T_base_tcp`` (4, 4) of the grasp (module docstring) for a garment at ``T_base_model``.

    ``x_prefer`` (3,) picks the sign of the gripper's x (the half turn nearer to it).
    """
    T = np.asarray(T_base_model, dtype=np.float64)
    point = T[:3, :3] @ np.array([grasp_point_mm[0], grasp_point_mm[1], 0.0]) + T[:3, 3]
    return _down_frame(point, T[:3, 2], T[:3, 0], x_prefer)


def _with_origin(T: NDArray[np.float64], origin: ArrayLike) -> NDArray[np.float64]:
    out = T.copy()
    out[:3, 3] = np.asarray(origin, dtype=np.float64)
    return out


def plan_pick(
    arm: ArmModel,
    q_start: ArrayLike,
    T_base_model: ArrayLike,
    layout: CellLayout | None = None,
    settings: PickSettings | None = None,
    rng: int | np.random.Generator | None = 0,
) -> PickPlan:
    """Plan picking the garment at ``T_base_model`` and placing it into the box.

    Parameters
    ----------
    arm : ArmModel
    q_start : ndarray (n,)
        The arm's joints now (e.g. where it photographed the table), radians.
    T_base_model : ndarray (4, 4)
        The garment's pose in the base frame, mm
        (``T_base_hand(q) @ T_hand_cam1 @ T_cam1_model``).
    layout : CellLayout, optional
    settings : PickSettings, optional
    rng : int, Generator or None
        Seed of the inverse kinematics' random restarts.

    Returns
    -------
    PickPlan

    Raises
    ------
    UnreachableError
        A waypoint (or a pose on a straight segment) is out of reach or only reachable outside
        the joint limits; the message names it and gives its position in the base frame.
    """
    layout = layout or CellLayout()
    cfg = settings or PickSettings()
    gen = np.random.default_rng(rng)
    q0 = arm.check_joints(q_start, "start joints")
    T_model = np.asarray(T_base_model, dtype=np.float64)
    T_hand_tcp = cfg.gripper.T_hand_tcp
    T_tcp_hand = invert_transform(T_hand_tcp)
    T_start_tcp = forward_kinematics(arm, q0) @ T_hand_tcp

    T_grasp = grasp_pose(T_model, cfg.grasp_point_mm, T_start_tcp[:3, 0])
    T_pre = _with_origin(T_grasp, T_grasp[:3, 3] - cfg.approach_mm * T_grasp[:3, 2])
    T_lift = _with_origin(T_grasp, T_grasp[:3, 3] + [0.0, 0.0, cfg.retreat_mm])
    T_box = layout.T_base_box
    above = cfg.place_clearance_mm + layout.box_depth_mm
    T_pre_place = _down_frame(T_box[:3, :3] @ [0.0, 0.0, above] + T_box[:3, 3],
                              -T_box[:3, 2], T_box[:3, 0], T_grasp[:3, 0])
    T_place = _with_origin(T_pre_place, T_box[:3, :3] @ [0.0, 0.0, cfg.release_mm]
                           + T_box[:3, 3])

    # (name, target, straight segment from the previous pose?)
    legs = [("pre_grasp", T_pre, False), ("grasp", T_grasp, True), ("lift", T_lift, True),
            ("pre_place", T_pre_place, False), ("place", T_place, True),
            ("retreat", T_pre_place, True)]
    waypoints = [Waypoint("start", T_start_tcp, q0)]
    rows = [0]
    path = [q0]
    q, T_prev = q0, T_start_tcp
    for name, T_target, straight in legs:
        steps = cfg.segment_steps if straight else 0
        slerp = Slerp([0.0, 1.0], Rotation.from_matrix(np.stack([T_prev[:3, :3],
                                                                 T_target[:3, :3]])))
        for s in np.linspace(0.0, 1.0, steps + 2)[1:]:
            T_s = make_transform(slerp([s]).as_matrix()[0],
                                 (1 - s) * T_prev[:3, 3] + s * T_target[:3, 3])
            result = inverse_kinematics(arm, T_s @ T_tcp_hand, q, cfg.ik, gen)
            if not result.success:
                where = name if s == 1.0 else f"the straight move to {name}"
                x, y, z = T_s[:3, 3]
                raise UnreachableError(f"pick plan: {where} at ({x:.0f}, {y:.0f}, {z:.0f}) mm "
                                       f"in the base frame is out of reach of the {arm.name}: "
                                       f"{result.reason}")
            q = result.q
            path.append(q)
        waypoints.append(Waypoint(name, T_target, q))
        rows.append(len(path) - 1)
        T_prev = T_target
    path_q = np.stack(path)
    yaw = float(np.degrees(np.arctan2(T_grasp[1, 0], T_grasp[0, 0])))
    return PickPlan(T_model, T_grasp[:3, 3].copy(), yaw, tuple(waypoints), path_q,
                    all(arm.within_limits(p) for p in path_q), tuple(rows))
