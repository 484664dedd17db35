"""Local refinement by damped Gauss-Newton on the colour residuals (Levenberg-Marquardt).

The ``soft`` fitness is a sum of Gaussian agreements ``a_j = exp(-|r_j|^2 / 2)`` of scaled
colour residuals ``r_j``: ``F = mean over cameras of (sum_in w_in a_j - sum_band w_out a_j) +
terms of the light offsets``. At a map of model points it gives its normal equations
(:meth:`NormalEquationsFitness.normal_equations`): the fitness's gradient ``g`` along the free
genes (the light offsets' own motion with the pose included) and the inner points' robust
Gauss-Newton matrix ``H = sum_in s_j a_j J_j^T J_j`` (``s_j`` the point's weight, ``J_j`` the
residual's analytic Jacobian: the Welsch M-estimator's iteratively reweighted least squares).
Each iteration takes the step ``(H + lambda diag H)^-1 g`` and keeps it when the fitness
rises, taken further where the fitness along it still climbs
(``GaussNewtonConfig.extrapolation``); else ``lambda`` grows and the step shrinks towards the
gradient. Where no step is accepted, the gradient comes from the fitness's own forward
differences (``GaussNewtonConfig.difference_steps``) for the rest of the refinement, and a
stall after that is a peak.

Genes: the pose vector (x, y, z in mm, camera 1's frame; eps1, eps2, eps3) and, with a start
strain, the model's in-plane strain ``(e_xx, e_yy, e_xy)``
(:func:`~photomodel.geometry.strained_matrices`), held back by a prior
(``GaussNewtonConfig.strain_weights``): wrinkled cloth lies shorter than its photo.

A fitness with numba kernels (:class:`~photomodel.fitness.KernelNormalEquations`, the ``soft``
fitness) is refined in one compiled loop (:mod:`._gauss_newton_loop`), any other by the same
iterations in Python here; the two give the same result to the bit. The basin is a few pixels
wide: coarse levels, where a hypothesis starts tens of millimetres away, use
:class:`~photomodel.search.LocalRefine`.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol, runtime_checkable

import numba
import numpy as np
from numpy.typing import ArrayLike, NDArray

from photomodel.fitness import KernelNormalEquations
from photomodel.geometry import pose_vectors_to_matrices, strained_matrices
from photomodel.search._base import SearchResult, conforms
from photomodel.search._gauss_newton_loop import (
    CONVERGED,
    NO_ASCENT_CODE,
    add_prior,
    clip_genes,
    damped_step,
    gauss_newton_loop,
    prior_values,
    slope_along,
)
from photomodel.search._gauss_newton_loop import extrapolation as _extrapolation
from photomodel.search._gauss_newton_loop import map_derivatives as _map_derivatives
from photomodel.search._space import SearchSpace

__all__ = ["NO_ASCENT", "GaussNewtonConfig", "NormalEquationsFitness", "TransformFitness",
           "gauss_newton_refine", "out_of_iterations"]

NO_ASCENT = "gauss-newton: no ascent step"
"""Stop reason of a refinement that accepted no step where it stopped (a kink or a peak)."""


@runtime_checkable
class TransformFitness(Protocol):
    """A fitness of pose vectors (P, 6) that also evaluates maps of model points into camera 1
    (P, 4, 4) and gives the light offsets (P, 2, 3) it found at the last poses
    (``SoftFitness``)."""

    def __call__(self, poses: NDArray[np.float64]) -> NDArray[np.float64]: ...

    def evaluate_transforms(self, T_cam1_model: NDArray[np.float64]
                            ) -> NDArray[np.float64]: ...

    def last_offsets(self) -> NDArray[np.float64]: ...


@runtime_checkable
class NormalEquationsFitness(TransformFitness, Protocol):
    """A :class:`TransformFitness` that also gives its normal equations from the residuals'
    analytic Jacobian (``SoftFitness.normal_equations``): at map ``A_cam1_model`` (4, 4)
    with its derivatives ``dA`` (G, 4, 4) along G genes and light offsets (2, 3), the
    gradient (G,) and the metric (G, G)."""

    def normal_equations(self, A_cam1_model: NDArray[np.float64], dA: NDArray[np.float64],
                         offsets: NDArray[np.float64], with_offsets: bool = False
                         ) -> tuple[NDArray[np.float64], NDArray[np.float64]]: ...


@dataclass(frozen=True)
class GaussNewtonConfig:
    """Settings of :func:`gauss_newton_refine` (level-0 values; level k scales the
    difference steps by 2**k).

    Attributes
    ----------
    difference_steps : tuple of float
        The unit step of each pose gene (x, y, z mm, eps1, eps2, eps3) for the stop rules and
        the fitness's own forward differences: 0.02 mm sideways and 2e-5 in eps are about a
        fortieth of a pixel at 685 mm; 0.1 mm in depth moves the outline of a 200 mm garment
        about as much.
    max_iterations : int
        Accepted steps at most.
    converged_steps : float
        Stop after an accepted step no larger than this many difference steps in any gene.
    min_gain : float
        Also stop after ``min_gain_steps`` accepted steps in a row that each raised the
        fitness by less than this (0: never).
    min_gain_per_level : float
        ``min_gain`` is multiplied by this for each pyramid level above 0: level 0 refines
        what level 1 leaves.
    min_gain_steps : int
        The accepted steps in a row that must each gain less than ``min_gain`` to stop.
    damping0 : float
        Start value of ``lambda``.
    max_damping : float
        Stop when no step is accepted up to this ``lambda`` (the start is a peak).
    rejected_damping : float
        After a rejected step ``lambda`` grows to at least this: below it the damped step is
        nearly the Gauss-Newton step, and trying it again wastes an evaluation.
    min_step : float
        A rejected step no larger than this many difference steps in any gene counts as
        ``max_damping`` reached (it moves the samples by less than a hundredth of a pixel).
    strain_step : float
        The unit step of the strain genes (1e-4: 0.01 mm on a 100 mm half-width).
    max_strain : float
        Largest strain component a refinement with strain may reach.
    strain_weights : (float, float)
        Prior on the strain: the refinement maximises the fitness less ``w_mean * m^2 +
        w_shape * (d^2 + e_xy^2)``, with the mean strain ``m = (e_xx + e_yy) / 2`` and ``d =
        (e_xx - e_yy) / 2`` (the result's fitness is the fitness itself). Where part of the
        outline is hidden, a strain that shrinks the model away from the hidden end costs the
        fitness nothing; the prior keeps the pose from walking with it.
    extrapolation : float
        After an accepted step, the parabola through the fitness at the start, its slope
        along the step (the gradient's) and its value one step on is fitted; where it peaks
        beyond 1.5 steps the step is taken that far (at most this many steps: one more
        evaluation), and kept when it rises further (1: never). The inner points' metric is
        steeper than the fitness, so the steps fall short.
    """

    def strain_prior(self) -> NDArray[np.float64]:
        """The prior's matrix (3, 3) ``W``: the penalty is ``strain^T W strain``."""
        mean, shape = self.strain_weights
        m, d = np.array([0.5, 0.5, 0.0]), np.array([0.5, -0.5, 0.0])
        return mean * np.outer(m, m) + shape * (np.outer(d, d) + np.diag([0.0, 0.0, 1.0]))

    difference_steps: tuple[float, ...] = (0.02, 0.02, 0.1, 2e-5, 2e-5, 2e-5)
    max_iterations: int = 40
    converged_steps: float = 2.5
    min_gain: float = 1e-5
    min_gain_per_level: float = 10.0
    min_gain_steps: int = 1
    damping0: float = 1e-3
    max_damping: float = 1e4
    rejected_damping: float = 0.25
    min_step: float = 0.5
    strain_step: float = 1e-4
    max_strain: float = 0.1
    strain_weights: tuple[float, float] = (10.0, 30.0)
    extrapolation: float = 4.0

    def __post_init__(self) -> None:
        if len(self.difference_steps) != 6 or min(self.difference_steps) <= 0:
            raise ValueError("difference_steps: expected six positive steps")
        if self.max_iterations < 1 or not 0 < self.damping0 < self.max_damping:
            raise ValueError("expected max_iterations >= 1 and 0 < damping0 < max_damping")
        if not (self.min_gain >= 0 and self.rejected_damping >= 0 and self.min_step >= 0
                and self.min_gain_steps >= 1 and self.min_gain_per_level >= 1):
            raise ValueError("expected min_gain, rejected_damping and min_step >= 0, "
                             "min_gain_steps >= 1 and min_gain_per_level >= 1")
        if not (self.strain_step > 0 and 0 < self.max_strain < 1
                and min(self.strain_weights) >= 0):
            raise ValueError("expected strain_step > 0, 0 < max_strain < 1, strain_weights >= 0")
        if not self.extrapolation >= 1.0:
            raise ValueError(f"extrapolation: expected >= 1, got {self.extrapolation}")


def gauss_newton_refine(fitness: NormalEquationsFitness, x0: NDArray[np.float64],
                        space: SearchSpace, level: int = 0,
                        config: GaussNewtonConfig | None = None,
                        free: NDArray[np.bool_] | None = None,
                        strain: ArrayLike | None = None,
                        start: tuple[float, NDArray[np.float64]] | None = None
                        ) -> SearchResult:
    """Refine pose ``x0`` (6,) to the nearest peak of ``fitness`` (see the module docstring).

    Parameters
    ----------
    fitness : NormalEquationsFitness
        One pyramid level's fitness.
    x0 : ndarray (6,)
        Start pose vector (clipped into ``space``).
    space : SearchSpace
        Steps are clipped into it.
    level : int
        Pyramid level of ``fitness`` (scales the difference steps by 2**level).
    config : GaussNewtonConfig, optional
    free : ndarray (6,) of bool, optional
        Genes that move (default: all).
    strain : array (3,), optional
        Start in-plane strain of the model (:func:`~photomodel.geometry.strained_matrices`):
        when given, the strain is refined with the pose (three more genes, within
        ``config.max_strain``) and returned in the result's ``strain``.
    start : (float, ndarray (2, 3)), optional
        The fitness at ``x0`` (with ``strain``) and the light offsets it found there, when
        the caller evaluated it: the refinement starts from them instead of evaluating
        ``x0`` again. Ignored where ``x0`` or ``strain`` lies outside the box (the start is
        clipped, so it is another pose).

    Returns
    -------
    SearchResult
        The last accepted pose, never worse than the start. ``evaluations`` counts every pose
        evaluated, the normal equations included; ``iterations`` the accepted steps.
    """
    if not conforms(fitness, NormalEquationsFitness):
        raise TypeError("gauss_newton_refine: expected a fitness with normal equations "
                        "(NormalEquationsFitness, e.g. SoftFitness)")
    c = config or GaussNewtonConfig()
    x0_given = np.asarray(x0, dtype=np.float64).reshape(6)
    strain_given = None if strain is None else np.asarray(strain, dtype=np.float64).reshape(3)
    genes = _Genes.start(x0_given, strain_given, free, space, level, c)
    if start is not None and not (np.array_equal(genes.x[:6], x0_given)
                                  and (not genes.strained
                                       or np.array_equal(genes.x[6:], strain_given))):
        start = None     # clipped: another pose than the one evaluated
    if conforms(fitness, KernelNormalEquations):
        return _refine_in_kernel(fitness, genes.x, genes.free, genes.h, space, genes.prior,
                                 level, c, start)
    return _PythonRefinement(fitness, genes, space, level, c, start).run()


@dataclass(frozen=True)
class _Genes:
    """The genes of one refinement: the clipped start ``x`` (G,) (G = 6, or 9 with the
    strain), their unit steps ``h`` (G,) (mm, eps, strain), which move (``free``, (G,) bool)
    and the strain's prior ``prior`` (G, G) (the penalty is ``x^T prior x``)."""

    x: NDArray[np.float64]
    h: NDArray[np.float64]
    free: NDArray[np.bool_]
    prior: NDArray[np.float64]

    @property
    def strained(self) -> bool:
        """Whether the strain is refined with the pose (nine genes)."""
        return len(self.x) > 6

    @classmethod
    def start(cls, x0: NDArray[np.float64], strain: NDArray[np.float64] | None,
              free: NDArray[np.bool_] | None, space: SearchSpace, level: int,
              c: GaussNewtonConfig) -> _Genes:
        """The genes from pose vector ``x0`` (6,) and ``strain`` (3,) or None, both clipped
        (into ``space``, within ``c.max_strain``); the difference steps of pyramid
        ``level``; ``free`` (6,) or None (all) with the strain's genes free."""
        free = np.ones(6, dtype=bool) if free is None else np.asarray(free, dtype=bool)
        x = space.clip(x0)
        h = np.asarray(c.difference_steps) * 2.0**level
        if strain is not None:
            x = np.concatenate([x, np.clip(strain, -c.max_strain, c.max_strain)])
            h = np.concatenate([h, np.full(3, c.strain_step * 2.0**level)])
            free = np.concatenate([free, np.ones(3, dtype=bool)])
        prior = np.zeros((len(x), len(x)))
        if strain is not None:
            prior[6:, 6:] = c.strain_prior()
        return cls(x, h, free, prior)


class _PythonRefinement:
    """:func:`gauss_newton_refine`'s iterations in Python, for a fitness without numba
    kernels: the state of one refinement (the genes ``x`` (G,) and their fitness ``f`` less
    the strain's prior, the light offsets (2, 3) found there, ``lambda``, the evaluations)
    and its stages. Each stage repeats :func:`._gauss_newton_loop.gauss_newton_loop`'s to
    the bit."""

    def __init__(self, fitness: NormalEquationsFitness, genes: _Genes, space: SearchSpace,
                 level: int, c: GaussNewtonConfig,
                 start: tuple[float, NDArray[np.float64]] | None) -> None:
        self.fitness, self.genes, self.space, self.c = fitness, genes, space, c
        self.x = genes.x
        if start is None:
            self.f = self.value(self.x)
            self.offsets = fitness.last_offsets()
            self.evaluations = 1
        else:
            self.f = start[0] - float(prior_values(self.x[None], genes.prior)[0])
            self.offsets = np.array(start[1], dtype=np.float64).reshape(2, 3)
            self.evaluations = 0
        self.history = [self.f]
        self.damping = c.damping0
        self.differenced = False     # the gradient from the fitness's own differences
        self.small_gains = 0     # accepted steps in a row that gained less than min_gain
        self.min_gain = c.min_gain * c.min_gain_per_level**level

    def run(self) -> SearchResult:
        """Damped steps until converged, out of iterations or no step is accepted."""
        reason = out_of_iterations(self.c)
        for _ in range(self.c.max_iterations):
            candidate, candidate_value, step = self._damped_step(*self._normal_equations())
            if candidate_value <= self.f:
                reason = NO_ASCENT
                break
            if self._accept(candidate, candidate_value, step):
                reason = "gauss-newton: converged"
                break
        trace = np.asarray(self.history)
        f = self.f + float(prior_values(self.x[None], self.genes.prior)[0])  # the fitness itself
        return SearchResult(self.x[:6], f, self.evaluations, len(self.history) - 1, reason,
                            trace, trace,
                            strain=self.x[6:].copy() if self.genes.strained else None)

    def transforms(self, poses: NDArray[np.float64]) -> NDArray[np.float64]:
        """Maps (P, 4, 4) of model points into camera 1 of gene vectors (P, G)."""
        if self.genes.strained:
            return strained_matrices(poses[:, :6], poses[:, 6:])
        return pose_vectors_to_matrices(poses)

    def values(self, v: NDArray[np.float64]) -> NDArray[np.float64]:
        """The fitness (P,) of gene vectors ``v`` (P, G), less the strain's prior."""
        return (self.fitness.evaluate_transforms(self.transforms(v))
                - prior_values(v, self.genes.prior))

    def value(self, v: NDArray[np.float64]) -> float:
        """The fitness of one gene vector ``v`` (G,), less the strain's prior."""
        return float(self.values(v[None])[0])

    def _normal_equations(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """The gradient (k,) and metric (k, k) over the k free genes at ``x``, the prior's
        terms added; the gradient from the fitness's own differences once differenced."""
        g = self.genes
        gradient, metric = self.fitness.normal_equations(
            self.transforms(self.x[None])[0], _map_derivatives(self.x, g.free), self.offsets,
            with_offsets=True)
        self.evaluations += 1
        if g.strained:
            add_prior(gradient, metric, g.prior, self.x, g.free)
        if self.differenced:
            gradient = self._differences()
        return gradient, metric

    def _differences(self) -> NDArray[np.float64]:
        """The gradient (k,) from the fitness's own forward differences at ``x``."""
        self.evaluations += len(self.x)
        return _fitness_gradient(self.values, self.x, self.f, self.genes.h, self.genes.free)

    def _damped_step(self, gradient: NDArray[np.float64], metric: NDArray[np.float64]
                     ) -> tuple[NDArray[np.float64], float, NDArray[np.float64]]:
        """The first damped step (G,) from ``x`` that raises the fitness, ``lambda`` growing
        after each rejected one (and the fitness's own gradient taken where ``lambda`` runs
        out), as ``(candidate (G,), its value, step (G,))``; the last rejected one when none
        does."""
        c, g = self.c, self.genes
        step = np.zeros(len(self.x))
        while True:
            step[g.free] = damped_step(metric, self.damping, gradient)
            candidate = clip_genes(self.x + step, self.space.lower, self.space.upper,
                                   c.max_strain)
            candidate_value = self.value(candidate)
            self.evaluations += 1
            if candidate_value > self.f:
                self.damping = max(self.damping / 3.0, 1e-4)
                self.offsets = self.fitness.last_offsets()
                return self._extrapolate(candidate, candidate_value, step, gradient)
            self.damping = max(4.0 * self.damping, c.rejected_damping)
            if self.damping > c.max_damping or np.all(np.abs(step) <= c.min_step * g.h):
                if self.differenced:
                    return candidate, candidate_value, step
                self.differenced, self.damping = True, c.damping0
                gradient = self._differences()

    def _extrapolate(self, candidate: NDArray[np.float64], candidate_value: float,
                     step: NDArray[np.float64], gradient: NDArray[np.float64]
                     ) -> tuple[NDArray[np.float64], float, NDArray[np.float64]]:
        """The accepted step taken further where the fitness along it still climbs
        (``GaussNewtonConfig.extrapolation``): ``(candidate (G,), its value, step (G,))``."""
        alpha = _extrapolation(self.f, candidate_value,
                               slope_along(gradient, step, self.genes.free),
                               self.c.extrapolation)
        if alpha > 1.0:
            further = clip_genes(self.x + alpha * step, self.space.lower, self.space.upper,
                                 self.c.max_strain)
            further_value = self.value(further)
            self.evaluations += 1
            if further_value > candidate_value:
                self.offsets = self.fitness.last_offsets()
                return further, further_value, further - self.x
        return candidate, candidate_value, step

    def _accept(self, candidate: NDArray[np.float64], candidate_value: float,
                step: NDArray[np.float64]) -> bool:
        """Move to ``candidate`` (G,); whether the refinement converged (a short step, or
        ``min_gain_steps`` small gains in a row)."""
        c = self.c
        self.small_gains = self.small_gains + 1 if candidate_value - self.f < self.min_gain else 0
        self.x, self.f = candidate, candidate_value
        self.history.append(self.f)
        return bool(np.all(np.abs(step) <= c.converged_steps * self.genes.h)
                    or self.small_gains >= c.min_gain_steps)


def _refine_in_kernel(fitness: KernelNormalEquations, x: NDArray[np.float64],
                      free: NDArray[np.bool_], h: NDArray[np.float64], space: SearchSpace,
                      prior: NDArray[np.float64], level: int, c: GaussNewtonConfig,
                      start: tuple[float, NDArray[np.float64]] | None = None
                      ) -> SearchResult:
    """The refinement's iterations in numba (:mod:`._gauss_newton_loop`) from genes ``x``
    (clipped; nine with the strain), where the fitness and offsets are ``start`` when
    known."""
    f_start, offsets_start = (np.nan, np.zeros((2, 3))) if start is None else start
    x, f, evaluations, trace, code, raw, offsets = gauss_newton_loop(
        numba.get_num_threads(), fitness.kernel_args(), fitness.normal_args(), x, free, h,
        np.ascontiguousarray(space.lower, dtype=np.float64),
        np.ascontiguousarray(space.upper, dtype=np.float64), c.max_strain, prior,
        c.max_iterations, c.converged_steps, c.min_gain * c.min_gain_per_level**level,
        c.min_gain_steps, c.damping0, c.max_damping, c.rejected_damping, c.min_step,
        c.extrapolation, float(f_start),
        np.ascontiguousarray(offsets_start, dtype=np.float64).reshape(2, 3))
    reason = {CONVERGED: "gauss-newton: converged", NO_ASCENT_CODE: NO_ASCENT}.get(
        code, out_of_iterations(c))
    f += float(prior_values(x[None], prior)[0])     # the fitness itself
    return SearchResult(x[:6].copy(), float(f), evaluations, len(trace) - 1, reason, trace,
                        trace, strain=x[6:].copy() if len(x) > 6 else None,
                        at_x=(float(raw), offsets.copy()))


def out_of_iterations(config: GaussNewtonConfig) -> str:
    """Stop reason of a refinement that spent ``config.max_iterations`` accepted steps
    without converging (still climbing)."""
    return f"gauss-newton: {config.max_iterations} iterations"


def _fitness_gradient(values: Callable[[NDArray[np.float64]], NDArray[np.float64]],
                      x: NDArray[np.float64], f: float, h: NDArray[np.float64],
                      free: NDArray[np.bool_]) -> NDArray[np.float64]:
    """Forward differences (k,) of the fitness itself (light offsets free; ``values`` of gene
    vectors (P, G)) over the ``free`` genes at ``x``, where it is ``f``."""
    poses = np.repeat(x[None], len(x), axis=0) + np.diag(h)
    return ((values(poses) - f) / h)[free]
