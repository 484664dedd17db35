"""Settings of photo-model generation (no heavy imports: the CLI reads their defaults)."""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

__all__ = ["BuildConfig"]


@dataclass(frozen=True)
class BuildConfig:
    """Settings of photo-model generation (see the module docstring for the defaults)."""

    hue_threshold_deg: float = 30.0
    achromatic_fraction: float = 0.4
    dark_fraction: float = 0.4
    step_mm: float = 3.0
    edge_inset_mm: float = 1.5
    band_gap_mm: float = 1.5
    band_width_mm: float = 6.0
    smooth_sigma_px: float = 1.0
    min_area_mm2: float = 400.0
    crop_margin_px: int = 8
    mixing_edge: bool = True

    def __post_init__(self) -> None:
        for key, value in asdict(self).items():
            if not math.isfinite(value) or value < 0:
                raise ValueError(f"{key}: expected a non-negative number, got {value}")
        if self.step_mm <= 0:
            raise ValueError(f"step_mm: expected a positive number, got {self.step_mm}")
