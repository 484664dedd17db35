"""Calibration from views of a printed chessboard (or ChArUco board), through OpenCV: one
camera's intrinsics (and the model station's plane distance), a stereo rig's, the corner
detector, the target.

What ``photomodel calibrate`` runs (docs/contracts.md, "Calibration").
"""

import lazy_loader

__getattr__, __dir__, _ = lazy_loader.attach(
    __name__,
    submod_attrs={
        "_calibrate": [
            "DEFAULT_DISTORTION",
            "DISTORTION_MODELS",
            "MIN_VIEWS",
            "CameraCalibration",
            "PlaneDistance",
            "SkippedView",
            "StereoCalibration",
            "calibrate_camera",
            "calibrate_camera_folder",
            "calibrate_station_folder",
            "calibrate_stereo",
            "calibrate_stereo_folder",
            "plane_distance",
            "plane_distance_from_image",
        ],
        "_compare": [
            "camera_difference",
            "distortion_difference_px",
            "stereo_difference",
            "transform_difference",
        ],
        "_detect": [
            "MIN_CHARUCO_CORNERS",
            "Detection",
            "chessboard_pose",
            "find_corners",
            "pose_from_corners",
        ],
        "_pattern": ["CharucoBoard", "Chessboard", "Target", "charuco_available", "parse_pattern"],
        "_plots": ["coverage_png", "errors_png", "plot_paths", "write_plots"],
        "_views": ["IMAGE_SUFFIXES", "ViewCorners", "detect_views", "list_images", "list_pairs"],
    },
)

__all__ = [
    "DEFAULT_DISTORTION",
    "DISTORTION_MODELS",
    "IMAGE_SUFFIXES",
    "MIN_CHARUCO_CORNERS",
    "MIN_VIEWS",
    "CameraCalibration",
    "CharucoBoard",
    "Chessboard",
    "Detection",
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
