# The subpackage's public names (lazy_loader.attach_stub reads this file; type
# checkers read it as the package's stub). One list: add a name here only.

from ._locate import (
    COARSE_MIN_SCORE,
    COARSE_SCAN,
    DEFAULT_FITNESS,
    DEFAULT_MIN_SCORE,
    PAPER_METHOD,
    LocateResult,
    LocateSettings,
    Method,
    PaperMethod,
    locate,
    locate_in_features,
    make_optimizer,
    paper_method,
    soft_score,
)
from ._locator import (
    Locator,
)
from ._overlay import (
    draw_overlay,
    draw_table_overlay,
)
from ._prepare import (
    prepare_model,
)
from ._scale import (
    locate_unknown_scale,
)
from ._threshold import (
    THRESHOLD_FILE,
    Threshold,
    calibrate_threshold,
    load_threshold,
    save_threshold,
    threshold_path,
    user_threshold_path,
)

__all__ = [
    "COARSE_MIN_SCORE",
    "COARSE_SCAN",
    "DEFAULT_FITNESS",
    "DEFAULT_MIN_SCORE",
    "LocateResult",
    "LocateSettings",
    "Locator",
    "Method",
    "PAPER_METHOD",
    "PaperMethod",
    "THRESHOLD_FILE",
    "Threshold",
    "calibrate_threshold",
    "draw_overlay",
    "draw_table_overlay",
    "load_threshold",
    "locate",
    "locate_in_features",
    "locate_unknown_scale",
    "make_optimizer",
    "paper_method",
    "prepare_model",
    "save_threshold",
    "soft_score",
    "threshold_path",
    "user_threshold_path",
]
