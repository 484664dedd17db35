"""Forward and inverse kinematics of a DH arm (numpy; the 7-DoF PA10 is redundant).

Inverse kinematics is a damped least-squares (Levenberg-Marquardt) iteration in the form of
Sugihara (2011, "Solvability-unconcerned inverse kinematics by the Levenberg-Marquardt method",
IEEE T-RO 27(5)), the method roboticstoolbox-python's ``ik_LM`` also implements: damping
``lambda = E + w_n`` where ``E`` is half the weighted squared pose error, joint steps clipped to
the joint limits, random restarts when a run stalls. Redundancy is resolved by the start: the
solution is the one the iteration reaches from ``q0`` (so consecutive waypoints seeded from the
previous one stay close in joint space).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial.transform import Rotation

from photomodel.robot._arm import ArmModel

__all__ = [
    "IKResult",
    "IKSettings",
    "forward_kinematics",
    "inverse_kinematics",
    "jacobian",
    "joint_frames",
    "pose_error",
]


def _link_transforms(arm: ArmModel, q: NDArray[np.float64]) -> NDArray[np.float64]:
    """Link transforms T_{i-1,i} (..., n, 4, 4) for joint angles q (..., n)."""
    theta = q + arm.offset_rad
    ct, st = np.cos(theta), np.sin(theta)
    ca, sa = np.cos(arm.alpha_rad), np.sin(arm.alpha_rad)
    T = np.zeros(q.shape + (4, 4))
    T[..., 0, 0] = ct
    T[..., 0, 1] = -st * ca
    T[..., 0, 2] = st * sa
    T[..., 0, 3] = arm.a_mm * ct
    T[..., 1, 0] = st
    T[..., 1, 1] = ct * ca
    T[..., 1, 2] = -ct * sa
    T[..., 1, 3] = arm.a_mm * st
    T[..., 2, 1] = sa
    T[..., 2, 2] = ca
    T[..., 2, 3] = arm.d_mm
    T[..., 3, 3] = 1.0
    return T


def _check_q(arm: ArmModel, q: ArrayLike) -> NDArray[np.float64]:
    arr = np.asarray(q, dtype=np.float64)
    if arr.shape[-1:] != (arm.n_joints,):
        raise ValueError(f"q: expected shape (..., {arm.n_joints}), got {arr.shape}")
    return arr


def joint_frames(arm: ArmModel, q: ArrayLike) -> NDArray[np.float64]:
    """Poses of every DH frame in the base frame, ``T_base_i`` (..., n + 1, 4, 4), i = 0..n.

    Frame 0 is the base (identity), frame n the hand (tool flange). Used for the Jacobian and
    for drawing the arm.
    """
    qa = _check_q(arm, q)
    links = _link_transforms(arm, qa)
    out = np.empty(qa.shape[:-1] + (arm.n_joints + 1, 4, 4))
    out[..., 0, :, :] = np.eye(4)
    for i in range(arm.n_joints):
        out[..., i + 1, :, :] = out[..., i, :, :] @ links[..., i, :, :]
    return out


def forward_kinematics(arm: ArmModel, q: ArrayLike) -> NDArray[np.float64]:
    """``T_base_hand`` (..., 4, 4), mm, for joint angles ``q`` (..., n) in radians."""
    qa = _check_q(arm, q)
    links = _link_transforms(arm, qa)
    T = links[..., 0, :, :]
    for i in range(1, arm.n_joints):
        T = T @ links[..., i, :, :]
    return T


def jacobian(arm: ArmModel, q: ArrayLike) -> NDArray[np.float64]:
    """Geometric Jacobian (6, n) of the hand in the base frame at ``q`` (n,).

    Rows 0-2: linear velocity of the hand origin, mm/rad; rows 3-5: angular velocity, rad/rad.
    """
    frames = joint_frames(arm, q)
    z = frames[:-1, :3, 2]
    o = frames[:-1, :3, 3]
    o_n = frames[-1, :3, 3]
    J = np.empty((6, arm.n_joints))
    J[:3] = np.cross(z, o_n - o).T
    J[3:] = z.T
    return J


def pose_error(T_target: ArrayLike, T: ArrayLike) -> NDArray[np.float64]:
    """Error (6,) taking ``T`` (4, 4) to ``T_target`` (4, 4), both in the base frame.

    (position difference in mm, rotation vector of ``R_target R^T`` in rad), so that a small
    step ``J dq = error`` reduces it.
    """
    Tt = np.asarray(T_target, dtype=np.float64)
    Ta = np.asarray(T, dtype=np.float64)
    e = np.empty(6)
    e[:3] = Tt[:3, 3] - Ta[:3, 3]
    e[3:] = Rotation.from_matrix(Tt[:3, :3] @ Ta[:3, :3].T).as_rotvec()
    return e


@dataclass(frozen=True)
class IKSettings:
    """Settings of :func:`inverse_kinematics`.

    Parameters
    ----------
    tol_mm : float
        Position tolerance of a solution, mm.
    tol_rad : float
        Rotation tolerance of a solution, rad.
    max_iterations : int
        Iterations per start.
    restarts : int
        Random starts (uniform within the joint limits) after the given start fails.
    length_mm : float
        Length that weighs rotation errors against position errors (1 rad counts as this many
        mm).
    damping : float
        The constant part ``w_n`` of the LM damping, in the weighted error's units (mm^2).
    """

    tol_mm: float = 1e-3
    tol_rad: float = 1e-6
    max_iterations: int = 200
    restarts: int = 30
    length_mm: float = 300.0
    damping: float = 1e-2

    def __post_init__(self) -> None:
        if self.tol_mm <= 0 or self.tol_rad <= 0:
            raise ValueError("tol_mm, tol_rad: expected positive tolerances")
        if self.max_iterations < 1 or self.restarts < 0:
            raise ValueError("max_iterations >= 1 and restarts >= 0 expected")


@dataclass(frozen=True)
class IKResult:
    """Outcome of :func:`inverse_kinematics`.

    Parameters
    ----------
    q : ndarray (n,)
        Best joint angles found, radians, always within the joint limits.
    success : bool
        Whether ``q`` meets both tolerances.
    position_error_mm, rotation_error_rad : float
        Residual of ``q``.
    iterations : int
        Iterations over all starts.
    starts : int
        Starts tried (1 = the given start sufficed).
    reason : str
        ``"converged"`` or why it failed.
    """

    q: NDArray[np.float64]
    success: bool
    position_error_mm: float
    rotation_error_rad: float
    iterations: int
    starts: int
    reason: str


def _rotvec(R: NDArray[np.float64]) -> NDArray[np.float64]:
    """Rotation vector (3,) of a rotation matrix (3, 3); closed form away from 180 deg."""
    cos = 0.5 * (R[0, 0] + R[1, 1] + R[2, 2] - 1.0)
    v = 0.5 * np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
    if cos < -0.99:
        return np.asarray(Rotation.from_matrix(R).as_rotvec())
    sin = float(np.linalg.norm(v))
    angle = float(np.arctan2(sin, cos))
    return v * (angle / sin) if sin > 1e-12 else v


def _frames_single(arm: ArmModel, q: NDArray[np.float64]) -> NDArray[np.float64]:
    links = _link_transforms(arm, q)
    out = np.empty((arm.n_joints + 1, 4, 4))
    out[0] = np.eye(4)
    for i in range(arm.n_joints):
        out[i + 1] = out[i] @ links[i]
    return out


def _error_and_jacobian(arm: ArmModel, T_target: NDArray[np.float64], q: NDArray[np.float64],
                        with_jacobian: bool) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    frames = _frames_single(arm, q)
    T = frames[-1]
    e = np.empty(6)
    e[:3] = T_target[:3, 3] - T[:3, 3]
    e[3:] = _rotvec(T_target[:3, :3] @ T[:3, :3].T)
    if not with_jacobian:
        return e, np.empty((6, 0))
    z = frames[:-1, :3, 2]
    J = np.empty((6, arm.n_joints))
    J[:3] = np.cross(z, T[:3, 3] - frames[:-1, :3, 3]).T
    J[3:] = z.T
    return e, J


def _solve_from(arm: ArmModel, T_target: NDArray[np.float64], q0: NDArray[np.float64],
                settings: IKSettings) -> tuple[NDArray[np.float64], float, float, int]:
    w = np.array([1.0, 1.0, 1.0] + [settings.length_mm] * 3) ** 2  # weights of e (mm^2)
    eye = np.eye(arm.n_joints)
    q = np.clip(q0, arm.q_min_rad, arm.q_max_rad)
    e, J = _error_and_jacobian(arm, T_target, q, True)
    E = 0.5 * float(e @ (w * e))
    E_window = E
    boost = 1.0  # grows while steps are refused: a refused step is not tried again unchanged
    for it in range(1, settings.max_iterations + 1):
        JtW = J.T * w
        step = np.linalg.solve(JtW @ J + boost * (E + settings.damping) * eye, JtW @ e)
        q_new = np.clip(q + step, arm.q_min_rad, arm.q_max_rad)
        e_new, _ = _error_and_jacobian(arm, T_target, q_new, False)
        E_new = 0.5 * float(e_new @ (w * e_new))
        if E_new < E:
            q, E = q_new, E_new
            e, J = _error_and_jacobian(arm, T_target, q, True)
            boost = max(1.0, 0.25 * boost)
        else:
            boost *= 4.0
        pos, rot = float(np.linalg.norm(e[:3])), float(np.linalg.norm(e[3:]))
        if pos < settings.tol_mm and rot < settings.tol_rad:
            return q, pos, rot, it
        if it % 25 == 0:  # stalled (a joint limit or a local minimum): let the caller restart
            if E > 0.9 * E_window:
                return q, pos, rot, it
            E_window = E
    return q, float(np.linalg.norm(e[:3])), float(np.linalg.norm(e[3:])), settings.max_iterations


def inverse_kinematics(
    arm: ArmModel,
    T_base_hand: ArrayLike,
    q0: ArrayLike | None = None,
    settings: IKSettings | None = None,
    rng: int | np.random.Generator | None = 0,
) -> IKResult:
    """Joint angles that put the hand at ``T_base_hand``, within the joint limits.

    Parameters
    ----------
    arm : ArmModel
    T_base_hand : ndarray (4, 4)
        Wanted pose of the hand (tool flange) in the base frame, mm.
    q0 : ndarray (n,), optional
        Start (radians); the solution reached from it is preferred (redundancy resolution by
        continuity). Default: the middle of the joint ranges.
    settings : IKSettings, optional
    rng : int, Generator or None
        Seed of the random restarts.

    Returns
    -------
    IKResult
        ``success`` False when no start reached the tolerances (the pose is out of reach or
        only reachable outside the joint limits); ``q`` is then the best attempt.
    """
    cfg = settings or IKSettings()
    T = np.asarray(T_base_hand, dtype=np.float64)
    if T.shape != (4, 4):
        raise ValueError(f"T_base_hand: expected shape (4, 4), got {T.shape}")
    start = (0.5 * (arm.q_min_rad + arm.q_max_rad) if q0 is None
             else _check_q(arm, q0).reshape(arm.n_joints))
    shoulder = np.array([0.0, 0.0, arm.d_mm[0]])
    distance = float(np.linalg.norm(T[:3, 3] - shoulder))
    if distance > arm.reach_mm + cfg.tol_mm:
        return IKResult(start, False, distance - arm.reach_mm, float("nan"), 0, 0,
                        f"the hand would be {distance:.0f} mm from the shoulder, beyond the "
                        f"arm's reach of {arm.reach_mm:.0f} mm")
    gen = np.random.default_rng(rng)
    best: tuple[NDArray[np.float64], float, float] | None = None
    total = 0
    for k in range(cfg.restarts + 1):
        q, pos, rot, its = _solve_from(arm, T, start, cfg)
        total += its
        if best is None or pos + cfg.length_mm * rot < best[1] + cfg.length_mm * best[2]:
            best = (q, pos, rot)
        if pos < cfg.tol_mm and rot < cfg.tol_rad:
            return IKResult(q, True, pos, rot, total, k + 1, "converged")
        start = gen.uniform(arm.q_min_rad, arm.q_max_rad)
    assert best is not None
    return IKResult(best[0], False, best[1], best[2], total, cfg.restarts + 1,
                    f"no solution within the joint limits after {cfg.restarts + 1} starts "
                    f"(best residual {best[1]:.1f} mm, {np.degrees(best[2]):.2f} deg)")
