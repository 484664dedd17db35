"""Local refinement after a global search: a (1, lambda) evolution strategy along camera rays.

The fitness is piecewise constant (nearest-pixel look-ups), so no gradients: each iteration
draws ``population`` poses around the best so far and keeps the best of them if it is
better. Steps are drawn in *ray coordinates* (x/z, y/z, z, eps1, eps2, eps3): a step in depth
keeps the garment's image position, which is the long, thin ridge of the stereo fitness that
a search over (x, y, z) walks slowly. The step sizes grow by ``grow`` after an improving
iteration and shrink by ``shrink`` otherwise (a success rule, as in the 1/5th rule); the
search stops when they fall below ``min_step_fraction`` of their start or after
``max_iterations``.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Self

import numpy as np
from numpy.typing import NDArray

from photomodel.search._base import Optimizer, SearchResult, _Tracker
from photomodel.search._space import SearchSpace

__all__ = ["GlobalThenLocal", "LocalRefine", "RefineConfig"]


@dataclass(frozen=True)
class RaySteps:
    """Start steps in ray coordinates (x/z, y/z, z, eps1, eps2, eps3) of a local search.

    Defaults: 1 mm sideways at 685 mm (``lateral_step = 0.0015`` in x/z and y/z), 4 mm in
    depth and 0.005 in eps (about 0.6 deg): the size of the errors a converged GA leaves.
    """

    lateral_step: float = 0.0015
    depth_step_mm: float = 4.0
    eps_step: float = 0.005

    @property
    def steps(self) -> NDArray[np.float64]:
        """The six start steps (6,), in ray coordinates."""
        return np.array([self.lateral_step, self.lateral_step, self.depth_step_mm,
                         self.eps_step, self.eps_step, self.eps_step])

    def scaled(self, factor: float) -> Self:
        """The start steps multiplied by ``factor`` (a pyramid level 2**k coarser)."""
        return replace(self, lateral_step=self.lateral_step * factor,
                       depth_step_mm=self.depth_step_mm * factor,
                       eps_step=self.eps_step * factor)


def start_tracker(space: SearchSpace, x0: NDArray[np.float64], f0: float) -> _Tracker:
    """A best-so-far tracker that starts at ``x0`` (clipped into ``space``) with ``f0``: a
    local search never returns worse than its start."""
    tracker = _Tracker()
    tracker.best_x = space.clip(np.asarray(x0, dtype=np.float64).reshape(6))
    tracker.best_f = float(f0)
    return tracker


@dataclass(frozen=True)
class RefineConfig(RaySteps):
    """Settings of :class:`LocalRefine`; the start steps are :class:`RaySteps`'."""

    population: int = 60
    grow: float = 1.3
    shrink: float = 0.7
    min_step_fraction: float = 0.03
    max_iterations: int = 200

    def __post_init__(self) -> None:
        if self.population < 1 or self.max_iterations < 1:
            raise ValueError("population and max_iterations must be >= 1")
        if not (0 < self.shrink < 1 <= self.grow) or not 0 < self.min_step_fraction < 1:
            raise ValueError("expected 0 < shrink < 1 <= grow and 0 < min_step_fraction < 1")


def _to_ray(x: NDArray[np.float64]) -> NDArray[np.float64]:
    r = np.array(x, dtype=np.float64)
    r[..., 0] = x[..., 0] / x[..., 2]
    r[..., 1] = x[..., 1] / x[..., 2]
    return r


def _from_ray(r: NDArray[np.float64]) -> NDArray[np.float64]:
    x = np.array(r, dtype=np.float64)
    x[..., 0] = r[..., 0] * r[..., 2]
    x[..., 1] = r[..., 1] * r[..., 2]
    return x


class LocalRefine:
    """Local search around a start pose behind the ask/tell interface."""

    def __init__(self, space: SearchSpace, x0: NDArray[np.float64], f0: float = -np.inf,
                 config: RefineConfig | None = None,
                 rng: int | np.random.Generator | None = None) -> None:
        self.space = space
        self.config = c = config or RefineConfig()
        self.rng = np.random.default_rng(rng)
        self._tracker = start_tracker(space, x0, f0)
        self._step0 = c.steps
        self.step = self._step0.copy()
        self.iteration = 0

    def ask(self) -> NDArray[np.float64]:
        """``population`` poses drawn around the best (ray coordinates, clipped to the box)."""
        assert self._tracker.best_x is not None
        centre = _to_ray(self._tracker.best_x)
        draws = self.rng.standard_normal((self.config.population, 6)) * self.step
        return self.space.clip(_from_ray(centre + draws))

    def tell(self, x: NDArray[np.float64], fitness: NDArray[np.float64]) -> None:
        """Keep the best if it improves; adapt the steps."""
        improved = self._tracker.update(x, fitness)
        self.step *= self.config.grow if improved else self.config.shrink
        self.step = np.minimum(self.step, self._step0 * 4)
        self.iteration += 1

    def stop(self) -> str | None:
        """Why the refinement stopped, or None."""
        if np.all(self.step < self._step0 * self.config.min_step_fraction):
            return "refined (steps converged)"
        if self.iteration >= self.config.max_iterations:
            return f"refine max_iterations ({self.config.max_iterations})"
        return None

    @property
    def result(self) -> SearchResult:
        """Best pose so far."""
        return self._tracker.result(self.stop() or "running")


class GlobalThenLocal:
    """Run a global optimiser to its stop, then :class:`LocalRefine` from its best pose."""

    def __init__(self, global_opt: Optimizer, space: SearchSpace,
                 config: RefineConfig | None = None,
                 rng: int | np.random.Generator | None = None) -> None:
        self.global_opt = global_opt
        self.space = space
        self.config = config
        self.rng = np.random.default_rng(rng)
        self.local: LocalRefine | None = None

    def _active(self) -> Optimizer:
        if self.local is None and self.global_opt.stop() is not None:
            g = self.global_opt.result
            self.local = LocalRefine(self.space, g.x, g.fitness, self.config, self.rng)
        return self.global_opt if self.local is None else self.local

    def ask(self) -> NDArray[np.float64]:
        """Candidates of the active stage."""
        return self._active().ask()

    def tell(self, x: NDArray[np.float64], fitness: NDArray[np.float64]) -> None:
        """Scores for the active stage."""
        self._active().tell(x, fitness)

    def stop(self) -> str | None:
        """The local stage's stop reason once it has stopped."""
        return self._active().stop() if self.local is not None else None

    @property
    def result(self) -> SearchResult:
        """Best pose with the histories of both stages concatenated."""
        g = self.global_opt.result
        if self.local is None:
            return g
        loc = self.local.result
        best = loc if loc.fitness >= g.fitness else g
        return SearchResult(
            best.x, best.fitness, g.evaluations + loc.evaluations,
            g.iterations + loc.iterations, f"{g.stop_reason}; then {loc.stop_reason}",
            np.concatenate([g.best_history, loc.best_history]),
            np.concatenate([g.mean_history, loc.mean_history]))
