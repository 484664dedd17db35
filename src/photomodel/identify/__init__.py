"""Identification: which photo-model of a library lies on the table, and its pose, or none.

Colour evidence drops models whose colours the images lack (:mod:`._screen`), the rest are
located with the default ``soft`` method in features computed once (:mod:`._identify`), and
the best is accepted against the threshold calibrated on simulated scenes
(:mod:`photomodel.locate._threshold`: the library's, the user's or the package's
``threshold.json``; ``photomodel experiment --identify --calibrate`` re-derives it).
:class:`Identifier` holds a library prepared for one rig.
"""

import lazy_loader

from photomodel.locate._threshold import (
    THRESHOLD_FILE,
    Threshold,
    calibrate_threshold,
    load_threshold,
    save_threshold,
)

__getattr__, _dir, _ = lazy_loader.attach(
    __name__,
    submod_attrs={
        "_identifier": ["Identifier"],
        "_identify": [
            "Candidate",
            "IdentifyConfig",
            "IdentifyResult",
            "identify",
            "identify_in_features",
        ],
        "_screen": ["ScreenConfig", "colour_evidence"],
    },
)

__all__ = [
    "THRESHOLD_FILE",
    "Candidate",
    "IdentifyConfig",
    "Identifier",
    "IdentifyResult",
    "ScreenConfig",
    "Threshold",
    "calibrate_threshold",
    "colour_evidence",
    "identify",
    "identify_in_features",
    "load_threshold",
    "save_threshold",
]


def __dir__() -> list[str]:
    return list(__all__)
