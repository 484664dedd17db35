"""Local refinement by damped Gauss-Newton on the colour residuals (Levenberg-Marquardt).

The ``soft`` fitness is a sum of Gaussian agreements ``a_j = exp(-|r_j|^2 / 2)`` of scaled
colour residuals ``r_j``: ``F = mean over cameras of (sum_in w_in a_j - sum_band w_out a_j) +
terms of the light offsets``. With the offsets held where the last accepted pose put them,
its pose gradient is ``g = -sum_j s_j a_j J_j^T r_j`` (``s_j`` the
point's signed weight, ``J_j`` the residual's Jacobian), and the inner points' robust
Gauss-Newton matrix ``H = sum_in s_j a_j J_j^T J_j`` (the Welsch M-estimator's
iteratively reweighted least squares) is a positive curvature metric for it. Each iteration
takes the step ``(H + lambda diag H)^-1 g`` and keeps it when the full fitness (offsets
free) rises, taken further where the fitness along it still climbs
(``GaussNewtonConfig.extrapolation``); else ``lambda`` grows and the step shrinks towards
the gradient.

The held offsets' gradient is not always the fitness's: the offsets maximise the inner
points' agreement only, and the band's agreement moves with them, so where the band decides
the fitness (a plain garment on a table of a close colour) the two can point apart (at a
stall on the grey sock No.6, level 0: a step along the held gradient raised the held
fitness by 4e-4 and lowered the fitness by 9e-5). With the analytic Jacobian the gradient
adds the offsets' own motion with the pose (``GaussNewtonConfig.offsets_in_gradient``: the
implicit function theorem on the offsets' objective), which makes it the fitness's full
gradient. Where no step along it is accepted (now rarely), the
gradient is taken from the fitness's own forward differences (six more poses an iteration)
for the rest of the refinement; a stall after that is a peak (CMA-ES from there raised the
fitness by less than 3e-4 on nine scenes, where it had raised it by up to 0.01 before).

``J`` is the residuals' analytic Jacobian where the fitness gives its normal equations
(``SoftFitness.normal_equations``: the bilinear interpolant's slope through the projection and
the map's derivative along each gene, ``_map_derivatives``), one pose an iteration; else it
comes from forward differences of the residuals, one pose per gene (bilinear samples of
smoothed images: a difference of a fortieth of a pixel is the local slope), all seven poses in
one kernel call (``GaussNewtonConfig.jacobian``). The two agree to 1-3 % and take nearly the
same steps; the analytic one costs 0.8 against 1.7 ms an iteration on level 0 (about 0.5
since its sums run in the model point's 9-dimensional space). An iteration also evaluates the
fitness once or twice, and 4-10 iterations converge from a pixel or two away
(with the differences, against CMA-ES): measured on 48 scenes (paper, blur,
gripper, overlap) against :class:`~photomodel.search.LocalCMA` on pyramid levels 1 and 0, the
same 48 successes and median errors (0.32 against 0.30 mm, 0.138 against 0.131 deg) in 0.39x
the time per stereo pair; on 48 more (wrinkles, warm light, tilt, distractors) 45 against 42
successes. Its basin is a few pixels wide: the coarse levels, where a hypothesis starts tens of
millimetres away, keep :class:`~photomodel.search.LocalRefine` (with it on level 2 and 3 as
well, 47/48).

With a start strain the model's in-plane strain ``(e_xx, e_yy, e_xy)`` is refined with the
pose (:func:`~photomodel.geometry.strained_matrices`: the residuals take any map of model
points). Its three Jacobian columns come from the translation's, not from more residual
poses: a strain ``E`` moves sample ``p`` by ``R E p`` (``_weighted_products``).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Literal, Protocol, runtime_checkable

import numba
import numpy as np
from numpy.typing import ArrayLike, NDArray

from photomodel.fitness._protocols import KernelNormalEquations
from photomodel.geometry import pose_vectors_to_matrices, rotation_from_eps, strained_matrices
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

__all__ = ["NO_ASCENT", "GaussNewtonConfig", "NormalEquationsFitness", "ResidualFitness",
           "gauss_newton_refine", "out_of_iterations"]

NO_ASCENT = "gauss-newton: no ascent step"
"""Stop reason of a refinement that accepted no step where it stopped (a kink or a peak)."""


@runtime_checkable
class ResidualFitness(Protocol):
    """A fitness that also gives its residuals at held light offsets (``SoftFitness``)."""

    def __call__(self, poses: NDArray[np.float64]) -> NDArray[np.float64]: ...

    def evaluate_transforms(self, T_cam1_model: NDArray[np.float64]
                            ) -> NDArray[np.float64]: ...

    def last_offsets(self) -> NDArray[np.float64]: ...

    def residuals(self, T_cam1_model: NDArray[np.float64], offsets: NDArray[np.float64]
                  ) -> tuple[NDArray[np.float64], NDArray[np.bool_]]: ...

    def residual_weights(self) -> NDArray[np.float64]: ...

    def residual_points(self) -> NDArray[np.float64]: ...


@runtime_checkable
class NormalEquationsFitness(ResidualFitness, Protocol):
    """A residual fitness that also gives its normal equations from an analytic Jacobian
    (``SoftFitness.normal_equations``)."""

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
        Forward-difference step of each gene (x, y, z mm, eps1, eps2, eps3): 0.02 mm
        sideways and 2e-5 in eps are about a fortieth of a pixel at 685 mm, 0.1 mm in depth
        moves the outline of a 200 mm garment about as much.
    max_iterations : int
        Accepted steps at most. A refinement on level 1 that ends them still climbing goes on
        with CMA-ES (``PyramidConfig.unconverged_to_cma``), 50-90 ms on two threads; with the
        analytic Jacobian a step costs about 0.5 ms there, so 40 (20 before) let a slow walk
        along a ridge (tilted and wrinkled garments, wood) finish: on 72 scenes (tilt,
        wrinkles, wood, overlap, gripper, blur) the same successes, mean time 88 -> 82 ms.
        The slowest walks then were tilted garments held at the search box's tilt bound
        (measured from camera 1 then, not from the table; see ``SearchSpace.from_ranges``):
        the tilt's step was clipped every iteration and the other genes crept.
    converged_steps : float
        Stop after an accepted step no larger than this many difference steps in any gene.
    min_gain : float
        Also stop after ``min_gain_steps`` accepted steps in a row that each raised the fitness by
        less than this (0: never). A tilted striped shirt's level-0 refinement ran its 40 steps for
        1e-5 a step: its tilt lay beyond the search box's bound, then measured from camera 1
        (``SearchSpace.from_ranges``' ``R_cam1_plane`` since), each step's tilt was clipped and the
        other genes crept. 1e-5 against none, on 36 tilt, wood and paper scenes: mean time 70 -> 65
        ms a pair, the same successes and median errors; the grey sock No.6 in 300 paper trials: the
        same means and std to 0.004 mm and 0.001 deg; 48 wrinkled, occluded and dim scenes
        unchanged. With the tilt bound from the table, on 72 tilt, wood and paper scenes: mean 109
        -> 100 ms, median 66 -> 64 ms, the same successes, poses within 0.07 mm.
    min_gain_per_level : float
        ``min_gain`` is multiplied by this for each pyramid level above 0 (level 1: 1e-4):
        level 0 refines what level 1 leaves. 192 scenes of 16 conditions (trial 5), both ways
        in turn: 192/192 either way, normal equations 15.8 -> 14.0 a scene, per-scene time
        0.98 (ratio of medians 0.97); 14 poses moved by 0.05-0.3 mm, both ways (the grey sock
        No.6 and the white towel No.8, whose peaks are flat).
    min_gain_steps : int
        The accepted steps in a row that must each gain less than ``min_gain`` to stop (2
        before): a step that gains less than 1e-5 is followed by smaller ones (Gauss-Newton
        converges quadratically near the peak; on levels 1 and 0 the gains fall as 1e-3,
        1e-4, 1e-6, 1e-8), and each costs the normal equations and an evaluation. See
        ``PyramidConfig.refine`` for the measurement.
    damping0 : float
        Start value of ``lambda``.
    max_damping : float
        Stop when no step is accepted up to this ``lambda`` (the start is a peak).
    rejected_damping : float
        After a rejected step ``lambda`` grows to at least this: below about a quarter the
        damped step is the Gauss-Newton step within 20 %, and trying it again wastes an
        evaluation.
    min_step : float
        A rejected step no larger than this many difference steps in any gene counts as
        ``max_damping`` reached: a smaller one moves the samples by less than a hundredth of
        a pixel.
    difference_on_stall : bool
        Where no step is accepted, go on with the gradient of the fitness's own forward
        differences before stopping (see the module docstring).
    strain_step : float
        Forward-difference step of the strain genes (1e-4: 0.01 mm on a 100 mm half-width).
    max_strain : float
        Largest strain component a refinement with strain may reach.
    jacobian : {"analytic", "differences"}
        Where the fitness gives its normal equations (:class:`NormalEquationsFitness`), take
        the gradient and metric from the residuals' analytic Jacobian (the image's bilinear
        slope through the projection: one pose an iteration instead of seven residual poses
        and their products; at level 0 0.8 (now 0.5) against 1.7 ms on two threads), else
        from forward differences of the residuals (``difference_steps``).
    offsets_in_gradient : bool
        With the analytic Jacobian, add to the held-offset gradient the offsets' own motion
        with the pose (``SoftFitness.normal_equations(with_offsets=True)``: the implicit
        function theorem on the offsets' objective): the fitness's full gradient. The held
        one can point away from it where the band decides (the grey sock No.6: off by 50-320
        % of the gradient's largest component on levels 0 and 1, the full one by 0.1-4 %,
        against central differences of the fitness), so the refinement stalled and went on
        with the fitness's own differences (nine poses an iteration).
    strain_by_differences : bool
        With ``jacobian="differences"``: take the strain genes' Jacobian from residual
        differences (three more poses an iteration) instead of from the translation's and
        the samples' model coordinates (``ResidualFitness.residual_points``; see
        ``_weighted_products``).
    strain_weights : (float, float)
        Prior on the strain: the refinement maximises the fitness less ``w_mean * m^2 +
        w_shape * (d^2 + e_xy^2)``, with the mean strain ``m = (e_xx + e_yy) / 2`` and ``d =
        (e_xx - e_yy) / 2`` (the result's fitness is the fitness itself). Where part of the
        outline is hidden (a gripper, another garment), a strain that shrinks the model away
        from the hidden end costs the fitness nothing, and the pose walks with it: without
        a prior the navy trousers under the gripper ended 3.7 mm off (0.14 mm rigid). On
        wrinkles, gripper and overlap x 2 trials (72 scenes): no prior, 21/24 wrinkled
        successes and occluded errors up to 3.74 mm; (30, 30) 18/24 and 1.34 mm; (0, 100)
        20/24 and 1.47 mm; (10, 30) 22/24 and 1.75 mm (rigid: 13/24 and 1.31 mm). Folds
        shorten the cloth across them, so the shape term is the one a wrinkled garment needs
        less of.
    extrapolation : float
        After an accepted step, the parabola through the fitness at the start, its slope along
        the step (the gradient's) and its value one step on is fitted; where it peaks beyond
        1.5 steps the step is taken that far (at most this many steps: one more evaluation),
        and kept when it rises further (1: never). The inner points' metric is steeper than
        the fitness (the Welsch weights' curvature ``a (1 - r^2)`` is below the metric's
        ``a``, and the band's negative weights are left out), so the steps fall short and
        the gains shrink by only 2-3 a step: on 72 paper, wood, tilt, wrinkled, dim and
        gripper scenes the normal equations fell from 22.6 to 16.1 a scene (3/4 of the tries
        kept on 72 paper, cool-light, tilt, wood, wrinkled and dim scenes); on 192 scenes of
        16 conditions 18.2 -> 14.7, the same 192 successes, per-scene time 0.99, ratio of
        medians 0.97.
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
    difference_on_stall: bool = True
    strain_step: float = 1e-4
    max_strain: float = 0.1
    jacobian: Literal["analytic", "differences"] = "analytic"
    offsets_in_gradient: bool = True
    strain_by_differences: bool = False
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
        if self.jacobian not in ("analytic", "differences"):
            raise ValueError(f"jacobian: expected 'analytic' or 'differences', "
                             f"got {self.jacobian!r}")
        if not (self.strain_step > 0 and 0 < self.max_strain < 1
                and min(self.strain_weights) >= 0):
            raise ValueError("expected strain_step > 0, 0 < max_strain < 1, strain_weights >= 0")
        if not self.extrapolation >= 1.0:
            raise ValueError(f"extrapolation: expected >= 1, got {self.extrapolation}")


def gauss_newton_refine(fitness: ResidualFitness, x0: NDArray[np.float64],
                        space: SearchSpace, level: int = 0,
                        config: GaussNewtonConfig | None = None,
                        free: NDArray[np.bool_] | None = None,
                        strain: ArrayLike | None = None,
                        start: tuple[float, NDArray[np.float64]] | None = None
                        ) -> SearchResult:
    """Refine pose ``x0`` (6,) to the nearest peak of ``fitness`` (see the module docstring).

    Parameters
    ----------
    fitness : ResidualFitness
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
        the caller evaluated it (the pyramid's blur choice does): the refinement starts from
        them instead of evaluating ``x0`` again. Ignored where ``x0`` or ``strain`` lies
        outside the box (the start is clipped, so it is another pose).

    Returns
    -------
    SearchResult
        The last accepted pose, never worse than the start. ``evaluations`` counts every pose
        evaluated, the residual evaluations included; ``iterations`` the accepted steps.
    """
    c = config or GaussNewtonConfig()
    free = np.ones(6, dtype=bool) if free is None else np.asarray(free, dtype=bool)
    x0_given = np.asarray(x0, dtype=np.float64).reshape(6)
    strain_given = None if strain is None else np.asarray(strain, dtype=np.float64).reshape(3)
    x = space.clip(x0_given)
    h = np.asarray(c.difference_steps) * 2.0**level
    strained = strain is not None
    if strained:
        x = np.concatenate([x, np.clip(np.asarray(strain, dtype=np.float64).reshape(3),
                                       -c.max_strain, c.max_strain)])
        h = np.concatenate([h, np.full(3, c.strain_step * 2.0**level)])
        free = np.concatenate([free, np.ones(3, dtype=bool)])

    def clip(v: NDArray[np.float64]) -> NDArray[np.float64]:
        return clip_genes(v, space.lower, space.upper, c.max_strain)

    def transforms(poses: NDArray[np.float64]) -> NDArray[np.float64]:
        if strained:
            return strained_matrices(poses[:, :6], poses[:, 6:])
        return pose_vectors_to_matrices(poses)

    prior = np.zeros((len(x), len(x)))     # the strain's prior: x^T prior x
    if strained:
        prior[6:, 6:] = c.strain_prior()

    def values(v: NDArray[np.float64]) -> NDArray[np.float64]:  # less the strain's prior
        return fitness.evaluate_transforms(transforms(v)) - prior_values(v, prior)

    def value(v: NDArray[np.float64]) -> float:
        return float(values(v[None])[0])

    if start is not None and not (np.array_equal(x[:6], x0_given)
                                  and (not strained or np.array_equal(x[6:], strain_given))):
        start = None     # clipped: another pose than the one evaluated
    analytic = c.jacobian == "analytic" and conforms(fitness, NormalEquationsFitness)
    if analytic and conforms(fitness, KernelNormalEquations):
        return _refine_in_kernel(fitness, x, free, h, space, prior, level, c, start)
    weights = (np.zeros(0) if analytic
               else np.asarray(fitness.residual_weights(), dtype=np.float64))
    # The strain's Jacobian from the translation's (no residual poses of its own).
    by_points = strained and not c.strain_by_differences and not analytic
    points = (np.ascontiguousarray(fitness.residual_points()[:, :2], dtype=np.float64)
              if by_points else np.zeros((0, 2)))
    if start is None:
        f = value(x)
        offsets = fitness.last_offsets()
        evaluations = 1
    else:
        f = start[0] - float(prior_values(x[None], prior)[0])
        offsets = np.array(start[1], dtype=np.float64).reshape(2, 3)
        evaluations = 0
    history = [f]
    damping = c.damping0
    reason = out_of_iterations(c)
    differenced = False     # the gradient from the fitness's own differences
    genes = len(x)
    differenced_genes = 6 if by_points else genes
    small_gains = 0     # accepted steps in a row that gained less than min_gain
    min_gain = c.min_gain * c.min_gain_per_level**level
    for _ in range(c.max_iterations):
        if analytic:
            gradient, metric = fitness.normal_equations(
                transforms(x[None])[0], _map_derivatives(x, free), offsets,
                with_offsets=c.offsets_in_gradient)
            evaluations += 1
        else:
            poses = np.repeat(x[None], differenced_genes + 1, axis=0)
            poses[1:] += np.diag(h)[:differenced_genes]
            r, ok = fitness.residuals(transforms(poses), offsets)
            gradient, metric = _weighted_products(r, ok, weights, h, np.flatnonzero(free),
                                                  points, rotation_from_eps(x[3:6]))
            evaluations += differenced_genes + 1
        if strained:
            add_prior(gradient, metric, prior, x, free)
        if differenced:
            gradient = _fitness_gradient(values, x, f, h, free)
            evaluations += genes
        step = np.zeros(genes)
        while True:
            step[free] = damped_step(metric, damping, gradient)
            candidate = clip(x + step)
            candidate_value = value(candidate)
            evaluations += 1
            if candidate_value > f:
                damping = max(damping / 3.0, 1e-4)
                offsets = fitness.last_offsets()
                alpha = _extrapolation(f, candidate_value, slope_along(gradient, step, free),
                                       c.extrapolation)
                if alpha > 1.0:
                    further = clip(x + alpha * step)
                    further_value = value(further)
                    evaluations += 1
                    if further_value > candidate_value:
                        candidate, candidate_value, step = further, further_value, further - x
                        offsets = fitness.last_offsets()
                break
            damping = max(4.0 * damping, c.rejected_damping)
            if damping > c.max_damping or np.all(np.abs(step) <= c.min_step * h):
                if differenced or not c.difference_on_stall:
                    break
                differenced, damping = True, c.damping0
                gradient = _fitness_gradient(values, x, f, h, free)
                evaluations += genes
        if candidate_value <= f:
            reason = NO_ASCENT
            break
        small_gains = small_gains + 1 if candidate_value - f < min_gain else 0
        x, f = candidate, candidate_value
        history.append(f)
        if np.all(np.abs(step) <= c.converged_steps * h) or small_gains >= c.min_gain_steps:
            reason = "gauss-newton: converged"
            break
    trace = np.asarray(history)
    f += float(prior_values(x[None], prior)[0])     # the fitness itself
    return SearchResult(x[:6], f, evaluations, len(history) - 1, reason, trace, trace,
                        strain=x[6:].copy() if strained else None)


def _refine_in_kernel(fitness: KernelNormalEquations, x: NDArray[np.float64],
                      free: NDArray[np.bool_], h: NDArray[np.float64], space: SearchSpace,
                      prior: NDArray[np.float64], level: int, c: GaussNewtonConfig,
                      start: tuple[float, NDArray[np.float64]] | None = None
                      ) -> SearchResult:
    """The analytic refinement's iterations in numba (:mod:`._gauss_newton_loop`) from genes
    ``x`` (clipped; nine with the strain), where the fitness and offsets are ``start`` when
    known."""
    f_start, offsets_start = (np.nan, np.zeros((2, 3))) if start is None else start
    x, f, evaluations, trace, code, raw, offsets = gauss_newton_loop(
        numba.get_num_threads(), fitness.kernel_args(), fitness.normal_args(), x, free, h,
        np.ascontiguousarray(space.lower, dtype=np.float64),
        np.ascontiguousarray(space.upper, dtype=np.float64), c.max_strain, prior,
        c.max_iterations, c.converged_steps, c.min_gain * c.min_gain_per_level**level,
        c.min_gain_steps, c.damping0, c.max_damping, c.rejected_damping, c.min_step,
        c.difference_on_stall, c.offsets_in_gradient, c.extrapolation, float(f_start),
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


@numba.njit(cache=True, nogil=True)
def _weighted_products(r: NDArray[np.float64], ok: NDArray[np.bool_],
                       weights: NDArray[np.float64], h: NDArray[np.float64],
                       genes: NDArray[np.intp], points: NDArray[np.float64],
                       R: NDArray[np.float64]
                       ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:  # pragma: no cover
    """The held-offset gradient ``-J (w r)`` and the inner points' ``J diag(w) J^T`` over
    ``genes``, from the residuals ``r`` (1 + G, cameras, N, 3) of the gene vector and its G
    forward differences (steps ``h``) and their ``ok`` (1 + G, cameras, N), in one pass.

    With ``points`` (N, 2), the samples' model-plane coordinates, ``r`` holds the six pose
    genes' differences only, and the strain genes' columns come from the translation's: a
    strain ``E`` moves sample ``p`` by ``R E p`` (``R`` the pose's rotation), so ``dr /
    de_xx = p_x (J_t R[:, 0])``, ``dr / de_yy = p_y (J_t R[:, 1])`` and ``dr / de_xy = p_y
    (J_t R[:, 0]) + p_x (J_t R[:, 1])`` with ``J_t`` the residual's translation Jacobian.

    A sample counts where every pose saw it; its weight ``w`` is its signed
    ``weights`` times its agreement ``exp(-|r|^2 / 2)``, averaged over the cameras; the
    metric takes the inner (positive) samples only. The sums run in a fixed order (not a
    BLAS product, whose sums depend on its thread count), so a trial's records are the same
    on every executor. 0.3 ms on level 0 (two cameras, 3000 samples) where numpy's Jacobian
    and weights before it took another 0.3."""
    k = genes.shape[0]
    cameras, n, channels = r.shape[1], r.shape[2], r.shape[3]
    by_points = points.shape[0] > 0
    differenced = r.shape[0] - 1
    gradient = np.zeros(k)
    metric = np.zeros((k, k))
    jacobian = np.zeros(k)
    full = np.zeros(differenced + (3 if by_points else 0))
    for c in range(cameras):
        for i in range(n):
            usable = True
            for p in range(r.shape[0]):
                usable = usable and ok[p, c, i]
            if not usable:
                continue
            d2 = 0.0
            for d in range(channels):
                d2 += r[0, c, i, d] ** 2
            w = np.exp(-0.5 * d2) * weights[i] / cameras
            inner = w if weights[i] > 0 else 0.0
            for d in range(channels):
                r0 = r[0, c, i, d]
                for g in range(differenced):
                    full[g] = (r[1 + g, c, i, d] - r0) / h[g]
                if by_points:
                    dx = R[0, 0] * full[0] + R[1, 0] * full[1] + R[2, 0] * full[2]
                    dy = R[0, 1] * full[0] + R[1, 1] * full[1] + R[2, 1] * full[2]
                    px, py = points[i, 0], points[i, 1]
                    full[6] = px * dx
                    full[7] = py * dy
                    full[8] = py * dx + px * dy
                for p in range(k):
                    jacobian[p] = full[genes[p]]
                    gradient[p] -= jacobian[p] * (w * r0)
                if inner != 0.0:
                    for p in range(k):
                        jp = jacobian[p] * inner
                        for q in range(p + 1):
                            metric[p, q] += jp * jacobian[q]
    for p in range(k):
        for q in range(p):
            metric[q, p] = metric[p, q]
    return gradient, metric
