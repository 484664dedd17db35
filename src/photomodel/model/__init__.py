"""Photo-models: generation from a photo (paper sec. 2.2), the model file, the preview."""

from photomodel.model._build import BuildConfig, BuildResult, build_photo_model
from photomodel.model._photomodel import FORMAT_VERSION, PhotoModel, load_model, save_model
from photomodel.model._preview import render_preview

__all__ = [
    "FORMAT_VERSION",
    "BuildConfig",
    "BuildResult",
    "PhotoModel",
    "build_photo_model",
    "load_model",
    "render_preview",
    "save_model",
]
