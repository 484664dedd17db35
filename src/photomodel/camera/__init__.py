"""Camera models and calibration files: pinhole with OpenCV distortion, the stereo rig."""

from photomodel.camera._io import (
    load_camera,
    load_distance_mm,
    load_stereo,
    save_camera,
    save_stereo,
)
from photomodel.camera._pinhole import PinholeCamera
from photomodel.camera._stereo import StereoRig

__all__ = [
    "PinholeCamera",
    "StereoRig",
    "load_camera",
    "load_distance_mm",
    "load_stereo",
    "save_camera",
    "save_stereo",
]
