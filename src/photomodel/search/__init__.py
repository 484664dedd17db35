"""Pose search behind one ask/tell interface.

The paper's binary GA and full (grid) search; for comparison a real-coded GA, CMA-ES with
IPOP restarts (the ``cma`` package, the ``compare`` extra) and differential evolution; and
the default method's coarse-to-fine search (:func:`pyramid_search`) with its local
refinements (:class:`LocalRefine`, :func:`gauss_newton_refine`).
"""

import lazy_loader

__getattr__, __dir__, __all__ = lazy_loader.attach_stub(__name__, __file__)
