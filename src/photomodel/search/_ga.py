"""The paper's binary genetic algorithm (sec. 2.5): 60 individuals, 6 genes x 12 bits.

Chromosome: 72 bits, genes in the order (x, y, z, eps1, eps2, eps3), the first 36 bits the
position and the last 36 the orientation, as in the paper. Gene ``g`` with integer value
``k`` in [0, 4095] (most significant bit first) decodes to
``lower[g] + (upper[g] - lower[g]) * k / 4095``. With ``gray=True`` the 12 bits are a
reflected Gray code of ``k`` (neighbouring values differ by one bit), still a binary
chromosome.

One generation, the operators the paper leaves open:

* **Elitism**: the ``elite`` best individuals pass unchanged (the best is never lost).
* **Selection**: tournament of ``tournament`` individuals drawn with replacement; the
  fitter wins. Works with negative fitness (unlike roulette) and keeps a steady pressure.
* **Crossover** (single-point): each child is a tournament winner; with probability
  ``crossover_rate`` its bits after a cut point drawn uniformly in 1..71 come from the next
  winner.
* **Mutation**: every bit of every non-elite child flips with probability ``mutation_rate``
  (default 1/72: on average one bit per chromosome).
* **Restarts**: when the best fitness has not improved for ``patience`` generations and
  restarts are left, the whole population is drawn anew (the best pose found so far is kept
  in the result, not in the population, which would pull the new one back to the same peak
  within a few generations). The plaid fabrics' repeating pattern makes local peaks one
  pattern repeat away from the true pose; independent restarts escape them.
* **Stop**: after ``max_generations`` or when the best fitness has not improved (by more
  than ``min_improvement``) for ``patience`` generations and no restart is left.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from photomodel.search._base import SearchResult, _Tracker, generation_stop
from photomodel.search._space import SearchSpace

__all__ = ["BinaryGA", "GAConfig"]


@dataclass(frozen=True)
class GAConfig:
    """Settings of :class:`BinaryGA` (paper: 60 individuals, 6 genes of 12 bits).

    The defaults add Gray coding (no Hamming cliffs between neighbouring values) and four
    independent restarts (out of a print's repeated peaks) to the paper's GA
    (docs/method/paper.md). :meth:`paper` gives the paper's GA as read here.
    """

    population: int = 60
    bits_per_gene: int = 12
    elite: int = 2
    tournament: int = 3
    crossover_rate: float = 0.9
    mutation_rate: float = 1.0 / 72.0
    max_generations: int = 800
    patience: int = 60
    restarts: int = 4
    min_improvement: float = 0.0
    """A generation counts as an improvement (for ``patience``) only when it raises the best
    fitness by more than this; 0 = any rise. A coarse stage whose result is refined anyway
    need not spend generations on the last thousandths."""
    gray: bool = True

    @classmethod
    def paper(cls, **overrides: object) -> GAConfig:
        """The paper's GA: plain binary coding, no restarts (other fields as given)."""
        return cls(**{"gray": False, "restarts": 0, **overrides})  # type: ignore[arg-type]

    def __post_init__(self) -> None:
        if self.population < 2 or not 0 <= self.elite < self.population:
            raise ValueError(f"population/elite: expected population >= 2 and "
                             f"0 <= elite < population, got {self.population}, {self.elite}")
        if not 1 <= self.bits_per_gene <= 30:
            raise ValueError(f"bits_per_gene: expected 1..30, got {self.bits_per_gene}")
        if self.tournament < 1:
            raise ValueError(f"tournament: expected >= 1, got {self.tournament}")
        for key in ("crossover_rate", "mutation_rate"):
            if not 0 <= getattr(self, key) <= 1:
                raise ValueError(f"{key}: expected a probability, got {getattr(self, key)}")
        if self.max_generations < 1 or self.patience < 1 or self.restarts < 0:
            raise ValueError("max_generations and patience must be >= 1, restarts >= 0")
        if not self.min_improvement >= 0:
            raise ValueError(f"min_improvement: expected >= 0, got {self.min_improvement}")


class BinaryGA:
    """Binary-coded GA behind the ask/tell interface (see the module docstring).

    Parameters
    ----------
    space : SearchSpace
    config : GAConfig, optional
    rng : int, Generator or None
        Seed or generator; the same seed gives the same search.
    """

    def __init__(self, space: SearchSpace, config: GAConfig | None = None,
                 rng: int | np.random.Generator | None = None) -> None:
        self.space = space
        self.config = config or GAConfig()
        self.rng = np.random.default_rng(rng)
        c = self.config
        self.n_bits = 6 * c.bits_per_gene
        self.bits = self.rng.integers(0, 2, size=(c.population, self.n_bits), dtype=np.uint8)
        self._weights = (1 << np.arange(c.bits_per_gene - 1, -1, -1)).astype(np.int64)
        self._tracker = _Tracker()
        self._since_improvement = 0
        self.generation = 0
        self.restarts_done = 0
        self._epoch_best: tuple[float, NDArray[np.float64] | None] = (-np.inf, None)
        self.epoch_bests: list[tuple[float, NDArray[np.float64]]] = []
        """Best (fitness, pose) of each finished run between restarts."""

    def decode(self, bits: NDArray[np.uint8]) -> NDArray[np.float64]:
        """Pose vectors (P, 6) of chromosomes (P, 72)."""
        c = self.config
        genes = bits.reshape(len(bits), 6, c.bits_per_gene).astype(np.int64)
        if c.gray:  # Gray -> binary: b_i = xor of g_0..g_i
            genes = np.bitwise_xor.accumulate(genes, axis=2)
        k = genes @ self._weights
        return self.space.lower + self.space.span * (k / float((1 << c.bits_per_gene) - 1))

    def ask(self) -> NDArray[np.float64]:
        """The current population's pose vectors (population, 6)."""
        return self.decode(self.bits)

    def tell(self, x: NDArray[np.float64], fitness: NDArray[np.float64]) -> None:
        """Score the population returned by the last ``ask`` and breed the next one."""
        c = self.config
        f = np.asarray(fitness, dtype=np.float64).reshape(-1)
        if len(f) != c.population:
            raise ValueError(f"tell: expected {c.population} fitness values, got {len(f)}")
        f = np.where(np.isfinite(f), f, -np.inf)
        previous = self._tracker.best_f
        self._tracker.update(x, f)
        improved = bool(np.max(f) > previous + c.min_improvement)
        i_best = int(np.argmax(f))
        if f[i_best] > self._epoch_best[0]:
            self._epoch_best = (float(f[i_best]), np.array(x[i_best], dtype=np.float64))
        self._since_improvement = 0 if improved else self._since_improvement + 1
        self.generation += 1

        order = np.argsort(-f, kind="stable")
        elite = self.bits[order[: c.elite]]
        n_children = c.population - c.elite
        contestants = self.rng.integers(0, c.population, size=(n_children + 1, c.tournament))
        winners = contestants[np.arange(len(contestants)),
                              np.argmax(f[contestants], axis=1)]
        parents = self.bits[winners]
        children = parents[:n_children].copy()
        partners = parents[1 : n_children + 1]
        do_cross = self.rng.random(n_children) < c.crossover_rate
        cuts = self.rng.integers(1, self.n_bits, size=n_children)
        after_cut = np.arange(self.n_bits)[None, :] >= cuts[:, None]
        swap = do_cross[:, None] & after_cut
        children[swap] = partners[swap]
        flips = self.rng.random(children.shape) < c.mutation_rate
        children ^= flips.astype(np.uint8)
        self.bits = np.concatenate([elite, children])
        if self._since_improvement >= c.patience and self.restarts_done < c.restarts:
            self.restarts_done += 1
            self._since_improvement = 0
            self._close_epoch()
            self.bits = self.rng.integers(0, 2, size=self.bits.shape, dtype=np.uint8)

    def _close_epoch(self) -> None:
        if self._epoch_best[1] is not None:
            self.epoch_bests.append((self._epoch_best[0], self._epoch_best[1]))
        self._epoch_best = (-np.inf, None)

    def hypotheses(self) -> list[NDArray[np.float64]]:
        """The best pose of every run (first to last restart), each a local peak to check."""
        xs = [x for _, x in self.epoch_bests]
        if self._epoch_best[1] is not None:
            xs.append(self._epoch_best[1])
        return xs

    def stop(self) -> str | None:
        """Why the search stopped, or None while it goes on."""
        return generation_stop(self.generation, self._since_improvement,
                               self.config.max_generations, self.config.patience)

    @property
    def result(self) -> SearchResult:
        """Best pose so far and the evolution of best and mean fitness."""
        return self._tracker.result(self.stop() or "running")
