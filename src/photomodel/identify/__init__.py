"""Identification: which photo-model of a library lies on the table, and its pose, or none.

Colour evidence drops models whose colours the images lack (:mod:`._screen`), the rest are
located with the default ``soft`` method in features computed once (:mod:`._identify`), and
the best is accepted against the threshold calibrated on simulated scenes and stored with the
package (:mod:`photomodel.locate._threshold`, ``threshold.json``; ``photomodel experiment
--identify --calibrate`` re-derives it).
"""

from photomodel.identify._identify import (
    Candidate,
    IdentifyConfig,
    IdentifyResult,
    identify,
    identify_in_features,
)
from photomodel.identify._screen import ScreenConfig, colour_evidence
from photomodel.locate._threshold import (
    THRESHOLD_FILE,
    Threshold,
    calibrate_threshold,
    load_threshold,
    save_threshold,
)

__all__ = [
    "THRESHOLD_FILE",
    "Candidate",
    "IdentifyConfig",
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
