"""Identification: which photo-model of a library lies on the table, and its pose, or none.

The garment-like regions of the pair (:func:`~photomodel.fitness.scene_regions`) are
compared with every model's descriptor (:mod:`._bank`: milliseconds for thousands of
models), the best-screened are
located with the default ``soft`` method in features computed once (:mod:`._identify`), and
the best is accepted against the threshold calibrated on simulated scenes
(:func:`photomodel.locate.load_threshold`: the library's, the user's or the package's
``threshold.json``; ``photomodel experiment --identify --calibrate`` re-derives it).
:class:`Identifier` holds a library for one rig, its models prepared on first use
(:class:`PreparedModels`), and reads the garment's label beside the photo-model's answer
(:func:`read_labels`, :class:`LabelCheck`: barcodes, QR codes and DataMatrix through
zxing-cpp, named by the library's label map).
"""

import lazy_loader

__getattr__, __dir__, __all__ = lazy_loader.attach_stub(__name__, __file__)
