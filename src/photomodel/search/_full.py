"""Full search (the paper's other named method): exhaustive grids over the search space.

Level 0 scans a regular grid over the whole space (``coarse_steps`` points per gene, the
"scan all possible" search of sec. 2.5). With ``levels > 1`` each further level scans a new
grid of ``fine_steps`` points per gene centred on the best pose so far and spanning +-1 grid
spacing of the level before, so the spacing halves each level (with 5 steps) and the result
reaches sub-millimetre resolution without a 6-D grid of that resolution. ``levels = 1`` is
the pure exhaustive grid.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from photomodel.search._base import SearchResult, _Tracker
from photomodel.search._space import SearchSpace

__all__ = ["FullSearch", "FullSearchConfig"]


@dataclass(frozen=True)
class FullSearchConfig:
    """Grid sizes per gene (x, y, z, eps1, eps2, eps3), levels and batch size.

    Default coarse grid: 16 mm in x and y, 100 mm in z, the tilt at the centre of its range,
    7.6 deg in the in-plane angle: 61,875 poses, every garment of 100 mm or more is overlapped
    by several. Five refinement levels of 5^6 poses bring the spacing to 0.5 mm.
    """

    coarse_steps: tuple[int, int, int, int, int, int] = (33, 25, 5, 1, 1, 15)
    fine_steps: tuple[int, int, int, int, int, int] = (5, 5, 5, 5, 5, 5)
    levels: int = 6
    batch_size: int = 8192

    def __post_init__(self) -> None:
        for key in ("coarse_steps", "fine_steps"):
            steps = getattr(self, key)
            if len(steps) != 6 or min(steps) < 1:
                raise ValueError(f"{key}: expected six counts >= 1, got {steps}")
        if self.levels < 1 or self.batch_size < 1:
            raise ValueError("levels and batch_size must be >= 1")


class FullSearch:
    """Exhaustive (multi-level) grid search behind the ask/tell interface."""

    def __init__(self, space: SearchSpace, config: FullSearchConfig | None = None,
                 rng: int | np.random.Generator | None = None) -> None:
        # rng is accepted for interface symmetry; the grid is deterministic.
        self.space = space
        self.config = config or FullSearchConfig()
        self._tracker = _Tracker()
        self.level = 0
        centre = (space.lower + space.upper) / 2
        self._start_level(centre, space.span / 2, self.config.coarse_steps)

    def _start_level(self, centre: NDArray[np.float64], half: NDArray[np.float64],
                     steps: tuple[int, ...]) -> None:
        axes = []
        spacing = np.zeros(6)
        for g in range(6):
            lo = max(centre[g] - half[g], self.space.lower[g])
            hi = min(centre[g] + half[g], self.space.upper[g])
            if steps[g] == 1:
                axes.append(np.array([(lo + hi) / 2]))
                spacing[g] = hi - lo
            else:
                axes.append(np.linspace(lo, hi, steps[g]))
                spacing[g] = (hi - lo) / (steps[g] - 1)
        self._axes = axes
        self._spacing = spacing
        self._n_grid = int(np.prod([len(a) for a in axes]))
        self._next = 0

    @property
    def grid_size(self) -> int:
        """Number of poses in the current level's grid."""
        return self._n_grid

    def ask(self) -> NDArray[np.float64]:
        """The next batch (<= batch_size, 6) of grid poses."""
        idx = np.arange(self._next, min(self._next + self.config.batch_size, self._n_grid))
        sub = np.unravel_index(idx, [len(a) for a in self._axes])
        return np.column_stack([self._axes[g][sub[g]] for g in range(6)])

    def tell(self, x: NDArray[np.float64], fitness: NDArray[np.float64]) -> None:
        """Record a batch; move to the next level when the grid is done."""
        self._tracker.update(x, fitness)
        self._next += len(np.asarray(fitness).reshape(-1))
        if self._next >= self._n_grid:
            self.level += 1
            if self.level < self.config.levels and self._tracker.best_x is not None:
                self._start_level(self._tracker.best_x, self._spacing, self.config.fine_steps)

    def stop(self) -> str | None:
        """'grid done' after the last level, else None."""
        return f"grid done ({self.config.levels} levels)" if self.level >= self.config.levels \
            else None

    @property
    def result(self) -> SearchResult:
        """Best grid pose so far."""
        return self._tracker.result(self.stop() or "running")
