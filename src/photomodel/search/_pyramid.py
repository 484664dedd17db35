"""Coarse-to-fine pose search for the ``soft`` fitness over a feature pyramid.

1. **Global** on the coarsest level, over (x, y, z, in-plane angle) with no tilt: the
   Gray-coded binary GA with restarts on the ``soft`` fitness with the garment's palette
   (``palette_weight``), whose peaks are as wide as the garment, not as a print's repeat.
2. **Hypotheses**: the best pose of every GA restart (and the overall best) is refined on
   the next level with the garment's own colours; the best of them goes on. The palette
   fitness can rank a wrong peak first (a print colour close to the table's), the finer
   level with own colours rarely does.
3. **Local** on each finer level down to level 0, over all six genes: the ray-coordinate
   evolution strategy of :class:`~photomodel.search.LocalRefine`, started from the previous
   level's best, its steps scaled to the level's pixel size.

Each level's fitness is cheap in proportion to its samples (about 4x fewer per level up).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import NDArray

from photomodel.search._base import SearchResult, run_search
from photomodel.search._ga import BinaryGA, GAConfig
from photomodel.search._refine import LocalRefine, RefineConfig
from photomodel.search._space import SearchSpace

__all__ = ["PyramidConfig", "pyramid_search"]


@dataclass(frozen=True)
class PyramidConfig:
    """Settings of :func:`pyramid_search`.

    Attributes
    ----------
    coarse_level : int
        Pyramid level of the global search (3 = 80 x 60 pixels for a 640 x 480 camera).
    palette_weight : float
        Palette weight of the global stage's fitness (see ``SoftFitness``).
    ga : GAConfig
        The global stage's GA.
    refine : RefineConfig
        Local stage at level 0; level k uses steps 2**k times larger.
    """

    coarse_level: int = 3
    palette_weight: float = 0.5
    ga: GAConfig = field(default_factory=lambda: GAConfig(patience=20, restarts=3))
    refine: RefineConfig = field(default_factory=lambda: RefineConfig(
        population=24, max_iterations=60, min_step_fraction=0.1))


FitnessAt = Callable[[int, float], Callable[[NDArray[np.float64]], NDArray[np.float64]]]


def pyramid_search(fitness_at: FitnessAt, space: SearchSpace, config: PyramidConfig | None = None,
                   rng: int | np.random.Generator | None = None) -> SearchResult:
    """Run the coarse-to-fine search.

    Parameters
    ----------
    fitness_at : callable
        ``fitness_at(level, palette_weight)`` returns the fitness of that pyramid level.
    space : SearchSpace
        Bounds of all stages; the global stage holds eps1 = eps2 = 0 (clipped into the box).
    config : PyramidConfig, optional
    rng : int, Generator or None

    Returns
    -------
    SearchResult
        The level-0 best, with the evaluations and histories of every stage.
    """
    c = config or PyramidConfig()
    gen = np.random.default_rng(rng)
    lo, hi = space.lower.copy(), space.upper.copy()
    flat = np.clip(0.0, lo[3:5], hi[3:5])
    lo[3:5] = flat
    hi[3:5] = flat
    ga = BinaryGA(SearchSpace(lo, hi), c.ga, rng=gen)
    stages = [run_search(ga, fitness_at(c.coarse_level, c.palette_weight))]
    # Each restart's best is a hypothesis; the next level (own colours, finer samples) decides.
    level = c.coarse_level - 1
    candidates = [_refine_at(fitness_at, level, x0, space, c.refine, gen)
                  for x0 in _distinct([stages[0].x, *ga.hypotheses()], space)]
    best = max(candidates, key=lambda r: r.fitness)
    stages.extend(candidates)
    x = best.x
    for level in range(c.coarse_level - 2, -1, -1):
        stages.append(_refine_at(fitness_at, level, x, space, c.refine, gen))
        x = stages[-1].x
    last = stages[-1]
    return SearchResult(
        last.x, last.fitness, sum(r.evaluations for r in stages),
        sum(r.iterations for r in stages), "; ".join(r.stop_reason for r in stages),
        np.concatenate([r.best_history for r in stages]),
        np.concatenate([r.mean_history for r in stages]))


def _refine_at(fitness_at: FitnessAt, level: int, x: NDArray[np.float64], space: SearchSpace,
               refine: RefineConfig, gen: np.random.Generator) -> SearchResult:
    """:class:`LocalRefine` on pyramid ``level`` from ``x``, steps scaled by 2**level."""
    s = 2.0**level
    cfg = replace(refine, lateral_step=refine.lateral_step * s,
                  depth_step_mm=refine.depth_step_mm * s, eps_step=refine.eps_step * s)
    objective = fitness_at(level, 0.0)
    f0 = float(objective(x[None])[0])
    return run_search(LocalRefine(space, x, f0, cfg, gen), objective)


def _distinct(xs: list[NDArray[np.float64]], space: SearchSpace,
              tolerance: float = 0.02) -> list[NDArray[np.float64]]:
    """``xs`` without near-repeats (every gene within ``tolerance`` of its range)."""
    kept: list[NDArray[np.float64]] = []
    span = np.where(space.span > 0, space.span, 1.0)
    for x in xs:
        if all(np.any(np.abs(x - k) / span > tolerance) for k in kept):
            kept.append(x)
    return kept
