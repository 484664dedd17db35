"""Image files and colour: reading with clear errors, atomic writing, HSV and hue distances,
log-opponent features and their pyramid, sub-pixel sampling, text labels, and barcodes
(through zxing-cpp, the ``labels`` extra)."""

import lazy_loader

__getattr__, __dir__, __all__ = lazy_loader.attach_stub(__name__, __file__)
