"""A servoed pick from a moving conveyor: the hand cameras track the garment while the arm
approaches it, and the grasp is aimed again at every frame.

Time runs in ticks of one camera frame (``1 / fps``). At tick ``k`` the arm stands at joints
``q_k``; the command for the coming tick is made from the measurements up to frame ``k - 1``
(one frame of latency); frame ``k`` is exposed at ``t_k = k / fps`` from the pose the arm has
then, moving at the commanded rate (motion blur), and tracked; the arm then follows the
commanded joint rates exactly for one tick (an ideal joint servo). The command is a Cartesian
twist of the TCP, the target's velocity plus a proportional pull towards it, limited in speed
and turn rate, mapped to joint rates by damped least squares on the TCP's Jacobian.

The target is the grasp pose (:func:`~photomodel.robot.grasp_pose`, with the half turn of
the gripper that keeps the garment upright in the cameras when the wrist allows it) of the
garment's pose predicted for the tick's start (the command adds the target's velocity),
raised by a height ``h`` along the grasp's z. The steered point is the middle of the rig's
baseline at the tracking height (the garment stays in the middle of both views, also while
the hand turns) and slides to the TCP as ``h`` falls. The prediction is a straight line at
constant velocity in the table's plane fitted, in the base frame, to the last
:attr:`ServoSettings.fit_window_s` of measurements (``T_base_hand(q_k) @ T_hand_cam1 @
T_cam1_model``), with the belt's nominal velocity until there are three; a measurement far
from the prediction, or of a garment less than :attr:`ServoSettings.min_visible` in view, is
ignored. Phases: ``follow`` (``h`` at the tracking height until the steered point is aligned
with its target), ``descend`` (``h`` falls at :attr:`ServoSettings.descent_mm_s`; once the
garment is less than ``min_visible`` in view the cameras are no longer used), ``close`` (the
gripper closes when ``h`` is 0 and the TCP is within :attr:`ServoSettings.close_mm` of its
target, or :attr:`ServoSettings.settle_s` after ``h`` reached 0).

Three ways to aim (:data:`AIM_MODES`) run on the same order with the same controller:
``open_loop`` holds the pose of the first frame (the cell's single measurement before it
moves); ``belt`` moves that pose at the belt's nominal speed (a conveyor encoder: what an
industrial cell does when the garment does not slip on the belt); ``servo`` uses the tracker
at every frame. The grasp error is the TCP's position when the gripper closes against the
true grasp point of the garment at that instant, in the base frame, mm.
"""

from __future__ import annotations

import math
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.spatial.transform import Rotation

from photomodel.camera import StereoRig
from photomodel.cell._cell import CellConfig, CellSetup, _photo_model, _stats, make_cell
from photomodel.geometry import invert_transform, make_transform
from photomodel.model import PhotoModel
from photomodel.robot import forward_kinematics, grasp_pose, jacobian
from photomodel.track import Tracker, TrackerConfig, TrackResult

__all__ = [
    "AIM_MODES",
    "ServoOutcome",
    "ServoReport",
    "ServoSettings",
    "ServoTick",
    "run_servo_cell",
    "run_servo_order",
]

AIM_MODES: tuple[str, ...] = ("open_loop", "belt", "servo")
"""How a pick is aimed (module docstring), in the order they are reported."""

_ROTATION_WEIGHT_MM = 300.0  # turns weigh like moves of this lever arm in the least squares
_DAMPING_MM = 5.0


@dataclass(frozen=True)
class ServoSettings:
    """Settings of a servoed pick (module docstring).

    Parameters
    ----------
    fps : float
        Camera frame rate = control rate, frames per second.
    conveyor_mm_s : float
        Belt speed, mm/s (0: a still garment).
    track_height_mm : float
        Height of the TCP above the grasp point while following, mm.
    descent_mm_s : float
        Speed of the final descent, mm/s.
    max_speed_mm_s, max_turn_deg_s : float
        Limits of the TCP's commanded speed (mm/s) and turn rate (deg/s).
    gain_per_s : float
        Proportional gain of the pull towards the target, 1/s.
    align_mm, align_deg : float
        How close to its target the TCP must be to start descending.
    close_mm : float
        How close to the grasp the TCP must be for the gripper to close, mm.
    settle_s : float
        The gripper closes at the latest this long after the descent ended, s.
    fit_window_s : float
        Measurements of the last this many seconds make the prediction, s.
    gate_mm : float
        A measurement farther than this from the prediction is ignored, mm.
    min_visible : float
        A measurement of a garment less visible than this share is ignored: close above it
        the hand sees too little of it to be accurate; from the first such frame of the
        descent on, the pick finishes on the prediction.
    max_lost_frames : int
        After this many frames in a row without the garment the cameras are no longer used
        and the pick finishes on the prediction.
    view_limit_deg : float
        While the cameras are used, the hand turns the garment at most this far from upright
        in the images (within the tracker's in-plane range of +-140 deg); a grasp with the
        gripper's other half turn finishes its turn blind.
    timeout_s : float
        An order that has not closed after this long fails, s.
    tracker : TrackerConfig
        The tracker's settings: coarse to fine in every frame and wider windows than a
        still hand's, since the hand's own accelerations move the garment in the image.
    """

    fps: float = 30.0
    conveyor_mm_s: float = 200.0
    track_height_mm: float = 300.0
    descent_mm_s: float = 250.0
    max_speed_mm_s: float = 600.0
    max_turn_deg_s: float = 180.0
    gain_per_s: float = 6.0
    align_mm: float = 5.0
    align_deg: float = 2.0
    close_mm: float = 1.0
    settle_s: float = 0.3
    fit_window_s: float = 0.8
    gate_mm: float = 10.0
    min_visible: float = 0.6
    max_lost_frames: int = 5
    view_limit_deg: float = 120.0
    timeout_s: float = 8.0
    tracker: TrackerConfig = field(
        default_factory=lambda: TrackerConfig(levels=(1, 0), margin_mm=30.0))

    def __post_init__(self) -> None:
        checks = {"fps": (self.fps, 1.0, 240.0), "conveyor_mm_s": (self.conveyor_mm_s, 0.0, 500.0),
                  "track_height_mm": (self.track_height_mm, 50.0, 600.0),
                  "descent_mm_s": (self.descent_mm_s, 10.0, 1000.0),
                  "max_speed_mm_s": (self.max_speed_mm_s, 10.0, 3000.0),
                  "timeout_s": (self.timeout_s, 0.5, 120.0)}
        for name, (value, lo, hi) in checks.items():
            if not (math.isfinite(value) and lo <= value <= hi):
                raise ValueError(f"{name}: expected {lo:g} to {hi:g}, got {value:g}")

    def to_json_dict(self) -> dict[str, Any]:
        d = {k: v for k, v in self.__dict__.items() if k != "tracker"}
        t = self.tracker
        d["tracker"] = {"levels": list(t.levels), "fallback_levels": list(t.fallback_levels),
                        "margin_mm": t.margin_mm, "max_jump_mm": t.max_jump_mm}
        return d


@dataclass(frozen=True)
class ServoTick:
    """The cell at one tick of a servoed order (for drawing it).

    ``q`` (n,) rad; ``T_base_model_true`` and ``T_base_model_aim`` (the prediction the
    command used) (4, 4) mm; ``image`` camera 1's frame (H, W, 3) uint8 or None (not
    rendered); ``T_cam1_model`` the tracker's pose in that frame or None; ``phase``.
    """

    t_s: float
    q: NDArray[np.float64]
    T_base_model_true: NDArray[np.float64]
    T_base_model_aim: NDArray[np.float64]
    phase: str
    image: NDArray[np.uint8] | None = None
    T_cam1_model: NDArray[np.float64] | None = None
    mode: str | None = None
    visible: float = math.nan
    note: str | None = None


class _LineFit:
    """The garment's pose predicted by a constant-velocity line through recent measurements
    (base frame, mm); the orientation is the latest measurement's.

    ``velocity_mm_s`` (3,) replaces the fitted velocity always, ``prior_mm_s`` (3,) only while
    fewer than three measurements make the fit (zero velocity without one). A fitted velocity
    keeps only its part in the plane of normal ``normal`` (3,): a garment on a table or a belt
    moves in its plane, and the depth of the poses measured close above it wavers most.
    """

    def __init__(self, window_s: float, velocity_mm_s: NDArray[np.float64] | None = None,
                 prior_mm_s: NDArray[np.float64] | None = None,
                 normal: NDArray[np.float64] | None = None) -> None:
        self.window_s = window_s
        self.normal = None if normal is None else np.asarray(normal, float) / np.linalg.norm(
            normal)
        self.known_velocity = velocity_mm_s
        self.prior = np.zeros(3) if prior_mm_s is None else np.asarray(prior_mm_s, float)
        self._t: deque[float] = deque()
        self._p: deque[NDArray[np.float64]] = deque()
        self._R = np.eye(3)

    def __len__(self) -> int:
        return len(self._t)

    def add(self, t_s: float, T: NDArray[np.float64]) -> None:
        self._t.append(t_s)
        self._p.append(T[:3, 3].copy())
        self._R = T[:3, :3].copy()
        while self._t and self._t[0] < t_s - self.window_s:
            self._t.popleft()
            self._p.popleft()

    def line(self) -> tuple[float, NDArray[np.float64], NDArray[np.float64]]:
        """(t_ref, position at t_ref, velocity) of the fit."""
        t = np.asarray(self._t)
        p = np.asarray(self._p)
        if self.known_velocity is not None:
            return float(t[-1]), p[-1], self.known_velocity
        if len(t) < 3:
            return float(t[-1]), p[-1], self.prior
        t_ref = float(t.mean())
        dt = t - t_ref
        velocity = (dt @ (p - p.mean(axis=0))) / float(dt @ dt)
        if self.normal is not None:
            velocity = velocity - (velocity @ self.normal) * self.normal
        return t_ref, p.mean(axis=0), velocity

    def predict(self, t_s: float) -> NDArray[np.float64]:
        t_ref, p, v = self.line()
        return make_transform(self._R, p + v * (t_s - t_ref))

    def velocity(self) -> NDArray[np.float64]:
        return self.line()[2]


def _tcp_jacobian(arm: Any, q: NDArray[np.float64], tcp_mm: float) -> NDArray[np.float64]:
    """Jacobian (6, n) of the TCP (``tcp_mm`` along the hand's z) in the base frame."""
    J = jacobian(arm, q)
    r = forward_kinematics(arm, q)[:3, :3] @ np.array([0.0, 0.0, tcp_mm])
    skew = np.array([[0.0, -r[2], r[1]], [r[2], 0.0, -r[0]], [-r[1], r[0], 0.0]])
    out = J.copy()
    out[:3] = J[:3] - skew @ J[3:]
    return out


def _joint_rates(arm: Any, q: NDArray[np.float64], tcp_mm: float,
                 twist: NDArray[np.float64]) -> NDArray[np.float64]:
    """Joint rates (n,) rad/s giving the TCP ``twist`` (mm/s, rad/s), damped least squares."""
    J = _tcp_jacobian(arm, q, tcp_mm)
    W = np.array([1.0, 1.0, 1.0, _ROTATION_WEIGHT_MM, _ROTATION_WEIGHT_MM, _ROTATION_WEIGHT_MM])
    Jw = J * W[:, None]
    A = Jw @ Jw.T + _DAMPING_MM**2 * np.eye(6)
    return Jw.T @ np.linalg.solve(A, twist * W)


def _clip_norm(v: NDArray[np.float64], limit: float) -> NDArray[np.float64]:
    n = float(np.linalg.norm(v))
    return v if n <= limit else v * (limit / n)


@dataclass
class _Order:
    """What one order needs, shared by its three aims."""

    index: int
    garment: str
    model: PhotoModel
    scene: Any  # sim.ConveyorView
    T_base_table: NDArray[np.float64]
    first: TrackResult
    T_base_model_first: NDArray[np.float64] | None
    image_first: NDArray[np.uint8]


class _Aim:
    """One aim's run through an order (module docstring)."""

    def __init__(self, mode: str, setup: CellSetup, config: CellConfig, servo: ServoSettings,
                 order: _Order, tracker: Tracker | None, keep_ticks: bool) -> None:
        self.mode, self.setup, self.config, self.servo, self.order = (mode, setup, config,
                                                                      servo, order)
        self.tracker = tracker
        self.keep_ticks = keep_ticks
        self.ticks: list[ServoTick] = []
        v_belt = order.T_base_table[:3, :3] @ np.array([0.0, servo.conveyor_mm_s, 0.0])
        self.fit = _LineFit(servo.fit_window_s, v_belt if mode == "belt" else None,
                            v_belt if mode == "servo" else None, order.T_base_table[:3, 2])
        assert order.T_base_model_first is not None
        self.fit.add(0.0, order.T_base_model_first)
        gripper = config.pick.gripper
        self.T_hand_tcp = gripper.T_hand_tcp
        self.tcp_mm = gripper.tcp_mm
        rig_centre_cam1 = _rig_centre_cam1(setup.rig)
        c = (invert_transform(self.T_hand_tcp) @ setup.T_hand_cam1
             @ np.append(rig_centre_cam1, 1.0))[:3]
        self.view_shift_tcp = np.array([c[0], c[1], 0.0])
        self.track_ms: list[float] = []
        self.counts = {"frames": 0, "track": 0, "detect": 0, "lost": 0, "used": 0, "gated": 0}
        self.last_used_s = 0.0

    # -- the target ----------------------------------------------------------------------

    def target(self, t_s: float, h_mm: float, x_prefer: NDArray[np.float64],
               view_limit_deg: float | None = None, x_now: NDArray[np.float64] | None = None
               ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """The command's target for time ``t_s`` at height ``h_mm``: the grasp orientation
        (3, 3), where the steered point should be (3,) (``h_mm`` above the grasp point along
        the grasp's z), and the garment's predicted pose (4, 4).

        With ``view_limit_deg``, a grasp that would turn the garment farther than that from
        upright in the cameras (the gripper's other half turn) is turned only that far, on
        the side of the gripper's x now, ``x_now`` (3,), so that the tracker can follow; the
        rest of the turn waits until the cameras are no longer used.
        """
        T_model = self.fit.predict(t_s)
        T_grasp = grasp_pose(T_model, self.config.pick.grasp_point_mm, x_prefer)
        R = T_grasp[:3, :3]
        if view_limit_deg is not None and x_now is not None:
            x_garment = T_model[:3, 0]
            off = _yaw_between(x_garment, R[:, 0])
            limit = math.radians(view_limit_deg)
            if abs(off) > limit:
                side = math.copysign(1.0, _yaw_between(x_garment, x_now))
                R = Rotation.from_rotvec([0.0, 0.0, side * limit - off]).as_matrix() @ R
        return R, T_grasp[:3, 3] - h_mm * T_grasp[:3, 2], T_model

    def steered(self, T_tcp: NDArray[np.float64], h_mm: float) -> NDArray[np.float64]:
        """The point the command steers (3,), base frame: the middle of the rig's baseline
        (projected along the TCP's axis) at the tracking height, the TCP at the grasp, in
        between in proportion to ``h_mm``."""
        s = min(max(h_mm / self.servo.track_height_mm, 0.0), 1.0)
        return T_tcp[:3, 3] + T_tcp[:3, :3] @ (s * self.view_shift_tcp)

    # -- vision --------------------------------------------------------------------------

    def look(self, k: int, t_s: float, q: NDArray[np.float64], qdot: NDArray[np.float64]
             ) -> tuple[NDArray[np.uint8], TrackResult]:
        """Frame ``k`` from the arm moving through ``q`` at ``qdot``, tracked; a pose
        consistent with the prediction is added to the fit."""
        setup, order = self.setup, self.order
        T_table_base = invert_transform(order.T_base_table)

        def T_table_cam1_at(t: float) -> NDArray[np.float64]:
            T_base_hand = forward_kinematics(setup.arm, q + (t - t_s) * qdot)
            return T_table_base @ T_base_hand @ setup.T_hand_cam1_true

        frame = order.scene.frame(k, t_s, T_table_cam1_at)
        assert self.tracker is not None
        T_base_cam1 = forward_kinematics(setup.arm, q) @ setup.T_hand_cam1
        T_expected = self.fit.predict(t_s)
        result = self.tracker(frame.right_bgr, frame.left_bgr, t_s=t_s, rng=k,
                              predicted=invert_transform(T_base_cam1) @ T_expected)
        self.counts["frames"] += 1
        self.counts[result.mode] += 1
        self.track_ms.append(1000.0 * result.seconds)
        if result.found and result.visible >= self.servo.min_visible:
            T = T_base_cam1 @ result.T_cam1_model
            miss = float(np.linalg.norm(T[:3, 3] - T_expected[:3, 3]))
            if len(self.fit) >= 3 and miss > self.servo.gate_mm:
                self.counts["gated"] += 1
            else:
                self.fit.add(t_s, T)
                self.counts["used"] += 1
                self.last_used_s = t_s
        return frame.right_bgr, result

    # -- the loop ------------------------------------------------------------------------

    def run(self) -> dict[str, Any]:
        servo, setup = self.servo, self.setup
        arm = setup.arm
        dt = 1.0 / servo.fps
        q = setup.q_photo.copy()
        h = servo.track_height_mm
        phase = "follow"
        settled_s: float | None = None
        blind = False
        lost_run = 0
        max_turn = math.radians(servo.max_turn_deg_s)
        n_ticks = int(math.ceil(servo.timeout_s * servo.fps))
        x_prefer = _gripper_x(arm, q, self.tcp_mm, self.T_hand_tcp, self.fit.predict(0.0))
        for k in range(n_ticks):
            t = k * dt
            T_tcp = forward_kinematics(arm, q) @ self.T_hand_tcp
            if phase == "descend":
                h = max(0.0, h - servo.descent_mm_s * dt)
            watching = self.mode == "servo" and not blind
            R_target, p_target, T_aim = self.target(
                t, h, x_prefer, servo.view_limit_deg if watching else None, T_tcp[:3, 0])
            # steer the rig's point, so that turning the hand keeps the garment in view;
            # feedforward: the garment's velocity, the descent, the steered point's slide
            rate = servo.descent_mm_s if phase == "descend" and h > 0 else 0.0
            r = self.steered(T_tcp, h) - T_tcp[:3, 3]
            e_pos = p_target - T_tcp[:3, 3] - r
            e_rot = Rotation.from_matrix(R_target @ T_tcp[:3, :3].T).as_rotvec()
            v_point = _clip_norm(self.fit.velocity() + rate * R_target[:, 2]
                                 + servo.gain_per_s * e_pos, servo.max_speed_mm_s)
            w = _clip_norm(servo.gain_per_s * e_rot, max_turn)
            slide = rate / servo.track_height_mm * (T_tcp[:3, :3] @ self.view_shift_tcp)
            v = v_point - np.cross(w, r) + slide
            qdot = _joint_rates(arm, q, self.tcp_mm, np.concatenate([v, w]))
            image, T_seen, seen_mode, seen_share, note = None, None, None, math.nan, None
            if k == 0:
                first = self.order.first
                image, T_seen, seen_mode = self.order.image_first, first.T_cam1_model, first.mode
                seen_share = float(first.visible)
            elif self.mode == "servo" and not blind:
                image, result = self.look(k, t, q, qdot)
                T_seen = result.T_cam1_model if result.found else None
                seen_mode, seen_share, note = result.mode, float(result.visible), result.note
                # close above the garment a lost view does not come back: finish on the fit
                lost_run = 0 if result.found else lost_run + 1
                blind = lost_run >= servo.max_lost_frames or (phase == "descend" and not (
                    result.found and result.visible >= servo.min_visible))
            if self.keep_ticks:
                T_true = self.order.T_base_table @ self.order.scene.T_table_model(t)
                self.ticks.append(ServoTick(t, q.copy(), T_true, T_aim, phase, image, T_seen,
                                            seen_mode, seen_share, note))
            q = q + qdot * dt
            if not arm.within_limits(q):
                return self._record(t + dt, q, "joint limits reached during the approach")
            err = float(np.linalg.norm(e_pos))
            if phase == "follow" and err <= servo.align_mm and (
                    math.degrees(float(np.linalg.norm(e_rot))) <= servo.align_deg):
                phase = "descend"
            elif phase == "descend" and h == 0.0:
                settled_s = t if settled_s is None else settled_s
                R_goal, p_goal, _ = self.target(t + dt, 0.0, x_prefer)
                T_now = forward_kinematics(arm, q) @ self.T_hand_tcp
                turned = Rotation.from_matrix(R_goal @ T_now[:3, :3].T).magnitude()
                close = (np.linalg.norm(p_goal - T_now[:3, 3]) <= servo.close_mm
                         and math.degrees(turned) <= servo.align_deg)
                if close or t + dt - settled_s >= servo.settle_s:
                    return self._record(t + dt, q, None)
        return self._record(n_ticks * dt, q, f"not closed within {servo.timeout_s:g} s")

    def _record(self, t_close: float, q: NDArray[np.float64], failure: str | None
                ) -> dict[str, Any]:
        T_tcp = forward_kinematics(self.setup.arm, q) @ self.T_hand_tcp
        T_true = self.order.T_base_table @ self.order.scene.T_table_model(t_close)
        grasp_true = grasp_pose(T_true, self.config.pick.grasp_point_mm)[:3, 3]
        err = T_tcp[:3, 3] - grasp_true
        norm = float(np.linalg.norm(err))
        out: dict[str, Any] = {
            "closed": failure is None, "reason": failure, "close_s": t_close,
            "grasp_error_mm": err.tolist(), "grasp_error_norm_mm": norm,
            "grasp_error_xy_mm": float(np.hypot(err[0], err[1])),
            "within_tolerance": failure is None and norm <= self.config.tolerance_mm,
        }
        if self.mode == "servo":
            ms = np.asarray(self.track_ms) if self.track_ms else np.zeros(1)
            out.update(self.counts, track_ms_median=float(np.median(ms)),
                       track_ms_max=float(ms.max()),
                       blind_s=float(t_close - self.last_used_s))
        return out


def _yaw_between(a: NDArray[np.float64], b: NDArray[np.float64]) -> float:
    """The angle (rad) about the base's z from direction ``a`` (3,) to ``b`` (3,), in
    (-pi, pi]."""
    return math.atan2(a[0] * b[1] - a[1] * b[0], a[0] * b[0] + a[1] * b[1])


def _gripper_x(arm: Any, q: NDArray[np.float64], tcp_mm: float, T_hand_tcp: NDArray[np.float64],
               T_base_model: NDArray[np.float64], margin_deg: float = 45.0
               ) -> NDArray[np.float64]:
    """Which half turn of the two-finger gripper to grasp with (its x (3,), base frame).

    The garment's own x when the wrist can turn there with ``margin_deg`` to spare: the
    cameras, square to the gripper, then see the garment as upright as its photo, where the
    tracker's rotations are well inside their range; else the other half turn, when that
    fits; else the smaller turn. The yaw about the base's z is turned by the last joint that
    turns the hand about that axis (the wrist, for a hand pointing down); the margin leaves
    room for the yaw the other joints add while the arm follows the garment.
    """
    T_tcp = forward_kinematics(arm, q) @ T_hand_tcp
    J = _tcp_jacobian(arm, q, tcp_mm)
    j = int(np.flatnonzero(np.abs(J[5]) > 0.7)[-1])
    x_now = T_tcp[:3, 0]
    margin = math.radians(margin_deg)
    best, best_cost = T_base_model[:3, 0], math.inf
    for flipped, x in enumerate((T_base_model[:3, 0], -T_base_model[:3, 0])):
        turn = _yaw_between(x_now, x)
        q_j = q[j] + turn / J[5, j]
        fits = arm.q_min_rad[j] + margin <= q_j <= arm.q_max_rad[j] - margin
        cost = (0.0 if fits else 10.0) + flipped + abs(turn) / 10.0
        if cost < best_cost:
            best, best_cost = x, cost
    return np.asarray(best, dtype=np.float64)


def _rig_centre_cam1(rig: StereoRig) -> NDArray[np.float64]:
    """The middle of the baseline in camera 1's frame (3,), mm."""
    return (-rig.R.T @ np.asarray(rig.T, dtype=np.float64).reshape(3)) / 2.0


@dataclass
class ServoOutcome:
    """One order: its record (JSON-ready) and, when kept, the servoed aim's ticks."""

    record: dict[str, Any]
    ticks: list[ServoTick] = field(default_factory=list)
    model: PhotoModel | None = None


def run_servo_order(config: CellConfig, setup: CellSetup, servo: ServoSettings, index: int,
                    trackers: dict[str, Tracker] | None = None, keep_ticks: bool = False,
                    modes: tuple[str, ...] = AIM_MODES) -> ServoOutcome:
    """Order ``index`` on a conveyor, aimed every way of ``modes`` (module docstring).

    The order's garment (``config.garments`` in turn) rides the belt of a
    :class:`~photomodel.sim.ConveyorView`; frame 0, taken from ``setup.q_photo``, is detected
    by a :class:`~photomodel.track.Tracker` (one per garment, kept in ``trackers``).
    """
    from photomodel.sim import ConveyorView, table_in_base

    unknown = set(modes) - set(AIM_MODES)
    if unknown:
        raise ValueError(f"modes: expected some of {', '.join(AIM_MODES)}, got {sorted(unknown)}")
    trackers = {} if trackers is None else trackers
    garment = config.garments[index % len(config.garments)]
    t0 = time.perf_counter()
    model = _photo_model(garment, config.seed)
    tracker = trackers.get(garment)
    if tracker is None:
        tracker = trackers[garment] = Tracker(model, setup.rig, config=servo.tracker)
    tracker.reset()
    scene = ConveyorView(garment, speed_mm_s=servo.conveyor_mm_s, seed=config.seed,
                         key=("cell", index), rig=setup.rig)
    T_base_table = table_in_base(setup.layout)
    T_table_cam1 = (invert_transform(T_base_table) @ forward_kinematics(setup.arm, setup.q_photo)
                    @ setup.T_hand_cam1_true)
    frame0 = scene.frame(0, 0.0, lambda t: T_table_cam1)
    first = tracker(frame0.right_bgr, frame0.left_bgr, t_s=0.0, rng=0)
    T_first = (forward_kinematics(setup.arm, setup.q_photo) @ setup.T_hand_cam1
               @ first.T_cam1_model) if first.found else None
    order = _Order(index, garment, model, scene, T_base_table, first, T_first, frame0.right_bgr)
    record: dict[str, Any] = {"order": index, "garment": garment, "found": bool(first.found),
                              "score": float(first.score), "detect_s": float(first.seconds),
                              "start": scene.facts}
    ticks: list[ServoTick] = []
    for mode in modes:
        if T_first is None:
            record[mode] = {"closed": False, "reason": f"not found (score {first.score:.2f})"}
            continue
        aim = _Aim(mode, setup, config, servo, order, tracker if mode == "servo" else None,
                   keep_ticks and mode == "servo")
        record[mode] = aim.run()
        ticks = ticks or aim.ticks
    record["cycle_seconds"] = time.perf_counter() - t0
    return ServoOutcome(record, ticks, model)


@dataclass(frozen=True)
class ServoReport:
    """Orders, their summary (JSON-ready), the set-up and the kept order's ticks."""

    cycles: list[dict[str, Any]]
    summary: dict[str, Any]
    setup: CellSetup
    kept: ServoOutcome | None = None

    def to_json_dict(self) -> dict[str, Any]:
        return {"summary": self.summary, "cycles": self.cycles}


def summarise_servo(config: CellConfig, servo: ServoSettings, setup: CellSetup,
                    cycles: list[dict[str, Any]], seconds: float) -> dict[str, Any]:
    """Per aim: orders closed, within the tolerance, and the grasp error's statistics (mm)."""
    aims: dict[str, Any] = {}
    for mode in AIM_MODES:
        rows = [c[mode] for c in cycles if mode in c]
        if not rows:
            continue
        closed = [r for r in rows if r["closed"]]
        aims[mode] = {
            "orders": len(rows), "closed": len(closed),
            "within_tolerance": sum(bool(r["within_tolerance"]) for r in rows),
            "grasp_error_mm": _stats([r["grasp_error_norm_mm"] for r in closed]),
            "grasp_error_xy_mm": _stats([r["grasp_error_xy_mm"] for r in closed]),
            "close_s": _stats([r["close_s"] for r in closed]),
        }
        if mode == "servo":
            aims[mode]["track_ms_median"] = _stats([r["track_ms_median"] for r in closed])
            aims[mode]["blind_s"] = _stats([r["blind_s"] for r in closed])
            aims[mode]["frames"] = int(sum(r.get("frames", 0) for r in rows))
            for key in ("track", "detect", "lost", "gated"):
                aims[mode][f"{key}_frames"] = int(sum(r.get(key, 0) for r in rows))
    return {"orders": len(cycles), "found": sum(bool(c["found"]) for c in cycles),
            "tolerance_mm": config.tolerance_mm, "aims": aims, "hand_eye": setup.hand_eye_info,
            "seconds": seconds, "config": config.to_json_dict(), "servo": servo.to_json_dict()}


def run_servo_cell(config: CellConfig, servo: ServoSettings | None = None,
                   progress: Callable[[int, int, str], None] | None = None,
                   keep: int | None = None) -> ServoReport:
    """Run ``config.orders`` orders on a conveyor, each aimed every way (module docstring).

    ``keep``: the order whose servoed ticks are kept (for :func:`animate_servo`), or None.
    ``progress(done, total, what)`` after each order.
    """
    servo = servo or ServoSettings()
    t0 = time.perf_counter()
    setup = make_cell(config)
    trackers: dict[str, Tracker] = {}
    cycles: list[dict[str, Any]] = []
    kept: ServoOutcome | None = None
    for k in range(config.orders):
        outcome = run_servo_order(config, setup, servo, k, trackers, keep_ticks=k == keep)
        if k == keep:
            kept = outcome
        cycles.append(outcome.record)
        if progress is not None:
            s = outcome.record.get("servo", {})
            what = (f"{outcome.record['garment']}: servoed {s['grasp_error_norm_mm']:.1f} mm"
                    if s.get("closed") else f"{outcome.record['garment']}: {s.get('reason')}")
            progress(k + 1, config.orders, what)
    return ServoReport(cycles, summarise_servo(config, servo, setup, cycles,
                                               time.perf_counter() - t0), setup, kept)
