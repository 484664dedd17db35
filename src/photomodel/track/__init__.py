"""Tracking a garment's pose through a stereo sequence: the motion model, the windows, the
tracker."""

import lazy_loader

__getattr__, __dir__, _ = lazy_loader.attach(
    __name__,
    submod_attrs={
        "_motion": ["ConstantVelocity", "se3_exp", "se3_log"],
        "_result": ["Mode", "TrackResult"],
        "_roi": ["Window", "WindowFeatures", "window_of_points"],
        "_tracker": ["Tracker", "TrackerConfig"],
    },
)

__all__ = [
    "ConstantVelocity",
    "Mode",
    "TrackResult",
    "Tracker",
    "TrackerConfig",
    "Window",
    "WindowFeatures",
    "se3_exp",
    "se3_log",
    "window_of_points",
]
