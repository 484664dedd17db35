"""Tracking a garment's pose through a stereo sequence: the motion model, the windows, the
tracker."""

import lazy_loader

__getattr__, __dir__, __all__ = lazy_loader.attach_stub(__name__, __file__)
