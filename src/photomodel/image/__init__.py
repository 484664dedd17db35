"""Image files and colour: reading with clear errors, atomic writing, HSV and hue distances."""

from photomodel.image._hsv import bgr_to_hsv, circular_mean_hue_deg, hue_distance_deg
from photomodel.image._io import read_color_image, write_image

__all__ = [
    "bgr_to_hsv",
    "circular_mean_hue_deg",
    "hue_distance_deg",
    "read_color_image",
    "write_image",
]
