# The subpackage's public names (lazy_loader.attach_stub reads this file; type
# checkers read it as the package's stub). One list: add a name here only.

from ._motion import (
    ConstantVelocity,
    se3_exp,
    se3_log,
)
from ._result import (
    Mode,
    TrackResult,
)
from ._roi import (
    Window,
    WindowFeatures,
    window_of_points,
)
from ._tracker import (
    Tracker,
    TrackerConfig,
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
