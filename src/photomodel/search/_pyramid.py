"""Coarse-to-fine pose search for the ``soft`` fitness over a feature pyramid.

Poses are pose vectors (x, y, z in mm in camera 1's frame, eps1, eps2, eps3: the vector part
of the unit quaternion ``quat_wxyz``); level k of the pyramid is 2**k times coarser than the
images, and each level's fitness costs about 4x fewer samples than the level below.

1. **Global**, on the coarsest level (``coarse_level``), over (x, y, z, in-plane angle) with
   the garment laid on the plane that faces the rig (``R_cam1_facing``): the ``seeds`` the
   caller found (:func:`~photomodel.fitness.scan_flat_poses`), and without seeds or with
   ``ga_with_seeds`` (a retry) the Gray-coded binary GA with restarts on the fitness with the
   garment's palette (``palette_weight``), whose peaks are as wide as the garment.
2. **Hypotheses**: every seed, each GA restart's best and the overall best are refined on the
   coarse level with the garment's own colours, still flat; those within
   ``hypothesis_margin`` of the best and distinct go on to the next level, where the best of
   them wins. Each is refined by the ray-coordinate evolution strategy of
   :class:`~photomodel.search.LocalRefine` (steps 2**level times level 0's), and after each
   of these two levels a **shift sweep** along the model's own axes (``shift_sweeps``) takes
   a hypothesis off a print's repeat.
3. **Local**, on each finer level down to level 0, over all six genes and the model's
   in-plane strain ``(e_xx, e_yy, e_xy)`` (:func:`~photomodel.geometry.strained_matrices`):
   damped Gauss-Newton on the colour residuals
   (:func:`~photomodel.search.gauss_newton_refine`), started from the previous level's best.
4. **Camera blur**: before each local stage the blur the model photo is given (mm on the
   garment) is chosen from ``optics_blur_candidates_mm`` by a climb up the fitness at the
   current pose from the blur the last stage used; after level 0 it is checked once more,
   and level 0 is refined again when the pose moved it. A print matches only when the model
   is as sharp as the scene.
5. **Flat restart**: a level-0 pose tilted from the facing plane with a strain that shrinks
   the model is refined again from the pose laid flat (``flat_restart_deg``).
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from typing import Any, Protocol, runtime_checkable

import numpy as np
from numpy.typing import ArrayLike, NDArray

from photomodel.geometry import (
    facing_pose_vectors,
    flat_pose_vectors,
    plane_quat_wxyz,
    pose_vectors_to_matrices,
    rotation_from_eps,
    strained_matrices,
)
from photomodel.search._base import SearchResult, conforms, run_search
from photomodel.search._ga import BinaryGA, GAConfig
from photomodel.search._gauss_newton import (
    GaussNewtonConfig,
    NormalEquationsFitness,
    TransformFitness,
    gauss_newton_refine,
)
from photomodel.search._kernel_loops import OnPlane, kernel_fitness, plane_poses, refine_kernel
from photomodel.search._refine import LocalRefine, RefineConfig
from photomodel.search._space import SearchSpace

__all__ = ["PyramidConfig", "PyramidResult", "pyramid_search"]


@dataclass(frozen=True)
class PyramidConfig:
    """Settings of :func:`pyramid_search`.

    Attributes
    ----------
    coarse_level : int
        Pyramid level of the global stage (3: 80 x 60 pixels for a 640 x 480 camera); the
        evolution strategy refines it and the level below, Gauss-Newton the levels under
        those down to level 0.
    palette_weight : float
        Palette weight of the global stage's fitness (see ``SoftFitness``).
    ga : GAConfig
        The global stage's GA (its restarts' bests are hypotheses too).
    refine : RefineConfig
        The evolution strategy of the hypotheses (level-0 steps; level k uses steps 2**k
        times larger).
    gauss_newton : GaussNewtonConfig
        The Gauss-Newton refinement of the finer levels (level-0 settings).
    optics_blur_mm : float
        Camera blur of the global stage and the coarse levels, mm on the garment (Gaussian
        sigma).
    optics_blur_candidates_mm : tuple of float
        Camera blurs the local stages choose from (empty: keep ``optics_blur_mm``). None is
        sharper than a camera in focus: on a plain garment the blur trades with the depth.
    optics_blur_margin : float
        Fitness by which a candidate blur must beat the current one to replace it (a plain
        garment's fitness is flat across the blurs, and its noise must not choose one).
    retry_restarts : int
        GA restarts of a second search (:meth:`for_retry`) after a miss.
    ga_with_seeds : bool
        Run the GA also when :func:`pyramid_search` is given seeds (else the seeds replace
        it).
    hypothesis_margin : float
        After the coarse level, only hypotheses within this of the best one's fitness go on
        to the next level, and of those that walked to the same pose (every gene within 2 %
        of its range) only the best.
    shift_sweeps : tuple of (level, reach_mm, step_mm)
        On these levels the refined hypotheses (the coarse level: every one that goes on; the
        next: the best) are shifted along the model's own x and y axes by up to ``reach_mm``
        every ``step_mm`` and move to the best shift while one beats them (three rounds at
        most): a striped print has a peak at every repeat.
    flat_restart_deg : float
        When level 0 ends more than this tilted from the facing plane with a strain that
        shrinks the model (mean of ``e_xx`` and ``e_yy`` below ``-flat_restart_shrink``),
        level 0 is refined again from the pose laid flat on the plane, first with the tilt
        held, then free, and the better end wins (0: never). Folds across one side of a
        garment gather its cloth, which a uniform strain matches by a tilt.
    flat_restart_shrink : float
        See ``flat_restart_deg``.
    """

    coarse_level: int = 3
    palette_weight: float = 0.5
    ga: GAConfig = field(default_factory=lambda: GAConfig(patience=20, restarts=3,
                                                          min_improvement=0.003))
    refine: RefineConfig = field(default_factory=lambda: RefineConfig(
        population=8, max_iterations=60, min_step_fraction=0.2))
    gauss_newton: GaussNewtonConfig = field(default_factory=GaussNewtonConfig)
    optics_blur_mm: float = 0.5
    optics_blur_candidates_mm: tuple[float, ...] = (0.5, 0.7, 1.0, 1.4, 2.0, 2.8)
    optics_blur_margin: float = 0.02
    retry_restarts: int = 8
    ga_with_seeds: bool = False
    hypothesis_margin: float = 0.2
    shift_sweeps: tuple[tuple[int, float, float], ...] = ((3, 45.0, 3.0), (2, 15.0, 1.5))
    flat_restart_deg: float = 2.0
    flat_restart_shrink: float = 0.005

    def __post_init__(self) -> None:
        if not self.coarse_level >= 1:
            raise ValueError(f"coarse_level: expected >= 1, got {self.coarse_level}")
        if not self.hypothesis_margin >= 0:
            raise ValueError(f"hypothesis_margin: expected >= 0, got {self.hypothesis_margin}")

    def for_retry(self) -> PyramidConfig:
        """These settings with ``retry_restarts`` GA restarts, run beside any seeds, for a
        search after a miss."""
        return replace(self, ga=replace(self.ga, restarts=self.retry_restarts),
                       ga_with_seeds=True)


@dataclass(frozen=True)
class PyramidResult(SearchResult):
    """:class:`SearchResult` of :func:`pyramid_search` with the scene's estimated camera blur.

    Attributes
    ----------
    optics_blur_mm : float
        Optical blur of the camera, mm on the garment, that fits the scene best at the final
        pose (Gaussian sigma; about 0.86 mm per pixel at the working distance).
    """

    optics_blur_mm: float = 0.0


Fitness = Callable[[NDArray[np.float64]], NDArray[np.float64]]
FitnessAt = Callable[[int, float, float], Fitness]


def pyramid_search(fitness_at: FitnessAt, space: SearchSpace, config: PyramidConfig | None = None,
                   rng: int | np.random.Generator | None = None,
                   seeds: Sequence[NDArray[np.float64]] = (),
                   R_cam1_facing: ArrayLike | None = None) -> PyramidResult:
    """Run the coarse-to-fine search.

    Parameters
    ----------
    fitness_at : callable
        ``fitness_at(level, palette_weight, optics_blur_mm)`` returns the fitness of that
        pyramid level with the model blurred by that camera blur; it is called once for
        each such triple, and the fitness reused.
    space : SearchSpace
        Bounds of all stages; the global stage and the coarse level hold the tilt of the
        facing plane (``R_cam1_facing``; the poses are clipped into the box).
    config : PyramidConfig, optional
    rng : int, Generator or None
    seeds : sequence of ndarray (6,)
        Hypotheses found elsewhere (:func:`~photomodel.fitness.scan_flat_poses`). With
        seeds the GA runs only when ``config.ga_with_seeds``; its hypotheses join them.
    R_cam1_facing : array (3, 3), optional
        Orientation of the plane the global stage lays the garment on (the table facing the
        rig: :attr:`~photomodel.camera.StereoRig.R_cam1_facing`); default square to camera 1.

    Returns
    -------
    PyramidResult
        The level-0 best, with the evaluations and histories of every stage.
    """
    c = config or PyramidConfig()
    gen = np.random.default_rng(rng)
    fitness_at = functools.cache(fitness_at)    # one object per (level, weight, blur)
    blur = c.optics_blur_mm
    starts = [space.clip(np.asarray(x, dtype=np.float64).reshape(6)) for x in seeds]
    stages: list[SearchResult] = []
    lo, hi = space.lower.copy(), space.upper.copy()
    lo[3:5] = hi[3:5] = 0.0
    flat = SearchSpace(lo, hi)     # genes 4 and 5 unused: flat pose vectors
    facing = np.eye(3) if R_cam1_facing is None else np.asarray(R_cam1_facing, dtype=np.float64)
    q_facing = plane_quat_wxyz(facing)

    def on_plane(x: NDArray[np.float64]) -> NDArray[np.float64]:
        return plane_poses(x, space, q_facing)

    def flat_fitness(level: int, palette_weight: float) -> OnPlane:
        return OnPlane(fitness_at(level, palette_weight, blur), space, q_facing)

    if c.ga_with_seeds or not starts:
        ga = BinaryGA(flat, c.ga, rng=gen)
        stages.append(run_search(ga, flat_fitness(c.coarse_level, c.palette_weight)))
        # Each restart's best is a hypothesis; the next levels decide.
        starts += list(on_plane(np.array([stages[0].x, *ga.hypotheses()])))
    level = c.coarse_level - 1
    evaluations = 0
    sweeps = {lv: (reach, step) for lv, reach, step in c.shift_sweeps}
    starts = _distinct(starts, space)
    own = flat_fitness(c.coarse_level, 0.0)
    coarse = [_refine_at(own, c.coarse_level, x0, flat, c.refine, gen)
              for x0 in flat_pose_vectors(np.array(starts), facing)]
    coarse = [replace(r, x=on_plane(r.x)[0]) for r in coarse]
    stages.extend(coarse)
    starts = _survivors(coarse, space, c.hypothesis_margin)
    if c.coarse_level in sweeps:
        sweep = fitness_at(c.coarse_level, 0.0, blur)
        swept = [_shift_sweep(sweep, x0, space, *sweeps[c.coarse_level]) for x0 in starts]
        starts = _distinct([x0 for x0, _ in swept], space)
        evaluations += sum(used for _, used in swept)
    objective = fitness_at(level, 0.0, blur)
    candidates = [_refine_at(objective, level, x0, space, c.refine, gen) for x0 in starts]
    best = max(candidates, key=lambda r: r.fitness)
    stages.extend(candidates)
    x = best.x
    if level in sweeps:
        x, used = _shift_sweep(objective, x, space, *sweeps[level], best.fitness)
        evaluations += used
    strain: NDArray[np.float64] | None = np.zeros(3)
    for level in range(c.coarse_level - 2, -1, -1):
        blur, objective, (f0, offsets0), used = _sharpest_fit(fitness_at, level, x, c, blur,
                                                              strain)
        evaluations += used
        stages.append(_local_at(objective, f0, level, x, space, c, strain, offsets0))
        x, strain = stages[-1].x, stages[-1].strain
    refined = stages[-1]     # level 0's refinement: its evaluation at x is the current blur's
    known = ({blur: refined.at_x} if refined.at_x is not None and np.array_equal(refined.x, x)
             else None)
    again, objective, (f0, offsets0), used = _sharpest_fit(fitness_at, 0, x, c, blur, strain,
                                                           known=known)
    evaluations += used
    if again != blur:
        blur = again
        stages.append(_local_at(objective, f0, 0, x, space, c, strain, offsets0))
        x, strain = stages[-1].x, stages[-1].strain
    if c.flat_restart_deg > 0:
        flat, used = _flat_restart(objective, stages[-1], space, c, facing)
        evaluations += used
        if flat is not None:
            stages.append(flat)
            x, strain = flat.x, flat.strain
    last = stages[-1]
    return PyramidResult(
        last.x, last.fitness, evaluations + sum(r.evaluations for r in stages),
        sum(r.iterations for r in stages), "; ".join(r.stop_reason for r in stages),
        np.concatenate([r.best_history for r in stages]),
        np.concatenate([r.mean_history for r in stages]), strain=strain, optics_blur_mm=blur)


def _flat_restart(objective: Fitness, last: SearchResult, space: SearchSpace,
                  config: PyramidConfig, facing: NDArray[np.float64]
                  ) -> tuple[SearchResult | None, int]:
    """Level 0 (fitness ``objective``) again from ``last``'s pose laid flat on the plane
    ``facing`` (3, 3), when it lies more than ``config.flat_restart_deg`` tilted from that
    plane and its strain shrinks the model (``config.flat_restart_shrink``): Gauss-Newton
    with the tilt held, then free. The result when its fitness beats ``last``'s (its
    evaluations all that was spent), else None and the evaluations spent.

    Folds across one side of a garment gather its cloth there, and a uniform strain cannot
    follow them; tilting the model foreshortens that side, and the refinement can end on
    that tilt although a flatter pose fits better."""
    if not conforms(objective, NormalEquationsFitness) or last.strain is None:
        return None, 0
    normal = rotation_from_eps(last.x[3:6])[:, 2]
    tilt_deg = float(np.degrees(np.arccos(np.clip(normal @ facing[:, 2], -1.0, 1.0))))
    if (tilt_deg <= config.flat_restart_deg
            or np.mean(last.strain[:2]) > -config.flat_restart_shrink):
        return None, 0
    start = space.clip(facing_pose_vectors(flat_pose_vectors(last.x, facing), facing)[0])
    held = gauss_newton_refine(objective, start, space, 0, config.gauss_newton,
                               free=np.array([True, True, True, False, False, True]),
                               strain=last.strain)
    free = gauss_newton_refine(objective, held.x, space, 0, config.gauss_newton,
                               strain=held.strain)
    used = held.evaluations + free.evaluations
    if not free.fitness > last.fitness:
        return None, used
    return replace(free, evaluations=used, iterations=held.iterations + free.iterations,
                   stop_reason=f"flat restart ({tilt_deg:.1f} deg): {held.stop_reason}, "
                   f"then {free.stop_reason}"), 0


def _strained(objective: Fitness, strain: NDArray[np.float64] | None) -> Fitness:
    """``objective`` of pose vectors (P, 6) with the model strained by ``strain`` (3,)
    (None: as it is); a strained objective needs ``evaluate_transforms``
    (:class:`~photomodel.search.TransformFitness`)."""
    if strain is None:
        return objective
    if not conforms(objective, TransformFitness):
        raise TypeError("a strained search needs a fitness of transforms "
                        "(TransformFitness, e.g. SoftFitness)")
    return lambda poses: objective.evaluate_transforms(strained_matrices(poses, strain))


def _shift_sweep(objective: Fitness, x: NDArray[np.float64], space: SearchSpace,
                 reach_mm: float, step_mm: float, f_x: float | None = None, rounds: int = 3
                 ) -> tuple[NDArray[np.float64], int]:
    """``x`` moved to the best of its shifts along the model's own x and y axes by up to
    ``reach_mm`` every ``step_mm``, while that beats it (at most ``rounds`` times), and the
    evaluations spent. ``f_x``: the fitness at ``x``, when known.

    A print that repeats (stripes, checks) has a peak at every repeat; a local search that
    starts a repeat away settles there, and the finer levels, whose basins are a few pixels
    wide, keep it. The shifts keep depth, angle and tilt, so one of them lands on the
    garment's own peak when only the repeat was wrong; a second round follows a repeat that
    was off along both axes.
    """
    used = 0
    if f_x is None:
        f_x = float(objective(x[None])[0])
        used += 1
    d = np.arange(step_mm, reach_mm + 1e-9, step_mm)
    d = np.concatenate([-d[::-1], d])
    for _ in range(rounds):
        R = rotation_from_eps(x[3:])
        shifts = np.concatenate([d[:, None] * R[:, 0], d[:, None] * R[:, 1]])
        poses = space.clip(np.column_stack([x[:3] + shifts,
                                            np.broadcast_to(x[3:], (len(shifts), 3))]))
        values = objective(poses)
        used += len(poses)
        i = int(np.argmax(values))
        if not values[i] > f_x + 1e-9:    # a tie (or rounding) is no move
            break
        x, f_x = poses[i], float(values[i])
    return x, used


@runtime_checkable
class _Colourings(Protocol):
    """A fitness that evaluates itself and others of the same points in other colours at
    one map together (``SoftFitness.evaluate_colourings``)."""

    def evaluate_colourings(self, others: Sequence[Any], T_cam1_model: NDArray[np.float64]
                            ) -> NDArray[np.float64]: ...

    def last_offsets(self) -> NDArray[np.float64]: ...


def _sharpest_fit(fitness_at: FitnessAt, level: int, x: NDArray[np.float64],
                  config: PyramidConfig, blur_mm: float,
                  strain: NDArray[np.float64] | None = None,
                  known: dict[float, tuple[float, NDArray[np.float64]]] | None = None
                  ) -> tuple[float, Fitness, tuple[float, NDArray[np.float64] | None], int]:
    """The camera blur (mm on the garment) for ``level`` at pose vector ``x`` (6,) (model
    strained by ``strain`` (3,)), that level's fitness with it, the fitness at ``x`` with the
    light offsets (2, 3) it found there (None where the fitness has none) and the
    evaluations spent.

    The candidate with the highest fitness, when it beats ``blur_mm`` (the current one) by
    ``config.optics_blur_margin``; else ``blur_mm``. Each blur is evaluated once, the
    current one among the candidates included. Where ``blur_mm`` is a candidate, only the
    candidates from it up the fitness are evaluated (its two neighbours, then on in the
    direction that rises while it does): the highest of a curve with one peak. Else every
    candidate is. Blurs evaluated together share one pass over the images where the fitness
    allows it (``SoftFitness.evaluate_colourings``).

    ``known``: blurs whose fitness at ``x`` (and offsets) the caller has, as the fitness
    returned them (level 0's refinement evaluated its end pose): taken, not evaluated.
    """
    computed: dict[float, tuple[float, NDArray[np.float64] | None]] = dict(known or {})

    def evaluate(blurs: Sequence[float]) -> None:
        """Each of ``blurs`` not yet known, together where the fitness can
        (``evaluate_colourings``: one pass over the images for them all)."""
        new = [b for b in dict.fromkeys(blurs) if b not in computed]
        objectives = [fitness_at(level, 0.0, b) for b in new]
        if len(new) > 1 and all(conforms(o, _Colourings) for o in objectives):
            T = (pose_vectors_to_matrices(x[None]) if strain is None
                 else strained_matrices(x[None], strain))[0]
            values = objectives[0].evaluate_colourings(objectives[1:], T)
            for b, o, f in zip(new, objectives, values, strict=True):
                computed[b] = (float(f), o.last_offsets())
            return
        for b, o in zip(new, objectives, strict=True):
            f = float(_strained(o, strain)(x[None])[0])
            computed[b] = (f, o.last_offsets() if conforms(o, TransformFitness) else None)

    def value(b: float) -> float:
        evaluate([b])
        return computed[b][0]

    candidates = tuple(config.optics_blur_candidates_mm)
    if blur_mm in candidates:
        grid = sorted(candidates)
        start = grid.index(blur_mm)
        evaluate(grid[max(start - 1, 0):start + 2])   # where the climb looks first
        tried = _climb(value, grid, start)
    else:
        evaluate((blur_mm, *candidates))
        tried = {b: value(b) for b in dict.fromkeys((blur_mm, *candidates))}
    chosen = blur_mm
    if candidates:
        best = max((b for b in candidates if b in tried), key=tried.__getitem__)
        if tried[best] > tried[blur_mm] + config.optics_blur_margin:
            chosen = best
    return (chosen, fitness_at(level, 0.0, chosen), computed[chosen],
            len(computed.keys() - (known or {}).keys()))


def _climb(value: Callable[[float], float], grid: list[float], start: int
           ) -> dict[float, float]:
    """The values of ``grid`` tried by a climb from ``grid[start]``: down the grid while the
    next value is higher, and when the first step down did not rise, up the same way."""
    tried = {grid[start]: value(grid[start])}
    best = start
    for step in (-1, 1):
        i = start + step
        while 0 <= i < len(grid):
            tried[grid[i]] = value(grid[i])
            if not tried[grid[i]] > tried[grid[best]]:
                break
            best, i = i, i + step
        if best != start:
            break
    return tried


def _refine_at(objective: Fitness, level: int, x: NDArray[np.float64], space: SearchSpace,
               refine: RefineConfig, gen: np.random.Generator) -> SearchResult:
    """:class:`LocalRefine` of ``objective`` (pyramid ``level``) from ``x``, steps scaled by
    2**level; in one numba loop (:func:`refine_kernel`) where the fitness gives its
    kernel."""
    config = refine.scaled(2.0**level)
    if kernel_fitness(objective) is not None:
        return refine_kernel(objective, space, x, config, gen)  # type: ignore[arg-type]
    f0 = float(objective(x[None])[0])
    return run_search(LocalRefine(space, x, f0, config, gen), objective)


def _local_at(objective: Fitness, f0: float, level: int, x: NDArray[np.float64],
              space: SearchSpace, config: PyramidConfig,
              strain: NDArray[np.float64] | None = None,
              offsets0: NDArray[np.float64] | None = None) -> SearchResult:
    """Gauss-Newton refinement of ``objective`` (a :class:`NormalEquationsFitness` of
    pyramid ``level``) from pose vector ``x`` (6,), with the model's ``strain`` (3,) when
    given; it starts from ``f0``, the fitness at ``x``, and ``offsets0`` (2, 3), the light
    offsets found there, when given, instead of evaluating ``x`` again."""
    return gauss_newton_refine(objective, x, space, level, config.gauss_newton,
                               strain=strain, start=None if offsets0 is None else (f0, offsets0))


def _survivors(results: list[SearchResult], space: SearchSpace, margin: float
               ) -> list[NDArray[np.float64]]:
    """The refined hypotheses worth the next level: best first, without near-repeats (they
    walked to the same peak), none more than ``margin`` below the best."""
    ranked = sorted(results, key=lambda r: -r.fitness)
    return _distinct([r.x for r in ranked if r.fitness >= ranked[0].fitness - margin], space)


def _distinct(xs: list[NDArray[np.float64]], space: SearchSpace,
              tolerance: float = 0.02) -> list[NDArray[np.float64]]:
    """``xs`` without near-repeats (every gene within ``tolerance`` of its range)."""
    kept: list[NDArray[np.float64]] = []
    span = np.where(space.span > 0, space.span, 1.0)
    for x in xs:
        if all(np.any(np.abs(x - k) / span > tolerance) for k in kept):
            kept.append(x)
    return kept
