# The subpackage's public names (lazy_loader.attach_stub reads this file; type
# checkers read it as the package's stub). One list: add a name here only.

from ._base import (
    Optimizer,
    SearchResult,
    run_search,
)
from ._cmaes import (
    CMAES,
    CMAConfig,
)
from ._de import (
    DEConfig,
    DifferentialEvolution,
)
from ._full import (
    FullSearch,
    FullSearchConfig,
)
from ._ga import (
    BinaryGA,
    GAConfig,
)
from ._gauss_newton import (
    GaussNewtonConfig,
    NormalEquationsFitness,
    TransformFitness,
    gauss_newton_refine,
)
from ._pyramid import (
    PyramidConfig,
    PyramidResult,
    pyramid_search,
)
from ._realga import (
    RealGA,
    RealGAConfig,
)
from ._refine import (
    GlobalThenLocal,
    LocalRefine,
    RefineConfig,
)
from ._registry import (
    OPTIMIZERS,
)
from ._space import (
    GENE_NAMES,
    SearchSpace,
)

__all__ = [
    "BinaryGA",
    "CMAConfig",
    "CMAES",
    "DEConfig",
    "DifferentialEvolution",
    "FullSearch",
    "FullSearchConfig",
    "GAConfig",
    "GENE_NAMES",
    "GaussNewtonConfig",
    "GlobalThenLocal",
    "LocalRefine",
    "NormalEquationsFitness",
    "OPTIMIZERS",
    "Optimizer",
    "PyramidConfig",
    "PyramidResult",
    "RealGA",
    "RealGAConfig",
    "RefineConfig",
    "SearchResult",
    "SearchSpace",
    "TransformFitness",
    "gauss_newton_refine",
    "pyramid_search",
    "run_search",
]
