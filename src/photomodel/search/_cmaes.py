"""CMA-ES (Hansen & Ostermeier 2001) from the ``cma`` package, with IPOP restarts.

The strategy runs in the unit cube [0, 1]^6 of the search box (``UnitBox``; ``cma``'s
``bounds`` option ``[0, 1]``, whose boundary transformation keeps every sample inside), so
one step size fits millimetres and eps alike. ``cma`` minimises: it is told ``-fitness``,
with non-finite fitness replaced by a value worse than every finite one of the batch.

Restarts (IPOP-CMA-ES, Auger & Hansen 2005): when ``cma`` stops and restarts are left, a
new strategy starts from a uniform random point of the cube with ``sigma0`` and twice the
previous population; larger populations smooth out the local peaks of a multimodal
fitness. The best pose over all runs is the result. ``maxfevals`` bounds the whole
search, restarts included.

Randomness: every sample comes from this object's generator (``cma``'s ``randn`` option),
and ``cma``'s ``seed`` option is ``nan`` ("do nothing"): a numeric ``seed`` would reseed
numpy's global generator, a process-wide side effect.

``cma`` is imported when a strategy is built (:func:`load_cma`), never with this module;
the ``compare`` extra installs it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from types import ModuleType
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from photomodel.errors import InputError
from photomodel.search._base import SearchResult, _Tracker
from photomodel.search._space import SearchSpace
from photomodel.search._unit import UnitBox

if TYPE_CHECKING:
    import cma

__all__ = ["CMAConfig", "CMAES", "load_cma"]

CMA_MISSING = "needs the 'cma' package: pip install 'photomodel[compare]'"
"""The problem an :class:`~photomodel.errors.InputError` names when ``cma`` is missing."""


def load_cma(source: str = "--optimizer cma") -> ModuleType:
    """The ``cma`` module, imported on first use; an :class:`~photomodel.errors.InputError`
    naming ``source`` (what asked for CMA-ES) and the extra that installs it where it is
    missing."""
    try:
        import cma
    except ImportError:
        raise InputError(source, CMA_MISSING) from None
    return cma

_CMA_REASONS = {
    "maxfevals": "evaluation budget spent",
    "maxiter": "iteration limit",
    "tolfun": "fitness range below tolfun",
    "tolfunhist": "fitness history range below tolfunhist",
    "tolfunrel": "fitness range below tolfunrel",
    "tolflatfitness": "flat fitness",
    "tolx": "step size below tolx",
    "tolstagnation": "no progress of the median fitness",
    "tolupsigma": "step size grew too much",
    "tolconditioncov": "covariance ill-conditioned",
    "noeffectaxis": "step has no effect along a principal axis",
    "noeffectcoord": "step has no effect in a coordinate",
    "timeout": "time limit",
    "callback": "callback",
}


def describe_cma_stop(stop: dict[str, Any]) -> str:
    """A readable reason from the dict of ``CMAEvolutionStrategy.stop()``."""
    parts = []
    for key, value in stop.items():
        text = f"cma {key}: {_CMA_REASONS.get(key, key)}"
        if isinstance(value, int | float) and not isinstance(value, bool):
            text += f" ({value:g})"
        parts.append(text)
    return "; ".join(parts)


def tell_strategy(es: cma.CMAEvolutionStrategy, pending: list[NDArray[np.float64]] | None,
                  tracker: _Tracker, x: NDArray[np.float64], fitness: NDArray[np.float64]
                  ) -> None:
    """Give ``es`` the fitness of the points it asked for (``pending``) and ``tracker`` the
    poses ``x``: ``cma`` minimises ``-fitness``, a non-finite fitness counts worse than every
    finite one of the batch."""
    if pending is None:
        raise ValueError("tell: call ask first (no points are waiting for their fitness)")
    f = np.asarray(fitness, dtype=np.float64).reshape(-1)
    if len(f) != len(pending):
        raise ValueError(f"tell: expected {len(pending)} fitness values, got {len(f)}")
    finite = np.isfinite(f)
    f = np.where(finite, f, -np.inf)
    tracker.update(x, f)
    worst = float(np.min(f[finite])) if finite.any() else 0.0
    es.tell(pending, (-np.where(finite, f, worst - 1.0 - abs(worst))).tolist())


@dataclass(frozen=True)
class CMAConfig:
    """Settings of :class:`CMAES` (unit-cube coordinates; fitness as told).

    ``popsize`` None is ``cma``'s default, ``4 + int(3 ln 6) = 9`` in six dimensions.
    ``maxfevals`` 48,000 is the budget of :class:`~photomodel.search.BinaryGA`'s default
    (800 generations of 60), so the methods are compared on equal terms. ``tolx`` 1e-6 of
    each gene's range is 0.5 um in x for the paper's box.
    """

    popsize: int | None = None
    sigma0: float = 0.3
    maxfevals: int = 48_000
    tolfun: float = 1e-8
    tolx: float = 1e-6
    restarts: int = 4
    popsize_factor: float = 2.0

    def __post_init__(self) -> None:
        if self.popsize is not None and self.popsize < 2:
            raise ValueError(f"popsize: expected >= 2 or None, got {self.popsize}")
        if not 0 < self.sigma0 <= 1:
            raise ValueError(f"sigma0: expected in (0, 1] (unit coordinates), got {self.sigma0}")
        if self.maxfevals < 1 or self.restarts < 0:
            raise ValueError("maxfevals must be >= 1, restarts >= 0")
        if not (self.tolfun >= 0 and self.tolx >= 0):
            raise ValueError("tolfun and tolx must be >= 0")
        if not self.popsize_factor >= 1:
            raise ValueError(f"popsize_factor: expected >= 1, got {self.popsize_factor}")

    @property
    def first_popsize(self) -> int:
        """Population of the first run."""
        return self.popsize if self.popsize is not None else 4 + int(3 * math.log(6))


class CMAES:
    """CMA-ES with IPOP restarts behind the ask/tell interface (see the module docstring).

    Parameters
    ----------
    space : SearchSpace
    config : CMAConfig, optional
    rng : int, Generator or None
        Seed or generator; the same seed gives the same search.
    x0 : array_like (6,), optional
        Start pose (x, y, z mm, eps1, eps2, eps3) of the first run; default a uniform
        random pose. Restarts start at random poses.
    sigma0 : array_like (6,), optional
        Initial step per gene of the first run (mm, eps), only with ``x0``; default a tenth
        of each gene's range. Without ``x0`` the first run uses ``config.sigma0``.

    Raises
    ------
    InputError
        Where the ``cma`` package is not installed (``--optimizer cma``).
    """

    def __init__(self, space: SearchSpace, config: CMAConfig | None = None,
                 rng: int | np.random.Generator | None = None,
                 x0: ArrayLike | None = None, sigma0: ArrayLike | None = None) -> None:
        self._cma = load_cma()
        self.space = space
        self.config = c = config or CMAConfig()
        self.rng = np.random.default_rng(rng)
        self.unit = UnitBox(space)
        start = self.unit.start(x0, sigma0)
        self._tracker = _Tracker()
        self.restarts_done = 0
        self.popsize = c.first_popsize
        self._pending: list[NDArray[np.float64]] | None = None
        self._last_stop = ""
        if start is None:
            self.es = self._new_strategy(self.rng.random(6), np.full(6, c.sigma0))
        else:
            self.es = self._new_strategy(*start)

    def _new_strategy(self, u0: NDArray[np.float64], s0: NDArray[np.float64]
                      ) -> cma.CMAEvolutionStrategy:
        c = self.config
        scale = float(np.max(s0))
        options = {
            "bounds": [0.0, 1.0],
            "popsize": self.popsize,
            "CMA_stds": (s0 / scale).tolist(),
            "maxfevals": max(c.maxfevals - self._tracker.evaluations, 1),
            "tolfun": c.tolfun,
            "tolx": c.tolx,
            "seed": np.nan,
            "randn": self._randn,
            "verbose": -9,
            "verb_log": 0,
            "verb_disp": 0,
        }
        return self._cma.CMAEvolutionStrategy(np.clip(u0, 0.0, 1.0).tolist(), scale, options)

    def _randn(self, *shape: int) -> NDArray[np.float64]:
        """Standard normal samples for ``cma``, from this optimiser's generator."""
        return self.rng.standard_normal(shape)

    def ask(self) -> NDArray[np.float64]:
        """The current run's population of pose vectors (popsize, 6)."""
        if self._pending is None:
            self._pending = self.es.ask()
        return self.unit.from_unit(np.array(self._pending))

    def tell(self, x: NDArray[np.float64], fitness: NDArray[np.float64]) -> None:
        """Score the population of the last ``ask``; restart when the run has stopped.

        ``x`` goes into the result; ``cma`` is told the points it was asked for.
        """
        tell_strategy(self.es, self._pending, self._tracker, x, fitness)
        self._pending = None
        reason = self.es.stop()
        if reason:
            self._last_stop = describe_cma_stop(reason)
            budget_left = self._tracker.evaluations < self.config.maxfevals
            if self.restarts_done < self.config.restarts and budget_left:
                self.restarts_done += 1
                self.popsize = int(round(self.popsize * self.config.popsize_factor))
                self.es = self._new_strategy(self.rng.random(6),
                                             np.full(6, self.config.sigma0))

    def stop(self) -> str | None:
        """Why the search stopped, or None while it goes on."""
        if self._tracker.evaluations >= self.config.maxfevals:
            return f"maxfevals ({self.config.maxfevals})"
        if self.es.stop():
            n = self.restarts_done
            runs = f" after {n} restart{'s' if n > 1 else ''}" if n else ""
            return f"{self._last_stop}{runs}"
        return None

    @property
    def result(self) -> SearchResult:
        """Best pose over all runs and the evolution of best and mean fitness."""
        return self._tracker.result(self.stop() or "running")
