"""Model libraries: a directory of photo-model files, with an index that caches them (name, size,
colours, dates, descriptors), and a label map (label text -> model)."""

import lazy_loader

__getattr__, __dir__, __all__ = lazy_loader.attach_stub(__name__, __file__)
