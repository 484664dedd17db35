"""Image files and colour: reading with clear errors, atomic writing, HSV and hue distances,
text labels."""

import lazy_loader

__getattr__, __dir__, _ = lazy_loader.attach(
    __name__,
    submod_attrs={
        "_hsv": ["bgr_to_hsv", "circular_mean_hue_deg", "hue_distance_deg"],
        "_io": ["IMAGE_SUFFIXES", "decode_color_image", "decode_color_images",
                "read_color_image", "read_grey_image", "write_image"],
        "_label": ["draw_label"],
        "_sample": ["sample_bilinear"],
    },
)

__all__ = [
    "IMAGE_SUFFIXES",
    "bgr_to_hsv",
    "circular_mean_hue_deg",
    "decode_color_image",
    "decode_color_images",
    "draw_label",
    "hue_distance_deg",
    "read_color_image",
    "read_grey_image",
    "sample_bilinear",
    "write_image",
]
