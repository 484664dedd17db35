"""Settings of photo-model generation (no heavy imports: the CLI reads their defaults)."""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

__all__ = ["BUILD_RANGES", "DEFAULT_STATION_DISTANCE_MM", "BuildConfig"]

DEFAULT_STATION_DISTANCE_MM = 400.0
"""Model-station camera to plane distance, mm, where none is given (the paper's station)."""


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
    background_compare: bool = True
    chroma_threshold: float = 0.10
    lighter_fraction: float = 0.05
    shadow_fraction: float = 0.6
    mixing_min_contrast: float = 30.0
    plane_share_warning: float = 0.01

    def __post_init__(self) -> None:
        for key, value in asdict(self).items():
            lo, hi = BUILD_RANGES[key]
            if not (math.isfinite(value) and lo <= value <= hi) or (
                    key in _POSITIVE and value <= 0):
                unit = next((u for end, u in _UNITS if key.endswith(end)), "")
                allowed = (f"greater than {lo:g} and at most {hi:g}{unit}" if key in _POSITIVE
                           else f"from {lo:g} to {hi:g}{unit}")
                raise ValueError(f"{key}: expected a number {allowed}, got {value:g}")


BUILD_RANGES: dict[str, tuple[float, float]] = {
    "hue_threshold_deg": (0.0, 180.0),
    "achromatic_fraction": (0.0, 1.0),
    "dark_fraction": (0.0, 1.0),
    "step_mm": (0.5, 20.0),
    "edge_inset_mm": (0.0, 50.0),
    "band_gap_mm": (0.0, 50.0),
    "band_width_mm": (0.0, 100.0),
    "smooth_sigma_px": (0.0, 20.0),
    "min_area_mm2": (0.0, 1e6),
    "crop_margin_px": (0.0, 1000.0),
    "mixing_edge": (0.0, 1.0),
    "background_compare": (0.0, 1.0),
    "chroma_threshold": (0.0, 5.0),
    "lighter_fraction": (0.0, 10.0),
    "shadow_fraction": (0.0, 1.0),
    "mixing_min_contrast": (0.0, 442.0),
    "plane_share_warning": (0.0, 1.0),
}
"""Allowed range of each setting (units in the names; ``step_mm`` from 0.5 mm, about half a
pixel of the model camera, to 20 mm, beyond which a mid-size garment keeps too few points)."""
_POSITIVE = {"hue_threshold_deg", "chroma_threshold", "lighter_fraction"}
_UNITS = (("_mm2", " mm^2"), ("_mm", " mm"), ("_deg", " deg"), ("_px", " px"))
