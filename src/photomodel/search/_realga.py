"""A real-coded elitist GA in normalised coordinates of the search box.

Individuals are points of the unit cube [0, 1]^6 (``UnitBox``: gene ``g`` maps to
``lower[g] + span[g] * u``), so one step size fits millimetres and eps alike. One
generation:

* **Elitism**: the ``elite`` best individuals pass unchanged.
* **Selection**: tournament of ``tournament`` individuals drawn with replacement, as in
  :class:`~photomodel.search.BinaryGA`.
* **Crossover**: simulated binary crossover (SBX, Deb & Agrawal 1995) with distribution
  index ``sbx_eta``: with probability ``crossover_rate`` a pair of winners yields two
  children whose genes (each with probability 1/2) spread around the parents' with the
  spread of a one-point crossover of binary strings, more tightly for larger ``sbx_eta``.
  SBX keeps the children's mean at the parents' mean, so a converged population keeps
  refining finely; children outside the cube are mirrored back in.
* **Mutation**: each gene of each non-elite child gets, with probability
  ``mutation_rate``, a Gaussian step of standard deviation ``step`` (unit coordinates,
  mirrored at the faces). ``step`` starts at ``mutation_step`` and is multiplied by
  ``step_shrink`` each time the best fitness has not improved for ``shrink_patience``
  generations (down to ``min_step``), so a stagnating search turns from exploring to
  fine-tuning. Gains of at most ``min_improvement`` count as stagnation.
* **Restarts**: as in :class:`~photomodel.search.BinaryGA`: after ``patience`` generations
  without improvement, while restarts are left, a new uniform population is drawn and the
  step reset (the best pose stays in the result, not in the population).
* **Stop**: after ``max_generations``, or after ``patience`` generations without
  improvement and no restart left.

Started with ``x0``, the first population is ``x0`` and ``population - 1`` draws from a
normal distribution of spread ``sigma0`` around it, and the step starts at no more than
``sigma0``; restarts are global.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from photomodel.search._base import SearchResult, _Tracker, generation_stop
from photomodel.search._space import SearchSpace
from photomodel.search._unit import UnitBox, reflect

__all__ = ["RealGA", "RealGAConfig"]


@dataclass(frozen=True)
class RealGAConfig:
    """Settings of :class:`RealGA` (unit-cube coordinates; population as the paper's GA).

    A generation counts as an improvement when it raises the best fitness by more than
    ``min_improvement``; without that threshold the endless tiny gains on a smooth
    fitness would never let the step shrink or a restart happen. The default 1e-6 is far
    below any gain that matters for a pose score of order 1.
    """

    population: int = 60
    elite: int = 2
    tournament: int = 3
    crossover_rate: float = 0.9
    sbx_eta: float = 15.0
    mutation_rate: float = 1.0 / 6.0
    mutation_step: float = 0.1
    step_shrink: float = 0.5
    shrink_patience: int = 10
    min_step: float = 1e-6
    max_generations: int = 800
    patience: int = 60
    restarts: int = 4
    min_improvement: float = 1e-6

    def __post_init__(self) -> None:
        if self.population < 2 or not 0 <= self.elite < self.population:
            raise ValueError(f"population/elite: expected population >= 2 and "
                             f"0 <= elite < population, got {self.population}, {self.elite}")
        if self.tournament < 1:
            raise ValueError(f"tournament: expected >= 1, got {self.tournament}")
        for key in ("crossover_rate", "mutation_rate"):
            if not 0 <= getattr(self, key) <= 1:
                raise ValueError(f"{key}: expected a probability, got {getattr(self, key)}")
        if not self.sbx_eta >= 0:
            raise ValueError(f"sbx_eta: expected >= 0, got {self.sbx_eta}")
        if not 0 < self.min_step <= self.mutation_step:
            raise ValueError(f"mutation_step/min_step: expected 0 < min_step <= mutation_step, "
                             f"got {self.mutation_step}, {self.min_step}")
        if not self.min_improvement >= 0:
            raise ValueError(f"min_improvement: expected >= 0, got {self.min_improvement}")
        if not 0 < self.step_shrink <= 1:
            raise ValueError(f"step_shrink: expected in (0, 1], got {self.step_shrink}")
        if (self.max_generations < 1 or self.patience < 1 or self.shrink_patience < 1
                or self.restarts < 0):
            raise ValueError("max_generations, patience and shrink_patience must be >= 1, "
                             "restarts >= 0")


class RealGA:
    """Real-coded GA behind the ask/tell interface (see the module docstring).

    Parameters
    ----------
    space : SearchSpace
    config : RealGAConfig, optional
    rng : int, Generator or None
        Seed or generator; the same seed gives the same search.
    x0 : array_like (6,), optional
        Start pose (x, y, z mm, eps1, eps2, eps3): the first population lies around it.
    sigma0 : array_like (6,), optional
        Spread of the first population around ``x0`` per gene (mm, eps); default a tenth
        of each gene's range.
    """

    def __init__(self, space: SearchSpace, config: RealGAConfig | None = None,
                 rng: int | np.random.Generator | None = None,
                 x0: ArrayLike | None = None, sigma0: ArrayLike | None = None) -> None:
        self.space = space
        self.config = c = config or RealGAConfig()
        self.rng = np.random.default_rng(rng)
        self.unit = UnitBox(space)
        self.pop, s0 = self.unit.initial_population(self.rng, c.population, x0, sigma0)
        self.step = np.full(6, c.mutation_step)
        if s0 is not None:
            self.step = np.minimum(self.step, s0)
        self._tracker = _Tracker()
        self._since_improvement = 0
        self.generation = 0
        self.restarts_done = 0

    def ask(self) -> NDArray[np.float64]:
        """The current population's pose vectors (population, 6)."""
        return self.unit.from_unit(self.pop)

    def _sbx(self, a: NDArray[np.float64], b: NDArray[np.float64]
             ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Two children per parent pair (n, 6) by simulated binary crossover."""
        c = self.config
        r = self.rng.random(a.shape)
        beta = np.where(r <= 0.5, (2 * r) ** (1 / (c.sbx_eta + 1)),
                        (1 / (2 * (1 - r))) ** (1 / (c.sbx_eta + 1)))
        cross = ((self.rng.random(len(a)) < c.crossover_rate)[:, None]
                 & (self.rng.random(a.shape) < 0.5))
        beta = np.where(cross, beta, 1.0)
        mid, half = (a + b) / 2, (a - b) / 2
        return mid + beta * half, mid - beta * half

    def tell(self, x: NDArray[np.float64], fitness: NDArray[np.float64]) -> None:
        """Score the population returned by the last ``ask`` and breed the next one."""
        c = self.config
        f = np.asarray(fitness, dtype=np.float64).reshape(-1)
        if len(f) != c.population:
            raise ValueError(f"tell: expected {c.population} fitness values, got {len(f)}")
        f = np.where(np.isfinite(f), f, -np.inf)
        best_before = self._tracker.best_f
        self._tracker.update(x, f)
        improved = self._tracker.best_f > best_before + c.min_improvement
        self._since_improvement = 0 if improved else self._since_improvement + 1
        self.generation += 1
        if self._since_improvement and self._since_improvement % c.shrink_patience == 0:
            self.step = np.maximum(self.step * c.step_shrink, c.min_step)

        order = np.argsort(-f, kind="stable")
        elite = self.pop[order[: c.elite]]
        n_children = c.population - c.elite
        n_pairs = (n_children + 1) // 2
        contestants = self.rng.integers(0, c.population, size=(2 * n_pairs, c.tournament))
        winners = contestants[np.arange(len(contestants)), np.argmax(f[contestants], axis=1)]
        parents = self.pop[winners]
        first, second = self._sbx(parents[:n_pairs], parents[n_pairs:])
        children = np.concatenate([first, second])[:n_children]
        mutate = self.rng.random(children.shape) < c.mutation_rate
        children = children + mutate * self.step * self.rng.standard_normal(children.shape)
        self.pop = np.concatenate([elite, reflect(children)])
        if self._since_improvement >= c.patience and self.restarts_done < c.restarts:
            self.restarts_done += 1
            self._since_improvement = 0
            self.pop = self.rng.random(self.pop.shape)
            self.step = np.full(6, c.mutation_step)

    def stop(self) -> str | None:
        """Why the search stopped, or None while it goes on."""
        return generation_stop(self.generation, self._since_improvement,
                               self.config.max_generations, self.config.patience)

    @property
    def result(self) -> SearchResult:
        """Best pose so far and the evolution of best and mean fitness."""
        return self._tracker.result(self.stop() or "running")
