"""Robot side of the cell: the PA10-7C's kinematics, hand-eye, pick-and-place plans, animation.

Imports neither ``photomodel.sim`` nor ``photomodel.locate``: the simulated cell and ``pick``
(locate, then plan) live in :mod:`photomodel.cell`, above both.

Frames (docs/contracts.md): ``base`` (the arm's, z up), ``hand`` (tool flange), ``tcp`` (gripper),
``cam1``, ``model``; ``T_a_b`` maps b to a; mm and radians inside, ``_deg`` at the edge.
``T_base_model = T_base_hand(q) @ T_hand_cam1 @ T_cam1_model``.
"""

import lazy_loader

__getattr__, __dir__, _ = lazy_loader.attach(
    __name__,
    submod_attrs={
        "_animate": [
            "ANIMATION_SUFFIXES",
            "animate_plan",
            "check_animation_path",
            "draw_workspace",
            "save_animation",
        ],
        "_arm": ["ArmModel", "load_arm"],
        "_arm_data": ["ARM_FILES", "available_link_sets"],
        "_handeye": [
            "HAND_EYE_METHODS",
            "Chessboard",
            "HandEyePairs",
            "HandEyeResult",
            "base_from_camera",
            "calibrate_hand_eye",
            "chessboard_pose",
            "hand_eye_error",
            "load_hand_eye",
            "load_hand_eye_pairs",
            "save_hand_eye",
        ],
        "_kinematics": [
            "IKResult",
            "IKSettings",
            "forward_kinematics",
            "inverse_kinematics",
            "jacobian",
            "joint_frames",
            "pose_error",
        ],
        "_plan": [
            "CellLayout",
            "Gripper",
            "PickPlan",
            "PickSettings",
            "UnreachableError",
            "Waypoint",
            "grasp_pose",
            "plan_pick",
        ],
        "_poses": ["PHOTO_SEED_DEG", "hand_pose_from_xyz_rpy", "joints_for_hand_pose"],
    },
)

__all__ = [
    "ANIMATION_SUFFIXES",
    "ARM_FILES",
    "HAND_EYE_METHODS",
    "PHOTO_SEED_DEG",
    "ArmModel",
    "CellLayout",
    "Chessboard",
    "Gripper",
    "HandEyePairs",
    "HandEyeResult",
    "IKResult",
    "IKSettings",
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
    "pose_error",
    "save_animation",
    "save_hand_eye",
]
