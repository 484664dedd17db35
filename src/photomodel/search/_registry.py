"""The global optimisers by the names ``locate --optimizer`` and ``PaperMethod`` use."""

from __future__ import annotations

from photomodel.search._cmaes import CMAES
from photomodel.search._de import DifferentialEvolution
from photomodel.search._full import FullSearch
from photomodel.search._ga import BinaryGA
from photomodel.search._realga import RealGA

__all__ = ["OPTIMIZERS"]

OPTIMIZERS = {"ga": BinaryGA, "full": FullSearch, "rga": RealGA, "cma": CMAES,
              "de": DifferentialEvolution}
"""Optimiser class by name: ``ga`` and ``full`` are the paper's, ``rga``, ``cma`` and ``de``
the comparison optimisers."""
