"""Pose search behind one ask/tell interface.

The paper's binary GA and full (grid) search, and for comparison a real-coded GA, CMA-ES
with IPOP restarts and differential evolution.
"""

from photomodel.search._base import Optimizer, SearchResult, run_search
from photomodel.search._cmaes import CMAES, CMAConfig
from photomodel.search._de import DEConfig, DifferentialEvolution
from photomodel.search._full import FullSearch, FullSearchConfig
from photomodel.search._ga import BinaryGA, GAConfig
from photomodel.search._gauss_newton import (
    GaussNewtonConfig,
    NormalEquationsFitness,
    ResidualFitness,
    gauss_newton_refine,
)
from photomodel.search._localcma import LocalCMA, LocalCMAConfig
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
    "LocalCMA",
    "LocalCMAConfig",
    "LocalRefine",
    "Optimizer",
    "PyramidConfig",
    "PyramidResult",
    "RealGA",
    "RealGAConfig",
    "RefineConfig",
    "NormalEquationsFitness",
    "ResidualFitness",
    "SearchResult",
    "SearchSpace",
    "gauss_newton_refine",
    "pyramid_search",
    "run_search",
]
