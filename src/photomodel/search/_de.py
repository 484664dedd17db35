"""Differential evolution, DE/rand/1/bin (Storn & Price 1997), in ask/tell form.

Storn, R. and Price, K. (1997), "Differential Evolution - A Simple and Efficient Heuristic
for global Optimization over Continuous Spaces", J. Global Optimization 11, 341-359.

scipy's :func:`scipy.optimize.differential_evolution` drives the loop itself (it calls the
objective; there is no ask/tell), so the method is written out here in ask/tell form over
the unit cube [0, 1]^6 of the search box (``UnitBox``):

* The first ``ask`` returns the initial population (``population`` uniform draws, or
  ``x0`` and draws of spread ``sigma0`` around it).
* Each later ``ask`` returns one trial per member ``i``: the mutant
  ``v = p[r1] + F * (p[r2] - p[r3])`` with ``r1, r2, r3`` distinct and different from
  ``i`` (DE/rand/1, chosen over current-to-best/1 for its robustness on the multimodal
  stereo fitness), crossed binomially with ``p[i]`` (each gene from ``v`` with probability
  ``CR``, one random gene always). A gene that leaves [0, 1] *bounces back* between the
  base ``p[r1]`` and the face it crossed: ``p[r1] + rand * (face - p[r1])`` (Price, Storn &
  Lampinen 2005), which keeps the population from piling up on the faces as clipping does.
* ``tell`` keeps the trial where its fitness is at least its target's (``>=`` lets the
  population drift across plateaus of the piecewise-constant fitness).
* **Stop**: after ``max_generations`` trial generations, or when the spread
  ``max - min`` of the population's fitness is at most ``tol`` (checked from the first
  trial generation on).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from photomodel.search._base import SearchResult, _Tracker
from photomodel.search._space import SearchSpace
from photomodel.search._unit import UnitBox

__all__ = ["DEConfig", "DifferentialEvolution"]


@dataclass(frozen=True)
class DEConfig:
    """Settings of :class:`DifferentialEvolution` (DE/rand/1/bin).

    ``F`` (differential weight) 0.7 and ``CR`` (crossover probability) 0.9 are the usual
    choice for non-separable problems (Storn & Price 1997 recommend F in [0.5, 1] and a
    large CR when the variables interact, as position and angle do here).
    """

    population: int = 40
    F: float = 0.7
    CR: float = 0.9
    max_generations: int = 1000
    tol: float = 1e-8

    def __post_init__(self) -> None:
        if self.population < 4:
            raise ValueError(f"population: expected >= 4 (DE/rand/1 needs four distinct "
                             f"members), got {self.population}")
        if not 0 < self.F <= 2:
            raise ValueError(f"F: expected in (0, 2], got {self.F}")
        if not 0 <= self.CR <= 1:
            raise ValueError(f"CR: expected a probability, got {self.CR}")
        if self.max_generations < 1 or not self.tol >= 0:
            raise ValueError("max_generations must be >= 1 and tol >= 0")


class DifferentialEvolution:
    """DE/rand/1/bin behind the ask/tell interface (see the module docstring).

    Parameters
    ----------
    space : SearchSpace
    config : DEConfig, optional
    rng : int, Generator or None
        Seed or generator; the same seed gives the same search.
    x0 : array_like (6,), optional
        Start pose (x, y, z mm, eps1, eps2, eps3): the initial population lies around it.
    sigma0 : array_like (6,), optional
        Spread of the initial population around ``x0`` per gene (mm, eps); default a tenth
        of each gene's range.
    """

    def __init__(self, space: SearchSpace, config: DEConfig | None = None,
                 rng: int | np.random.Generator | None = None,
                 x0: ArrayLike | None = None, sigma0: ArrayLike | None = None) -> None:
        self.space = space
        self.config = c = config or DEConfig()
        self.rng = np.random.default_rng(rng)
        self.unit = UnitBox(space)
        self.pop, _ = self.unit.initial_population(self.rng, c.population, x0, sigma0)
        self.pop_f: NDArray[np.float64] | None = None  # None until the first tell
        self._trials: NDArray[np.float64] | None = self.pop
        self._tracker = _Tracker()
        self.generation = 0

    def _make_trials(self) -> NDArray[np.float64]:
        c, p = self.config, self.pop
        n = len(p)
        keys = self.rng.random((n, n))
        np.fill_diagonal(keys, np.inf)  # r1, r2, r3 != i, and distinct from each other
        r1, r2, r3 = np.argsort(keys, axis=1)[:, :3].T
        base = p[r1]
        mutant = base + c.F * (p[r2] - p[r3])
        cross = self.rng.random((n, 6)) < c.CR
        cross[np.arange(n), self.rng.integers(0, 6, size=n)] = True
        trial = np.where(cross, mutant, p)
        bounce = self.rng.random((n, 6))
        trial = np.where(trial < 0, base - bounce * base, trial)
        return np.where(trial > 1, base + bounce * (1 - base), trial)

    def ask(self) -> NDArray[np.float64]:
        """The initial population, then one trial per member (population, 6)."""
        if self._trials is None:
            self._trials = self._make_trials()
        return self.unit.from_unit(self._trials)

    def tell(self, x: NDArray[np.float64], fitness: NDArray[np.float64]) -> None:
        """Score the points of the last ``ask``; each trial replaces its target if not worse.

        ``x`` goes into the result; the population takes the points that were asked for.
        """
        if self._trials is None:
            raise ValueError("tell: call ask first (no points are waiting for their fitness)")
        f = np.asarray(fitness, dtype=np.float64).reshape(-1)
        if len(f) != len(self._trials):
            raise ValueError(f"tell: expected {len(self._trials)} fitness values, got {len(f)}")
        f = np.where(np.isfinite(f), f, -np.inf)
        self._tracker.update(x, f)
        if self.pop_f is None:
            self.pop_f = f
        else:
            keep = f >= self.pop_f
            self.pop = np.where(keep[:, None], self._trials, self.pop)
            self.pop_f = np.where(keep, f, self.pop_f)
            self.generation += 1
        self._trials = None

    @property
    def spread(self) -> float:
        """max - min of the population's fitness (inf before the first tell)."""
        if self.pop_f is None:
            return np.inf
        return float(np.max(self.pop_f) - np.min(self.pop_f))

    def stop(self) -> str | None:
        """Why the search stopped, or None while it goes on."""
        c = self.config
        if self.generation >= c.max_generations:
            return f"max_generations ({c.max_generations})"
        if self.generation >= 1 and self.spread <= c.tol:
            return f"population fitness spread {self.spread:.3g} <= tol ({c.tol:g})"
        return None

    @property
    def result(self) -> SearchResult:
        """Best pose so far and the evolution of best and mean fitness."""
        return self._tracker.result(self.stop() or "running")
