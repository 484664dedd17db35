"""Identification: which photo-model of a library lies on the table, and its pose, or none.

The garment-like regions of the pair (:func:`~photomodel.fitness.scene_regions`) are
compared with every model's descriptor (:mod:`._bank`: milliseconds for thousands of
models), the best-screened are
located with the default ``soft`` method in features computed once (:mod:`._identify`), and
the best is accepted against the threshold calibrated on simulated scenes
(:func:`photomodel.locate.load_threshold`: the library's, the user's or the package's
``threshold.json``; ``photomodel experiment --identify --calibrate`` re-derives it).
:class:`Identifier` holds a library for one rig, its models prepared on first use
(:class:`PreparedModels`), and reads the garment's label beside the photo-model's answer
(:func:`read_labels`, :class:`LabelCheck`: barcodes, QR codes and DataMatrix through
zxing-cpp, named by the library's label map).
"""

import lazy_loader

from photomodel.fitness import Region, SceneConfig, SceneRegions, scene_regions
from photomodel.locate import (
    THRESHOLD_FILE,
    Threshold,
    calibrate_threshold,
    load_threshold,
    save_threshold,
)

__getattr__, _dir, _ = lazy_loader.attach(
    __name__,
    submod_attrs={
        "_bank": ["BankConfig", "DescriptorBank"],
        "_cache": ["CacheStats", "PreparedModels"],
        "_identifier": ["DEFAULT_PREPARED_MODELS", "Identifier"],
        "_identify": [
            "Candidate",
            "IdentifyConfig",
            "IdentifyResult",
            "identify",
            "identify_in_features",
            "identify_with_bank",
        ],
        "_labels": ["READ_FORMATS", "LabelCheck", "LabelRead", "check_label", "read_labels"],
        "_table": ["TableConfig", "TableGarment", "TableResult", "identify_all"],
    },
)

__all__ = [
    "DEFAULT_PREPARED_MODELS",
    "READ_FORMATS",
    "THRESHOLD_FILE",
    "BankConfig",
    "CacheStats",
    "Candidate",
    "DescriptorBank",
    "IdentifyConfig",
    "Identifier",
    "IdentifyResult",
    "LabelCheck",
    "LabelRead",
    "PreparedModels",
    "Region",
    "SceneConfig",
    "SceneRegions",
    "TableConfig",
    "TableGarment",
    "TableResult",
    "Threshold",
    "calibrate_threshold",
    "check_label",
    "identify",
    "identify_all",
    "identify_in_features",
    "identify_with_bank",
    "load_threshold",
    "read_labels",
    "save_threshold",
    "scene_regions",
]


def __dir__() -> list[str]:
    return list(__all__)
