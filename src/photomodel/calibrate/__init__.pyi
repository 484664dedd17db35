# The subpackage's public names (lazy_loader.attach_stub reads this file; type
# checkers read it as the package's stub). One list: add a name here only.

from ._calibrate import (
    DEFAULT_DISTORTION,
    DISTORTION_MODELS,
    MIN_VIEWS,
    CameraCalibration,
    PlaneDistance,
    SkippedView,
    StereoCalibration,
    calibrate_camera,
    calibrate_camera_folder,
    calibrate_station_folder,
    calibrate_stereo,
    calibrate_stereo_folder,
    plane_distance,
    plane_distance_from_image,
)
from ._compare import (
    camera_difference,
    distortion_difference_px,
    stereo_difference,
    transform_difference,
)
from ._detect import (
    MIN_CHARUCO_CORNERS,
    Detection,
    chessboard_pose,
    find_corners,
    pose_from_corners,
)
from ._pattern import (
    CharucoBoard,
    Chessboard,
    Target,
    charuco_available,
    parse_pattern,
)
from ._plots import (
    coverage_png,
    errors_png,
    plot_paths,
    write_plots,
)
from ._views import (
    IMAGE_SUFFIXES,
    ViewCorners,
    detect_views,
    list_images,
    list_pairs,
)

__all__ = [
    "CameraCalibration",
    "CharucoBoard",
    "Chessboard",
    "DEFAULT_DISTORTION",
    "DISTORTION_MODELS",
    "Detection",
    "IMAGE_SUFFIXES",
    "MIN_CHARUCO_CORNERS",
    "MIN_VIEWS",
    "PlaneDistance",
    "SkippedView",
    "StereoCalibration",
    "Target",
    "ViewCorners",
    "calibrate_camera",
    "calibrate_camera_folder",
    "calibrate_station_folder",
    "calibrate_stereo",
    "calibrate_stereo_folder",
    "camera_difference",
    "charuco_available",
    "chessboard_pose",
    "coverage_png",
    "detect_views",
    "distortion_difference_px",
    "errors_png",
    "find_corners",
    "list_images",
    "list_pairs",
    "parse_pattern",
    "plane_distance",
    "plane_distance_from_image",
    "plot_paths",
    "pose_from_corners",
    "stereo_difference",
    "transform_difference",
    "write_plots",
]
