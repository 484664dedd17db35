"""The named simulated conditions (pure data: the CLI lists them without loading the
simulator)."""

from __future__ import annotations

__all__ = ["CONDITIONS"]

CONDITIONS: dict[str, dict[str, object]] = {
    "paper": {},
    "clean": {"noise_sigma": 0.0, "blur_sigma_px": 0.0, "vignetting": 0.0},
    "dim": {"light_level": 0.4},
    "bright": {"light_level": 1.6},
    "warm-light": {"colour_temperature_k": 3000.0},
    "cool-light": {"colour_temperature_k": 10000.0},
    "vignetting": {"vignetting": 0.45},
    "noise": {"noise_sigma": 7.0},
    "blur": {"blur_sigma_px": 1.8},
    "no-distortion": {"lens": "none"},
    "wide-lens": {"lens": "wide"},
    "grey": {"table": "grey"},
    "wood": {"table": "wood"},
    "conveyor": {"table": "conveyor"},
    "green": {"table": "green"},
    "tilt": {"tilt_deg": 8.0},
    "wrinkles": {"wrinkle_height_mm": 8.0},
    "distractors": {"distractor_garments": 2, "distractor_objects": 2},
    "gripper": {"occlusion": "gripper"},
    "overlap": {"occlusion": "garment"},
    "no-target": {"target": False, "distractor_garments": 2, "distractor_objects": 1},
    "empty": {"target": False},
}
"""Named presets: field overrides of :class:`Conditions` (``"paper"`` is the default set-up)."""
