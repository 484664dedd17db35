"""Pose search behind one ask/tell interface.

The paper's binary GA and full (grid) search; for comparison a real-coded GA, CMA-ES with
IPOP restarts (the ``cma`` package, the ``compare`` extra) and differential evolution; and
the default method's coarse-to-fine search (:func:`pyramid_search`) with its local
refinements (:class:`LocalRefine`, :func:`gauss_newton_refine`).
"""

from photomodel.search._base import Optimizer, SearchResult, run_search
from photomodel.search._cmaes import CMAES, CMAConfig
from photomodel.search._de import DEConfig, DifferentialEvolution
from photomodel.search._full import FullSearch, FullSearchConfig
from photomodel.search._ga import BinaryGA, GAConfig
from photomodel.search._gauss_newton import (
    GaussNewtonConfig,
    NormalEquationsFitness,
    TransformFitness,
    gauss_newton_refine,
)
from photomodel.search._pyramid import PyramidConfig, PyramidResult, pyramid_search
from photomodel.search._realga import RealGA, RealGAConfig
from photomodel.search._refine import GlobalThenLocal, LocalRefine, RefineConfig
from photomodel.search._space import GENE_NAMES, SearchSpace

OPTIMIZERS = {"ga": BinaryGA, "full": FullSearch, "rga": RealGA, "cma": CMAES,
              "de": DifferentialEvolution}

__all__ = [
    "CMAES",
    "GENE_NAMES",
    "OPTIMIZERS",
    "BinaryGA",
    "CMAConfig",
    "DEConfig",
    "DifferentialEvolution",
    "FullSearch",
    "FullSearchConfig",
    "GAConfig",
    "GaussNewtonConfig",
    "GlobalThenLocal",
    "LocalRefine",
    "Optimizer",
    "PyramidConfig",
    "PyramidResult",
    "RealGA",
    "RealGAConfig",
    "RefineConfig",
    "NormalEquationsFitness",
    "SearchResult",
    "SearchSpace",
    "TransformFitness",
    "gauss_newton_refine",
    "pyramid_search",
    "run_search",
]
