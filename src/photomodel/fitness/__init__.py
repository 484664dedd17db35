"""Fitness functions over whole pose populations: the paper's eq. (9) with hue matching, and
the ``soft`` fitness (graded log-opponent colour, sub-pixel, over a feature pyramid)."""

import lazy_loader

__getattr__, __dir__, __all__ = lazy_loader.attach_stub(__name__, __file__)
