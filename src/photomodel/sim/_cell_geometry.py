"""The simulated cell's fixed geometry: the hand rig's mount, the table and the photographing pose.

Frames as docs/contracts.md; lengths in mm. The arm's base stands on the floor of the cell; the
work table's top (``table``) lies at :attr:`~photomodel.robot.CellLayout.table_centre_mm`.

- The hand rig (:func:`hand_stereo_rig`) is mounted on the hand by :func:`default_hand_eye`: the
  middle of its baseline 110 mm off the flange axis along the hand's -y and 40 mm along its z,
  the rig's bisector along the hand's z.
- The photographing configuration ``q_photo`` (:func:`photo_configuration`) puts the rig's
  bisector perpendicular to the table, 685 mm above its centre, so the cameras see the table as
  :func:`hand_table_pose` renders it.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from photomodel.camera import StereoRig
from photomodel.geometry import invert_transform, make_transform
from photomodel.robot import (
    PHOTO_SEED_DEG,
    ArmModel,
    CellLayout,
    UnreachableError,
    inverse_kinematics,
)
from photomodel.sim._rigs import WORK_DISTANCE_MM, hand_table_pose

__all__ = ["default_hand_eye", "photo_configuration", "table_in_base"]


def default_hand_eye(rig: StereoRig) -> NDArray[np.float64]:
    """The simulated mount ``T_hand_cam1`` (4, 4), mm, of the hand rig (module docstring)."""
    T_cam1_rig = hand_table_pose(rig) @ make_transform(np.eye(3), [0, 0, -WORK_DISTANCE_MM])
    T_hand_rig = make_transform(np.eye(3), [0.0, -110.0, 40.0])
    return T_hand_rig @ invert_transform(T_cam1_rig)


def table_in_base(layout: CellLayout) -> NDArray[np.float64]:
    """``T_base_table`` (4, 4), mm: the simulator's table frame in the base frame.

    Origin at the table's centre (``layout.table_centre_mm``), z down into the table, x along
    the base's x.
    """
    return make_transform(np.diag([1.0, -1.0, -1.0]), layout.table_centre_mm)


def photo_configuration(arm: ArmModel, layout: CellLayout, rig: StereoRig,
                        T_hand_cam1: NDArray[np.float64]) -> NDArray[np.float64]:
    """Joints ``q_photo`` (n,), radians, at which the rig sees the table as the simulator does.

    Raises :class:`~photomodel.robot.UnreachableError` when the arm cannot reach that view.
    """
    T_base_cam1 = table_in_base(layout) @ invert_transform(hand_table_pose(rig))
    T_base_hand = T_base_cam1 @ invert_transform(T_hand_cam1)
    result = inverse_kinematics(arm, T_base_hand, np.radians(PHOTO_SEED_DEG), rng=0)
    if not result.success:
        raise UnreachableError(f"cell: the photographing pose above the table is out of reach: "
                               f"{result.reason}")
    return result.q
