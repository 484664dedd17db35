"""Camera models and calibration files: pinhole with OpenCV distortion, the stereo rig."""

import lazy_loader

__getattr__, __dir__, _ = lazy_loader.attach(
    __name__,
    submod_attrs={
        "_io": ["load_camera", "load_distance_mm", "load_matrix", "load_stereo", "save_camera",
                "save_stereo"],
        "_pinhole": ["PinholeCamera"],
        "_stereo": ["StereoRig"],
    },
)

__all__ = [
    "PinholeCamera",
    "StereoRig",
    "load_camera",
    "load_distance_mm",
    "load_matrix",
    "load_stereo",
    "save_camera",
    "save_stereo",
]
