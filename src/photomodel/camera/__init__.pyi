# The subpackage's public names (lazy_loader.attach_stub reads this file; type
# checkers read it as the package's stub). One list: add a name here only.

from ._io import (
    load_camera,
    load_distance_mm,
    load_matrix,
    load_stereo,
    save_camera,
    save_stereo,
)
from ._pinhole import (
    PinholeCamera,
)
from ._stereo import (
    StereoRig,
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
