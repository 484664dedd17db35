"""Default cameras of the simulated cell, with realistic intrinsics and geometry (the paper's).

The hand rig: camera 1 (reference, the paper's right camera) and camera 2 (left) 120 mm apart,
both toed in so that their optical axes cross 685 mm in front of the middle of the baseline.
A *rig frame* is used to build it: origin at the baseline's midpoint, x from camera 2 to
camera 1, z along the bisector of the optical axes (towards the table), y = z x x. Each camera is
rotated about the rig's y axis by half the vergence angle, towards the other camera.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from photomodel.camera import PinholeCamera, StereoRig
from photomodel.geometry import invert_transform, make_transform
from photomodel.model import DEFAULT_STATION_DISTANCE_MM

__all__ = [
    "BASELINE_MM",
    "MODEL_DISTANCE_MM",
    "WORK_DISTANCE_MM",
    "hand_stereo_rig",
    "hand_table_pose",
    "model_station_camera",
]

MODEL_DISTANCE_MM = DEFAULT_STATION_DISTANCE_MM
"""Distance from the model-station camera to the green plane, mm (the default station's)."""

WORK_DISTANCE_MM = 685.0
"""Distance from the hand rig (middle of its baseline) to the table, along the bisector, mm."""

BASELINE_MM = 120.0
"""Distance between the two hand cameras' centres, mm."""


def _intrinsics(fx: float, fy: float, cx: float, cy: float) -> NDArray[np.float64]:
    return np.array([[fx, 0.0, cx], [0.0, fy, cy], [0.0, 0.0, 1.0]])


def _rot_y(angle_rad: float) -> NDArray[np.float64]:
    c, s = np.cos(angle_rad), np.sin(angle_rad)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def model_station_camera() -> PinholeCamera:
    """The fixed camera of the model station (640 x 480, f = 760 px, mild barrel distortion).

    It looks squarely at the green plane from :data:`MODEL_DISTANCE_MM`.
    """
    K = _intrinsics(760.0, 760.0, 319.5 + 2.3, 239.5 - 1.7)
    return PinholeCamera(K, np.array([-0.12, 0.08, 0.0005, -0.0004, 0.0]), 640, 480)


def hand_stereo_rig(distortion: bool = True, lens: str = "standard") -> StereoRig:
    """The stereo pair on the robot's hand (640 x 480 each, f about 800 px, 120 mm baseline).

    Parameters
    ----------
    distortion : bool
        Lens distortion when True, none when False (the same as ``lens="none"``); everything
        else is identical.
    lens : str
        ``"standard"`` (k1 about -0.15), ``"wide"`` (strong barrel distortion, k1 about -0.32,
        as of a wide-angle lens) or ``"none"``.

    Returns
    -------
    StereoRig
        Camera 1 = the right camera (reference), camera 2 = the left camera, whose centre lies
        120 mm along camera 1's -x (rotated by the vergence angle); optical axes crossing at
        :data:`WORK_DISTANCE_MM` from the baseline's midpoint.
    """
    d1 = np.array([-0.15, 0.06, 0.0011, -0.0008, 0.0])
    d2 = np.array([-0.145, 0.058, -0.0009, 0.0012, 0.0])
    if lens == "wide":
        d1 = np.array([-0.32, 0.14, 0.0011, -0.0008, -0.02])
        d2 = np.array([-0.315, 0.135, -0.0009, 0.0012, -0.02])
    elif lens not in ("standard", "none"):
        raise ValueError(f"lens: expected 'standard', 'wide' or 'none', got {lens!r}")
    if not distortion or lens == "none":
        d1, d2 = np.zeros(5), np.zeros(5)
    cam1 = PinholeCamera(_intrinsics(801.2, 800.6, 322.1, 238.4), d1, 640, 480)
    cam2 = PinholeCamera(_intrinsics(798.4, 798.9, 317.6, 241.3), d2, 640, 480)
    half_vergence = np.arctan2(BASELINE_MM / 2, WORK_DISTANCE_MM)
    # Camera 1 sits at rig +x and turns its axis towards -x: a rotation of -half about rig y.
    T_rig_cam1 = make_transform(_rot_y(-half_vergence), [BASELINE_MM / 2, 0.0, 0.0])
    T_rig_cam2 = make_transform(_rot_y(half_vergence), [-BASELINE_MM / 2, 0.0, 0.0])
    T_cam2_cam1 = invert_transform(T_rig_cam2) @ T_rig_cam1
    return StereoRig(cam1, cam2, T_cam2_cam1[:3, :3], T_cam2_cam1[:3, 3])


def hand_table_pose(rig: StereoRig, distance_mm: float = WORK_DISTANCE_MM) -> NDArray[np.float64]:
    """Pose ``T_cam1_table`` (4, 4) of a table facing the rig.

    The table plane is perpendicular to the bisector of the two optical axes, ``distance_mm``
    from the middle of the baseline along it (where the axes cross for the default rig).
    Table frame: origin on the bisector, z along the bisector away from the cameras, x along
    camera 1's x projected onto the table, y = z x x (so roughly camera 1's y). Camera 1 sees
    the table tilted by half the vergence angle about its y axis.
    """
    R_cam1_table = rig.R_cam1_facing
    centre2 = -rig.R.T @ rig.T  # camera 2's centre in camera 1's frame
    return make_transform(R_cam1_table, centre2 / 2 + distance_mm * R_cam1_table[:, 2])
