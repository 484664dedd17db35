"""Locating a photo-model in a stereo pair: the search loop, the result, the overlay."""

import lazy_loader

__getattr__, __dir__, __all__ = lazy_loader.attach_stub(__name__, __file__)
