"""Photo-models: generation from a photo (paper sec. 2.2), the model file, the preview."""

import lazy_loader

__getattr__, __dir__, _ = lazy_loader.attach(
    __name__,
    submod_attrs={
        "_build": ["BuildQuality", "BuildResult", "build_model", "build_photo_model"],
        "_config": ["BuildConfig"],
        "_descriptor": ["DESCRIPTOR_VERSION", "ModelDescriptor", "describe_model"],
        "_photomodel": ["FORMAT_VERSION", "PhotoModel", "load_model", "save_model"],
        "_preview": ["render_preview"],
    },
)

__all__ = [
    "DESCRIPTOR_VERSION",
    "FORMAT_VERSION",
    "BuildConfig",
    "BuildQuality",
    "BuildResult",
    "ModelDescriptor",
    "PhotoModel",
    "build_model",
    "build_photo_model",
    "describe_model",
    "load_model",
    "render_preview",
    "save_model",
]
