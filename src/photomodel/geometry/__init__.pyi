# The subpackage's public names (lazy_loader.attach_stub reads this file; type
# checkers read it as the package's stub). One list: add a name here only.

from ._pose import (
    eps_from_rotation,
    facing_kernel,
    facing_pose_vectors,
    flat_pose_vectors,
    in_plane_angle_rad,
    plane_quat_wxyz,
    pose_maps_kernel,
    pose_vectors_to_matrices,
    quat_wxyz_from_matrix,
    rotation_from_eps,
    strained_matrices,
)
from ._transforms import (
    invert_transform,
    make_transform,
    rotation_angle_deg,
    transform_points,
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
