# The subpackage's public names (lazy_loader.attach_stub reads this file; type
# checkers read it as the package's stub). One list: add a name here only.

from ._barcode import (
    EXTRA_HINT,
    LINEAR_FORMATS,
    Barcode,
    barcode_modules,
    decode_barcodes,
    zxing,
    zxing_available,
)
from ._features import (
    feature_pyramid,
    linear_intensity,
    log_opponent,
)
from ._hsv import (
    bgr_to_hsv,
    circular_mean_hue_deg,
    hue_distance_deg,
)
from ._io import (
    IMAGE_SUFFIXES,
    decode_color_image,
    decode_color_images,
    read_color_image,
    read_grey_image,
    write_image,
)
from ._label import (
    draw_label,
)
from ._sample import (
    sample_bilinear,
)

__all__ = [
    "Barcode",
    "EXTRA_HINT",
    "IMAGE_SUFFIXES",
    "LINEAR_FORMATS",
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
