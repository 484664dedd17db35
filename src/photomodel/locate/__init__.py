"""Locating a photo-model in a stereo pair: the search loop, the result, the overlay."""

import lazy_loader

__getattr__, __dir__, _ = lazy_loader.attach(
    __name__,
    submod_attrs={
        "_locate": [
            "COARSE_MIN_SCORE",
            "COARSE_SCAN",
            "DEFAULT_FITNESS",
            "DEFAULT_MIN_SCORE",
            "PAPER_METHOD",
            "LocateResult",
            "Method",
            "PaperMethod",
            "locate",
            "locate_in_features",
            "make_optimizer",
            "paper_method",
            "soft_score",
        ],
        "_locator": ["Locator"],
        "_overlay": ["draw_overlay", "draw_table_overlay"],
        "_prepare": ["prepare_model"],
        "_threshold": [
            "THRESHOLD_FILE",
            "Threshold",
            "calibrate_threshold",
            "load_threshold",
            "save_threshold",
            "threshold_path",
            "user_threshold_path",
        ],
    },
)

__all__ = [
    "COARSE_MIN_SCORE",
    "COARSE_SCAN",
    "DEFAULT_FITNESS",
    "DEFAULT_MIN_SCORE",
    "PAPER_METHOD",
    "THRESHOLD_FILE",
    "LocateResult",
    "Locator",
    "Method",
    "PaperMethod",
    "Threshold",
    "calibrate_threshold",
    "draw_overlay",
    "draw_table_overlay",
    "locate",
    "load_threshold",
    "locate_in_features",
    "make_optimizer",
    "paper_method",
    "prepare_model",
    "save_threshold",
    "threshold_path",
    "user_threshold_path",
    "soft_score",
]
