"""Locating a photo-model in a stereo pair: the search loop, the result, the overlay."""

from photomodel.locate._locate import (
    DEFAULT_FITNESS,
    DEFAULT_MIN_SCORE,
    PAPER_METHOD,
    LocateResult,
    locate,
    locate_in_features,
    make_optimizer,
)
from photomodel.locate._overlay import draw_overlay

__all__ = [
    "DEFAULT_FITNESS",
    "DEFAULT_MIN_SCORE",
    "PAPER_METHOD",
    "LocateResult",
    "draw_overlay",
    "locate",
    "locate_in_features",
    "make_optimizer",
]
