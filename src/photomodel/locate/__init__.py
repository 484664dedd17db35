"""Locating a photo-model in a stereo pair: the search loop, the result, the overlay."""

from photomodel.locate._locate import (
    COARSE_MIN_SCORE,
    COARSE_SCAN,
    DEFAULT_FITNESS,
    DEFAULT_MIN_SCORE,
    PAPER_METHOD,
    LocateResult,
    locate,
    locate_in_features,
    make_optimizer,
    soft_score,
)
from photomodel.locate._overlay import draw_overlay
from photomodel.locate._prepare import prepare_model
from photomodel.locate._threshold import (
    THRESHOLD_FILE,
    Threshold,
    calibrate_threshold,
    load_threshold,
    save_threshold,
)

__all__ = [
    "COARSE_MIN_SCORE",
    "COARSE_SCAN",
    "DEFAULT_FITNESS",
    "DEFAULT_MIN_SCORE",
    "PAPER_METHOD",
    "THRESHOLD_FILE",
    "LocateResult",
    "Threshold",
    "calibrate_threshold",
    "draw_overlay",
    "locate",
    "load_threshold",
    "locate_in_features",
    "make_optimizer",
    "prepare_model",
    "save_threshold",
    "soft_score",
]
