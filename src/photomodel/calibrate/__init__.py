"""Calibration from views of a printed chessboard (or ChArUco board), through OpenCV: one
camera's intrinsics (and the model station's plane distance), a stereo rig's, the corner
detector, the target.

What ``photomodel calibrate`` runs (docs/contracts.md, "Calibration").
"""

import lazy_loader

__getattr__, __dir__, __all__ = lazy_loader.attach_stub(__name__, __file__)
