"""Model libraries: a directory of photo-model files with an index (name, size, colours, dates)."""

from photomodel.library._library import (
    INDEX_NAME,
    LIBRARY_FORMAT_VERSION,
    LibraryEntry,
    LibraryScan,
    ModelLibrary,
    Skipped,
    check_model_name,
    main_colours,
)

__all__ = [
    "INDEX_NAME",
    "LIBRARY_FORMAT_VERSION",
    "LibraryEntry",
    "LibraryScan",
    "ModelLibrary",
    "Skipped",
    "check_model_name",
    "main_colours",
]
