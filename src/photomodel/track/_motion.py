"""A constant-velocity motion model of a pose in SE(3), from timestamped measurements.

The velocity is the twist ``xi = log(T_k T_{k-1}^-1) / dt`` (camera 1's frame: a rotation
about camera 1's axes and a translation in mm), smoothed over frames
(:attr:`ConstantVelocity.smoothing`); the prediction at time ``t`` is ``exp(xi (t - t_k))
T_k``. A hand that moves steadily, or a garment carried on a conveyor, moves its pose in
camera 1 this way between two frames.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray
from scipy.spatial.transform import Rotation

__all__ = ["ConstantVelocity", "se3_exp", "se3_log"]


def _hat(w: NDArray[np.float64]) -> NDArray[np.float64]:
    return np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])


def _left_jacobian(w: NDArray[np.float64]) -> NDArray[np.float64]:
    """SO(3)'s left Jacobian ``V`` (3, 3) of rotation vector ``w``: ``t = V v``."""
    theta = float(np.linalg.norm(w))
    W = _hat(w)
    if theta < 1e-8:
        return np.eye(3) + 0.5 * W
    return (np.eye(3) + (1.0 - np.cos(theta)) / theta**2 * W
            + (theta - np.sin(theta)) / theta**3 * (W @ W))


def se3_exp(xi: NDArray[np.float64]) -> NDArray[np.float64]:
    """The transform (4, 4) of twist ``xi`` (6,) = (rotation vector rad, translation mm)."""
    xi = np.asarray(xi, dtype=np.float64)
    T = np.eye(4)
    T[:3, :3] = Rotation.from_rotvec(xi[:3]).as_matrix()
    T[:3, 3] = _left_jacobian(xi[:3]) @ xi[3:]
    return T


def se3_log(T: NDArray[np.float64]) -> NDArray[np.float64]:
    """The twist (6,) = (rotation vector rad, translation mm) of transform ``T`` (4, 4)."""
    T = np.asarray(T, dtype=np.float64)
    w = Rotation.from_matrix(T[:3, :3]).as_rotvec()
    return np.concatenate([w, np.linalg.solve(_left_jacobian(w), T[:3, 3])])


@dataclass
class ConstantVelocity:
    """Constant-velocity prediction of ``T_cam1_model`` (mm) from timestamped poses.

    Attributes
    ----------
    smoothing : float
        Weight of the newest velocity estimate (1: the last two poses only); lower values
        average the measurement noise of successive poses out of the velocity.
    max_gap_s : float
        A gap between two measurements longer than this restarts the velocity at zero.
    """

    smoothing: float = 0.6
    max_gap_s: float = 0.5
    T_last: NDArray[np.float64] | None = field(default=None, repr=False)
    t_last: float | None = None
    velocity: NDArray[np.float64] = field(default_factory=lambda: np.zeros(6), repr=False)

    def reset(self) -> None:
        """Forget every measurement."""
        self.T_last, self.t_last, self.velocity = None, None, np.zeros(6)

    def predict(self, t_s: float) -> NDArray[np.float64] | None:
        """The predicted pose (4, 4) at ``t_s``, None before the first measurement."""
        if self.T_last is None or self.t_last is None:
            return None
        dt = float(t_s) - self.t_last
        if not 0.0 <= dt <= self.max_gap_s:
            return self.T_last.copy()
        return se3_exp(self.velocity * dt) @ self.T_last

    def speed(self) -> tuple[float, float]:
        """The current speeds: translation mm/s and rotation rad/s (of the twist)."""
        return float(np.linalg.norm(self.velocity[3:])), float(np.linalg.norm(self.velocity[:3]))

    def update(self, T_cam1_model: NDArray[np.float64], t_s: float) -> None:
        """Take a measured pose (4, 4) at ``t_s`` (after the last one)."""
        T = np.asarray(T_cam1_model, dtype=np.float64).copy()
        if self.T_last is not None and self.t_last is not None:
            dt = float(t_s) - self.t_last
            if 0.0 < dt <= self.max_gap_s:
                xi = se3_log(T @ np.linalg.inv(self.T_last)) / dt
                self.velocity = self.smoothing * xi + (1.0 - self.smoothing) * self.velocity
            else:
                self.velocity = np.zeros(6)
        self.T_last, self.t_last = T, float(t_s)
