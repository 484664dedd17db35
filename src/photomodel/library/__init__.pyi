# The subpackage's public names (lazy_loader.attach_stub reads this file; type
# checkers read it as the package's stub). One list: add a name here only.

from ._library import (
    INDEX_NAME,
    LABELS_NAME,
    LIBRARY_FORMAT_VERSION,
    LOOKED_FOR,
    LibraryEntry,
    LibraryScan,
    ModelLibrary,
    Skipped,
    check_label_code,
    check_model_name,
    main_colours,
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
