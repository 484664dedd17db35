"""Pose search behind one ask/tell interface: the paper's binary GA and full (grid) search."""

from photomodel.search._base import Optimizer, SearchResult, run_search
from photomodel.search._full import FullSearch, FullSearchConfig
from photomodel.search._ga import BinaryGA, GAConfig
from photomodel.search._refine import GlobalThenLocal, LocalRefine, RefineConfig
from photomodel.search._space import GENE_NAMES, SearchSpace

OPTIMIZERS = {"ga": BinaryGA, "full": FullSearch}

__all__ = [
    "GENE_NAMES",
    "OPTIMIZERS",
    "BinaryGA",
    "FullSearch",
    "FullSearchConfig",
    "GAConfig",
    "GlobalThenLocal",
    "LocalRefine",
    "Optimizer",
    "RefineConfig",
    "SearchResult",
    "SearchSpace",
    "run_search",
]
