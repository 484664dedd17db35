"""Model libraries: a directory of photo-model files, with an index that caches them (name, size,
colours, dates, descriptors), and a label map (label text -> model)."""

import lazy_loader

__getattr__, __dir__, _ = lazy_loader.attach(
    __name__,
    submod_attrs={
        "_library": [
            "INDEX_NAME",
            "LABELS_NAME",
            "LIBRARY_FORMAT_VERSION",
            "LOOKED_FOR",
            "LibraryEntry",
            "LibraryScan",
            "ModelLibrary",
            "Skipped",
            "check_label_code",
            "check_model_name",
            "main_colours",
        ],
    },
)

__all__ = [
    "INDEX_NAME",
    "LABELS_NAME",
    "LIBRARY_FORMAT_VERSION",
    "LOOKED_FOR",
    "LibraryEntry",
    "LibraryScan",
    "ModelLibrary",
    "Skipped",
    "check_label_code",
    "check_model_name",
    "main_colours",
]
