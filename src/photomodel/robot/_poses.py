"""Hand poses given by hand: a pose from position and roll-pitch-yaw, the joints that reach it."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial.transform import Rotation

from photomodel.geometry import make_transform
from photomodel.robot._arm import ArmModel
from photomodel.robot._kinematics import inverse_kinematics
from photomodel.robot._plan import UnreachableError

__all__ = ["PHOTO_SEED_DEG", "hand_pose_from_xyz_rpy", "joints_for_hand_pose"]

PHOTO_SEED_DEG = (0.0, 25.0, 0.0, 100.0, 0.0, 55.0, 0.0)
"""Start of the IK for a photographing pose: elbow up, hand pointing down."""


def hand_pose_from_xyz_rpy(xyz_mm: ArrayLike, rpy_deg: ArrayLike) -> NDArray[np.float64]:
    """``T_base_hand`` (4, 4) from a position (mm) and roll, pitch, yaw (deg, extrinsic x-y-z)."""
    R = Rotation.from_euler("xyz", np.asarray(rpy_deg, dtype=np.float64), degrees=True)
    return make_transform(R.as_matrix(), np.asarray(xyz_mm, dtype=np.float64))


def joints_for_hand_pose(arm: ArmModel, T_base_hand: ArrayLike,
                         source: str = "--hand-pose-mm") -> NDArray[np.float64]:
    """Joints (n,) rad that reach ``T_base_hand`` (4, 4); :class:`UnreachableError` if none."""
    result = inverse_kinematics(arm, T_base_hand, np.radians(PHOTO_SEED_DEG), rng=0)
    if not result.success:
        raise UnreachableError(f"{source}: the hand pose is out of reach of the {arm.name}: "
                               f"{result.reason}")
    return result.q
