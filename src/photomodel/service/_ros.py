"""A pose as ROS 2's ``geometry_msgs/PoseStamped`` spells it (metres, an ``xyzw`` quaternion)."""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from photomodel.geometry import quat_wxyz_from_matrix

__all__ = ["pose_stamped"]


def pose_stamped(T_cam1_model: NDArray[np.float64] | None, stamp_s: float,
                 frame_id: str = "cam1") -> dict[str, Any] | None:
    """``{"header": {"frame_id", "stamp"}, "pose": {"position": {x, y, z}, "orientation":
    {x, y, z, w}}}`` of a pose ``T_cam1_model`` (4 x 4, mm); positions in metres, ``stamp``
    in unix seconds; None for no pose."""
    if T_cam1_model is None:
        return None
    T = np.asarray(T_cam1_model, dtype=np.float64)
    w, x, y, z = quat_wxyz_from_matrix(T[:3, :3])
    px, py, pz = (T[:3, 3] / 1000.0).tolist()
    return {"header": {"frame_id": frame_id, "stamp": float(stamp_s)},
            "pose": {"position": {"x": px, "y": py, "z": pz},
                     "orientation": {"x": float(x), "y": float(y), "z": float(z),
                                     "w": float(w)}}}
