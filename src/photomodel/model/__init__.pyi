# The subpackage's public names (lazy_loader.attach_stub reads this file; type
# checkers read it as the package's stub). One list: add a name here only.

from ._build import (
    BuildQuality,
    BuildResult,
    build_model,
    build_photo_model,
)
from ._config import (
    BUILD_RANGES,
    DEFAULT_STATION_DISTANCE_MM,
    BuildConfig,
)
from ._descriptor import (
    COLOUR_BIN,
    COLOUR_GRID_LOW,
    COLOUR_GRID_SHAPE,
    DESCRIPTOR_VERSION,
    HAND_MM_PER_PX,
    ModelDescriptor,
    describe_model,
    soft_colour_histogram,
)
from ._in_place import (
    InPlaceBuild,
    TablePlane,
    build_in_place,
    measure_plane,
)
from ._photomodel import (
    FORMAT_VERSION,
    PhotoModel,
    load_model,
    save_model,
)
from ._preview import (
    render_preview,
)
from ._scale import (
    MAX_SCALE,
    at_scale,
    build_unknown_scale,
    confirmed_scale,
    resampled_model,
    scale_known,
    scaled_model,
)

__all__ = [
    "BUILD_RANGES",
    "BuildConfig",
    "BuildQuality",
    "BuildResult",
    "COLOUR_BIN",
    "COLOUR_GRID_LOW",
    "COLOUR_GRID_SHAPE",
    "DEFAULT_STATION_DISTANCE_MM",
    "DESCRIPTOR_VERSION",
    "FORMAT_VERSION",
    "HAND_MM_PER_PX",
    "InPlaceBuild",
    "MAX_SCALE",
    "ModelDescriptor",
    "PhotoModel",
    "TablePlane",
    "at_scale",
    "build_in_place",
    "build_model",
    "build_photo_model",
    "build_unknown_scale",
    "confirmed_scale",
    "describe_model",
    "load_model",
    "measure_plane",
    "render_preview",
    "resampled_model",
    "save_model",
    "scale_known",
    "scaled_model",
    "soft_colour_histogram",
]
