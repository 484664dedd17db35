"""Photo-models: generation from a photo (paper sec. 2.2), the model file, the preview."""

import lazy_loader

__getattr__, __dir__, _ = lazy_loader.attach(
    __name__,
    submod_attrs={
        "_build": ["BuildQuality", "BuildResult", "build_model", "build_photo_model"],
        "_config": ["BUILD_RANGES", "DEFAULT_STATION_DISTANCE_MM", "BuildConfig"],
        "_descriptor": ["COLOUR_BIN", "COLOUR_GRID_LOW", "COLOUR_GRID_SHAPE", "DESCRIPTOR_VERSION",
                        "HAND_MM_PER_PX", "ModelDescriptor", "describe_model",
                        "soft_colour_histogram"],
        "_in_place": ["InPlaceBuild", "TablePlane", "build_in_place", "measure_plane"],
        "_photomodel": ["FORMAT_VERSION", "PhotoModel", "load_model", "save_model"],
        "_preview": ["render_preview"],
        "_scale": ["MAX_SCALE", "at_scale", "build_unknown_scale", "confirmed_scale",
                   "resampled_model", "scale_known", "scaled_model"],
    },
)

__all__ = [
    "BUILD_RANGES",
    "COLOUR_BIN",
    "COLOUR_GRID_LOW",
    "COLOUR_GRID_SHAPE",
    "DEFAULT_STATION_DISTANCE_MM",
    "DESCRIPTOR_VERSION",
    "FORMAT_VERSION",
    "HAND_MM_PER_PX",
    "MAX_SCALE",
    "BuildConfig",
    "BuildQuality",
    "BuildResult",
    "InPlaceBuild",
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
