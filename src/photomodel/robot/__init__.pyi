# The subpackage's public names (lazy_loader.attach_stub reads this file; type
# checkers read it as the package's stub). One list: add a name here only.

from ._animate import (
    animate_plan,
    check_animation_path,
    draw_workspace,
    save_animation,
)
from ._arm import (
    ArmModel,
    load_arm,
)
from ._arm_data import (
    available_link_sets,
)
from ._handeye import (
    HAND_EYE_METHODS,
    Chessboard,
    HandEyePairs,
    HandEyeResult,
    base_from_camera,
    calibrate_hand_eye,
    chessboard_pose,
    hand_eye_error,
    load_hand_eye,
    load_hand_eye_pairs,
    save_hand_eye,
)
from ._kinematics import (
    IKResult,
    IKSettings,
    forward_kinematics,
    inverse_kinematics,
    jacobian,
    joint_frames,
)
from ._plan import (
    CellLayout,
    Gripper,
    PickPlan,
    PickSettings,
    UnreachableError,
    Waypoint,
    grasp_pose,
    plan_pick,
)
from ._poses import (
    PHOTO_SEED_DEG,
    hand_pose_from_xyz_rpy,
    joints_for_hand_pose,
)

__all__ = [
    "ArmModel",
    "CellLayout",
    "Chessboard",
    "Gripper",
    "HAND_EYE_METHODS",
    "HandEyePairs",
    "HandEyeResult",
    "IKResult",
    "IKSettings",
    "PHOTO_SEED_DEG",
    "PickPlan",
    "PickSettings",
    "UnreachableError",
    "Waypoint",
    "animate_plan",
    "available_link_sets",
    "base_from_camera",
    "calibrate_hand_eye",
    "check_animation_path",
    "chessboard_pose",
    "draw_workspace",
    "forward_kinematics",
    "grasp_pose",
    "hand_eye_error",
    "hand_pose_from_xyz_rpy",
    "inverse_kinematics",
    "jacobian",
    "joint_frames",
    "joints_for_hand_pose",
    "load_arm",
    "load_hand_eye",
    "load_hand_eye_pairs",
    "plan_pick",
    "save_animation",
    "save_hand_eye",
]
