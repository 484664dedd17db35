"""Camera models and calibration files: pinhole with OpenCV distortion, the stereo rig."""

import lazy_loader

__getattr__, __dir__, __all__ = lazy_loader.attach_stub(__name__, __file__)
