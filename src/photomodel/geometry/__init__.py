"""Rigid transforms and pose parametrisations (``T_a_b`` maps frame b to frame a)."""

import lazy_loader

__getattr__, __dir__, _ = lazy_loader.attach(
    __name__,
    submod_attrs={
        "_pose": [
            "eps_from_rotation",
            "facing_kernel",
            "facing_pose_vectors",
            "flat_pose_vectors",
            "in_plane_angle_rad",
            "plane_quat_wxyz",
            "pose_maps_kernel",
            "pose_vectors_to_matrices",
            "quat_wxyz_from_matrix",
            "rotation_from_eps",
            "strained_matrices",
        ],
        "_transforms": ["invert_transform", "make_transform", "rotation_angle_deg",
                        "transform_points"],
    },
)

__all__ = [
    "eps_from_rotation",
    "facing_kernel",
    "facing_pose_vectors",
    "flat_pose_vectors",
    "in_plane_angle_rad",
    "invert_transform",
    "make_transform",
    "plane_quat_wxyz",
    "pose_maps_kernel",
    "pose_vectors_to_matrices",
    "quat_wxyz_from_matrix",
    "rotation_angle_deg",
    "rotation_from_eps",
    "strained_matrices",
    "transform_points",
]
