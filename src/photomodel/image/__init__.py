"""Image files and colour: reading with clear errors, atomic writing, HSV and hue distances,
log-opponent features and their pyramid, sub-pixel sampling, text labels, and barcodes
(through zxing-cpp, the ``labels`` extra)."""

import lazy_loader

__getattr__, __dir__, _ = lazy_loader.attach(
    __name__,
    submod_attrs={
        "_barcode": ["EXTRA_HINT", "LINEAR_FORMATS", "Barcode", "barcode_modules",
                     "decode_barcodes", "zxing", "zxing_available"],
        "_features": ["feature_pyramid", "linear_intensity", "log_opponent"],
        "_hsv": ["bgr_to_hsv", "circular_mean_hue_deg", "hue_distance_deg"],
        "_io": ["IMAGE_SUFFIXES", "decode_color_image", "decode_color_images",
                "read_color_image", "read_grey_image", "write_image"],
        "_label": ["draw_label"],
        "_sample": ["sample_bilinear"],
    },
)

__all__ = [
    "EXTRA_HINT",
    "IMAGE_SUFFIXES",
    "LINEAR_FORMATS",
    "Barcode",
    "barcode_modules",
    "bgr_to_hsv",
    "circular_mean_hue_deg",
    "decode_barcodes",
    "decode_color_image",
    "decode_color_images",
    "draw_label",
    "feature_pyramid",
    "hue_distance_deg",
    "linear_intensity",
    "log_opponent",
    "read_color_image",
    "read_grey_image",
    "sample_bilinear",
    "write_image",
    "zxing",
    "zxing_available",
]
