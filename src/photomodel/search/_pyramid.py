"""Coarse-to-fine pose search for the ``soft`` fitness over a feature pyramid.

1. **Global** on the coarsest level, over (x, y, z, in-plane angle) with no tilt: the
   ``seeds`` the caller found (``locate`` scans every pixel, angle and depth by correlation:
   :func:`~photomodel.fitness.scan_flat_poses`), and, without seeds or with
   ``ga_with_seeds`` (a retry), the Gray-coded binary GA with restarts on the ``soft``
   fitness with the garment's palette (``palette_weight``), whose peaks are as wide as the
   garment, not as a print's repeat.
2. **Hypotheses**: every seed, the best pose of every GA restart and the overall best are
   refined on the coarse level with the garment's own colours (``coarse_own_colours``),
   then, those near the best and distinct (``hypothesis_margin``), on the next level; the
   best of them goes on. The global stage and the coarse level lay the garment on the plane
   that faces the rig (``R_cam1_facing``), as a table below a converging rig lies; after
   each of these two levels a **shift sweep** along the model's own axes takes a
   hypothesis off a print's repeat (``shift_sweeps``). The palette fitness can rank a wrong
   peak first (a print colour close to the table's), the finer level with own colours
   rarely does. Each hypothesis is refined by the ray-coordinate evolution strategy of
   :class:`~photomodel.search.LocalRefine`, whose growing steps walk in from tens of
   millimetres away.
3. **Local** on each finer level down to level 0, over all six genes: damped Gauss-Newton on
   the colour residuals (:func:`~photomodel.search.gauss_newton_refine`; where it accepts no
   step, on the fitness's own differences), started from the previous level's best, steps
   scaled to the level's pixel size, with the model's in-plane strain (``fit_strain``: wrinkled
   cloth lies shorter than its photo). It follows the ridge that couples tilt with position to
   the peak, where ``LocalRefine`` stops short of it by degrees of tilt, as CMA-ES in ray
   coordinates (:class:`~photomodel.search.LocalCMA`) does in ten times the evaluations.
   ``local_method="cma"`` refines every level with CMA-ES (the default before Gauss-Newton),
   ``gauss_newton_max_level=0`` level 1 only.
4. **Optical blur**: before each local stage, the camera blur the model photo is given is
   the candidate whose fitness is highest at the current pose, found by a climb from the
   blur the last stage used (level 1 from the global stage's, level 0 from level 1's: 2-3
   evaluations instead of 6; ``optics_blur_climb``); after level 0 it is checked once more,
   and level 0 is refined again when the pose moved it. A print matches only
   when the model is as sharp as the scene (measured at the true pose of six scenes: a
   1.8-pixel blur scores 0.25-0.30 with the in-focus model and 0.65-0.75 with the estimated
   one; in focus, 0.74-0.89).

Each level's fitness is cheap in proportion to its samples (about 4x fewer per level up).
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from typing import Any, Literal, Protocol, runtime_checkable

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
    NO_ASCENT,
    GaussNewtonConfig,
    ResidualFitness,
    gauss_newton_refine,
    out_of_iterations,
)
from photomodel.search._kernel_loops import OnPlane, kernel_fitness, plane_poses, refine_kernel
from photomodel.search._localcma import LocalCMA, LocalCMAConfig
from photomodel.search._refine import LocalRefine, RefineConfig
from photomodel.search._space import SearchSpace

__all__ = ["PyramidConfig", "PyramidResult", "pyramid_search"]


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
        The global stage's GA. It stops a run after 20 generations without a rise of 0.003:
        level 2 refines its result anyway (measured on 96 hard scenes, 12 garments x 8
        conditions: 23 % fewer evaluations than any rise counting, the same successes).
    refine : RefineConfig
        The hypotheses' refinement (level 0 steps; level k uses steps 2**k times larger).
        8 poses an iteration (24 before): on 192 scenes (16 conditions) 188 against 187
        successes, the same median errors, evaluations 2224 -> 920 (median); in the study
        (No.4, No.6, No.11 x 1000 paper trials) the same means and std to 0.003 mm and
        0.1-0.14 s instead of 0.16-0.20 s a trial on one-thread workers. It stops at a fifth
        of its start steps (a tenth before; Gauss-Newton on levels 1 and 0 takes the pose
        on): with ``GaussNewtonConfig.min_gain_steps`` 1, on 192 scenes (16 conditions,
        trial 2) each run both ways in turn, 192/192 either way, per-scene time 0.955x, 18
        poses moved by more than 0.05 mm (the grey sock No.6 by 0.1-0.25 mm both ways).
    local_method : {"gauss-newton", "cma"}
        The finer levels' refinement: :func:`~photomodel.search.gauss_newton_refine` with
        ``gauss_newton`` on the levels up to ``gauss_newton_max_level`` and
        :class:`~photomodel.search.LocalCMA` with ``local`` above them, or ``LocalCMA`` on
        every level. Gauss-Newton on levels 1 and 0, against CMA-ES on both, on 96 scenes
        (12 garments x 8 conditions): 93 against 90 successes (9 against 6 of 12 wrinkled
        garments), the same median errors, 0.4-0.5x the time per stereo pair.
    gauss_newton_max_level : int
        The coarsest level Gauss-Newton refines; CMA-ES refines the finer levels above it.
        Level 1 (default) against 0, on the benchmark (432 scenes, 18 conditions): 97.0 %
        against 96.5 % successes, median 354 against 557 ms per pair on 2 threads. CMA-ES's
        samples reach farther: with Gauss-Newton on level 1 a striped No.4 stayed one stripe
        (6.6 mm) off in 1 of 100 study trials, which CMA-ES on level 1 finds.
    gauss_newton : GaussNewtonConfig
        Level-0 settings of the Gauss-Newton refinement.
    stalled_to_cma : bool
        When Gauss-Newton accepts no step, go on with ``LocalCMA`` from there. Before
        Gauss-Newton fell back on the fitness's own gradient at a stall
        (``GaussNewtonConfig.difference_on_stall``) this was the default: a quarter of the
        refinements stalled on a kink, and on the grey sock No.6 it left 1.2-3.9 deg of
        tilt that CMA-ES reduced to 0.5-1.7 deg. With the fallback CMA-ES raises a stalled
        pose's fitness by less than 3e-4 (nine scenes); off, on 192 scenes (16
        conditions): the same 189 successes and mean errors (0.60 mm, 0.34 deg), median
        time 0.43 -> 0.34 s and 90th percentile 0.81 -> 0.58 s in a two-worker run.
    unconverged_to_cma : bool
        When Gauss-Newton on a level above 0 ends its iterations still climbing, go on
        with ``LocalCMA`` from there. A half-covered No.5 (overlap) left level 2 with its
        depth 11 mm off; Gauss-Newton walked it 1.5 mm in 20 steps and level 0 could not
        recover (8.3 mm, not found); CMA-ES walks it to 1.8 mm and level 0 to 0.1 mm. On
        level 0 CMA-ES ended less precise than the 20 steps (three scenes 0.2-0.4 ->
        0.5-1.1 mm). 192 scenes: 189 successes either way, one changed pose (a failing
        wrinkled garment), the same median time.
    local : LocalCMAConfig
        The CMA-ES refinement (level 0 steps, scaled the same way). It starts with
        0.6 steps and stops below 0.08: the previous level's best is that close (on the 96
        scenes: 2 % fewer evaluations and 12 % less time than 1 and 0.05, the same median
        errors).
    retry_restarts : int
        GA restarts of a second search (:meth:`for_retry`), when the first one's score says
        it missed: more independent runs at the price of a slower answer in those scenes.
    fit_strain : bool
        Gauss-Newton on levels 1 and 0 refines the model's in-plane strain ``(e_xx, e_yy,
        e_xy)`` with the pose (:func:`~photomodel.geometry.strained_matrices`; CMA-ES holds
        it), and the fitness is scored with it. Folds gather cloth, so a wrinkled garment
        lies up to 3-4 % shorter than its photo; a rigid model matched that by tilting
        (foreshortening) and moving away, until its depth and tilt came from the garment's
        size instead of the two cameras' disparity. With the strain free, size and disparity
        no longer trade: on 24 wrinkled scenes (2 per garment) 21 against 13 successes,
        median tilt error 4.0 -> 1.6 deg (benchmark: 54.2 -> 87.5 %); on 192 mixed scenes
        (16 conditions) the same 189 successes, median position error 0.18 -> 0.12 mm. The
        grey sock's depth bias, a band that pulls its low-contrast outline outwards, goes
        into a +0.3 % strain instead of the depth (paper No.6: -1.20 -> -0.42 mm). A garment
        partly hidden can shrink away from its hidden end, so the strain has a prior
        (``GaussNewtonConfig.strain_weights``); with it, 22/24 wrinkled successes, and the
        occluded scenes' largest error 1.75 mm against 1.31 mm rigid (48 gripper and overlap
        scenes, all successes). The strain's Jacobian comes from the translation's
        (``GaussNewtonConfig.strain_by_differences``), so an iteration still evaluates 7
        residual poses.
    coarse_own_colours : bool
        Refine each hypothesis on the coarse level with the garment's own colours before
        the next level. The palette's peak is as wide as the garment and its top is flat:
        the GA's best lies 25-50 mm and about 5 deg from the garment, and from there the next
        level's own colours, whose peaks are as narrow as a print's repeat, settle on the
        print one dot or stripe away (a pose 20 mm off with a score of 0.64-0.68 against the
        true pose's 0.78-0.87). The coarse level's own colours blur the print and keep the
        garment's edge, so they walk in first (on 96 hard scenes: 87 against 82 successes,
        6 % more evaluations). The pose stays flat there, as in the GA: level 3 cannot see a
        small garment's tilt, and a free tilt walked a 130 mm shirt to 14 deg.
    finest_level : int
        The last level refined (0: full resolution). The fitness returned is level 0's at
        the final pose either way, the scale of the found threshold.
    optics_blur_mm : float
        Camera blur of the global stage, mm on the garment.
    optics_blur_candidates_mm : tuple of float
        Camera blurs the local stages choose from (empty: keep ``optics_blur_mm``). None
        is sharper than a camera in focus (0.5 mm): on a plain garment the blur trades with
        the depth, and with 0.0 and 0.3 mm among them the navy trousers settled on 0.0 at a
        pose 2.4 mm too far and 0.75 deg tilted, below the fitness that 0.5 mm reaches at
        the right pose (0.88 against 0.90). On 48 scenes (paper, blur, gripper, overlap):
        48 against 47 successes; No.2's depth error +2.0-2.4 -> -0.3-0.5 mm, No.9's
        +1.2 -> -0.4 mm; the same evaluations.
    optics_blur_margin : float
        Fitness by which a candidate blur must beat the current one to replace it.
    optics_blur_climb : bool
        Level 1 too climbs the candidates from the blur before it (``optics_blur_mm``)
        instead of evaluating every one (level 0 always climbs from level 1's choice). On
        192 + 144 scenes (16 conditions, trial 2; blur, noise, dim, wrinkles, paper and
        vignetting, trials 3-4), each run both ways in one process: the same poses (none
        moved by 0.001 mm), per-scene time 0.986 and 0.965 (ratio of medians 0.96): the
        fitness rises with the blur up to the scene's and falls beyond it, and the climb
        walks up to it.
    ga_with_seeds : bool
        Run the GA also when :func:`pyramid_search` is given seeds (else the seeds replace
        it).
    hypothesis_margin : float
        After the coarse level, only hypotheses within this of the best one's fitness go on
        to the next level, and of those that walked to the same pose (every gene within 2 %
        of its range) only the best. Three scan peaks often end on one garment: on 192
        scenes (16 conditions), 63 % of the hypotheses go on without repeats, 30 % with the
        margin too. Of the 702 hypotheses, one more than 0.2 below the best won at level 2
        (a wrinkled towel; the best ended 6 mm from the truth, it 1 mm). 189/192
        successes either way (188 with every hypothesis), 27 % fewer evaluations.
    shift_sweeps : tuple of (level, reach_mm, step_mm)
        On these levels the refined hypotheses (level 3: every one that goes on; level 2:
        the best) are shifted along the model's own x and y axes by up to ``reach_mm``
        every ``step_mm`` and move to the best shift while one beats them (three rounds at
        most): a striped print has a peak at every repeat, and a local search that starts
        near one keeps it. In the 12 x 1000 study (``9ea5751``) the striped No.4 and No.11
        ended a repeat off (4-21 mm, fitness 0.64-0.72 against the garment's 0.85-0.89)
        in 9 and 8 trials of 1000, every one of them a stripe or two away along the
        model's y axis, some along both. A level-2 sweep alone (30 mm) left 1 and 2:
        hypotheses 41-58 mm away and off along both axes.
    flat_restart_deg : float
        When level 0 ends more than this tilted from the facing plane with a strain that
        shrinks the model (mean of ``e_xx`` and ``e_yy`` below ``-flat_restart_shrink``: folds
        gathered the cloth), level 0 is refined again from the pose laid flat on the plane,
        first with the tilt held, then free, and the better of the two ends wins (0: never).
        Folds across one side of a garment gather that side's cloth, which a uniform strain
        cannot follow; tilting the model foreshortens that side, and Gauss-Newton can end on
        such a tilt although a flatter pose fits better. A wrinkled dress (No.7) ended 5.75
        deg tilted at fitness 0.5405; from the flat pose the same level reaches 0.5510 at 1.03
        deg. 72 wrinkled scenes (trials 0-5 of each garment): 64 -> 66 successes, 8 tilts
        lower by 0.3-4.7 deg, none higher, median time 107 -> 110 ms; 96 tilt, gripper,
        overlap and paper scenes: never triggered (no shrink with a tilt), poses identical.
    flat_restart_shrink : float
        See ``flat_restart_deg``.
    """

    coarse_level: int = 3
    palette_weight: float = 0.5
    ga: GAConfig = field(default_factory=lambda: GAConfig(patience=20, restarts=3,
                                                          min_improvement=0.003))
    refine: RefineConfig = field(default_factory=lambda: RefineConfig(
        population=8, max_iterations=60, min_step_fraction=0.2))
    local_method: Literal["gauss-newton", "cma"] = "gauss-newton"
    gauss_newton: GaussNewtonConfig = field(default_factory=GaussNewtonConfig)
    gauss_newton_max_level: int = 1
    stalled_to_cma: bool = False
    unconverged_to_cma: bool = True
    local: LocalCMAConfig = field(default_factory=lambda: LocalCMAConfig(sigma0=0.6, tolx=0.08))
    coarse_own_colours: bool = True
    finest_level: int = 0
    optics_blur_mm: float = 0.5
    optics_blur_candidates_mm: tuple[float, ...] = (0.5, 0.7, 1.0, 1.4, 2.0, 2.8)
    optics_blur_margin: float = 0.02
    optics_blur_climb: bool = True
    retry_restarts: int = 8
    fit_strain: bool = True
    ga_with_seeds: bool = False
    hypothesis_margin: float = 0.2
    shift_sweeps: tuple[tuple[int, float, float], ...] = ((3, 45.0, 3.0), (2, 15.0, 1.5))
    flat_restart_deg: float = 2.0
    flat_restart_shrink: float = 0.005

    def __post_init__(self) -> None:
        if not 0 <= self.finest_level < self.coarse_level:
            raise ValueError(f"finest_level: expected 0..{self.coarse_level - 1}, "
                             f"got {self.finest_level}")
        if not self.hypothesis_margin >= 0:
            raise ValueError(f"hypothesis_margin: expected >= 0, got {self.hypothesis_margin}")
        if self.local_method not in ("gauss-newton", "cma"):
            raise ValueError(f"local_method: expected 'gauss-newton' or 'cma', "
                             f"got {self.local_method!r}")

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
    if c.coarse_own_colours:
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
    strain = np.zeros(3) if c.fit_strain else None
    for level in range(c.coarse_level - 2, c.finest_level - 1, -1):
        blur, objective, (f0, offsets0), used = _sharpest_fit(
            fitness_at, level, x, c, blur, strain,
            climb=c.optics_blur_climb or level < c.coarse_level - 2)
        evaluations += used
        stages.append(_local_at(objective, f0, level, x, space, c, gen, strain, offsets0))
        x, strain = stages[-1].x, stages[-1].strain
    refined = stages[-1]     # level 0's refinement: its evaluation at x is the current blur's
    known = ({blur: refined.at_x} if refined.at_x is not None and np.array_equal(refined.x, x)
             else None)
    again, objective, (f0, offsets0), used = _sharpest_fit(fitness_at, c.finest_level, x, c,
                                                           blur, strain, climb=True,
                                                           known=known)
    evaluations += used
    if again != blur:
        blur = again
        stages.append(_local_at(objective, f0, c.finest_level, x, space, c, gen, strain,
                                offsets0))
        x, strain = stages[-1].x, stages[-1].strain
    if c.flat_restart_deg > 0 and strain is not None:
        flat, used = _flat_restart(objective, stages[-1], space, c, facing)
        evaluations += used
        if flat is not None:
            stages.append(flat)
            x, strain = flat.x, flat.strain
    last = stages[-1]
    fitness = last.fitness
    if c.finest_level > 0:    # the score is level 0's, as the threshold's
        fitness = float(_strained(fitness_at(0, 0.0, blur), strain)(last.x[None])[0])
        evaluations += 1
    return PyramidResult(
        last.x, fitness, evaluations + sum(r.evaluations for r in stages),
        sum(r.iterations for r in stages), "; ".join(r.stop_reason for r in stages),
        np.concatenate([r.best_history for r in stages]),
        np.concatenate([r.mean_history for r in stages]), strain=strain, optics_blur_mm=blur)


def _flat_restart(objective: Fitness, last: SearchResult, space: SearchSpace,
                  config: PyramidConfig, facing: NDArray[np.float64]
                  ) -> tuple[SearchResult | None, int]:
    """The finest level (fitness ``objective``) again from ``last``'s pose laid flat on the
    plane ``facing``, when it lies more than ``config.flat_restart_deg`` tilted from that
    plane and its strain shrinks the model (``config.flat_restart_shrink``): Gauss-Newton
    with the tilt held, then free. The result when its fitness beats ``last``'s (its
    evaluations all that was spent), else None and the evaluations spent.

    Folds across one side of a garment gather its cloth there, and a uniform strain cannot
    follow them; tilting the model foreshortens that side, and the refinement can end on
    that tilt although a flatter pose fits better."""
    if not conforms(objective, ResidualFitness) or last.strain is None:
        return None, 0
    normal = rotation_from_eps(last.x[3:6])[:, 2]
    tilt_deg = float(np.degrees(np.arccos(np.clip(normal @ facing[:, 2], -1.0, 1.0))))
    if (tilt_deg <= config.flat_restart_deg
            or np.mean(last.strain[:2]) > -config.flat_restart_shrink):
        return None, 0
    start = space.clip(facing_pose_vectors(flat_pose_vectors(last.x, facing), facing)[0])
    level = config.finest_level
    held = gauss_newton_refine(objective, start, space, level, config.gauss_newton,
                               free=np.array([True, True, True, False, False, True]),
                               strain=last.strain)
    free = gauss_newton_refine(objective, held.x, space, level, config.gauss_newton,
                               strain=held.strain)
    used = held.evaluations + free.evaluations
    if not free.fitness > last.fitness:
        return None, used
    return replace(free, evaluations=used, iterations=held.iterations + free.iterations,
                   stop_reason=f"flat restart ({tilt_deg:.1f} deg): {held.stop_reason}, "
                   f"then {free.stop_reason}"), 0


def _strained(objective: Fitness, strain: NDArray[np.float64] | None) -> Fitness:
    """``objective`` of pose vectors with the model strained by ``strain`` (None: as it is);
    a strained objective needs ``evaluate_transforms`` (:class:`ResidualFitness`)."""
    if strain is None:
        return objective
    if not conforms(objective, ResidualFitness):
        raise TypeError("fit_strain needs a fitness of transforms (SoftFitness)")
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
                  strain: NDArray[np.float64] | None = None, climb: bool = False,
                  known: dict[float, tuple[float, NDArray[np.float64]]] | None = None
                  ) -> tuple[float, Fitness, tuple[float, NDArray[np.float64] | None], int]:
    """The camera blur for ``level`` at ``x`` (model strained by ``strain``), that level's
    fitness with it, the fitness at ``x`` with the light offsets it found there (None where
    the fitness has none) and the evaluations spent.

    The candidate with the highest fitness, when it beats ``blur_mm`` (the current one) by
    ``config.optics_blur_margin``; else ``blur_mm``. A plain garment looks the same at every
    blur (its fitness curve is flat to +-0.01), and its noise must not choose one. Each blur
    is evaluated once, the current one among the candidates included.

    With ``climb`` and ``blur_mm`` among the candidates, only the candidates from it up the
    fitness are evaluated (its two neighbours, then on in the direction that rises while it
    does): the highest of a curve with one peak, in 3 evaluations where it stays, instead of
    one per candidate (``PyramidConfig.optics_blur_climb``). Blurs evaluated together (the
    current one and its neighbours; every candidate without the climb) share one pass over
    the images where the fitness allows it (``SoftFitness.evaluate_colourings``: on level 0
    three blurs cost about what two did one at a time).

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
            computed[b] = (f, o.last_offsets() if conforms(o, ResidualFitness) else None)

    def value(b: float) -> float:
        evaluate([b])
        return computed[b][0]

    candidates = tuple(config.optics_blur_candidates_mm)
    if climb and blur_mm in candidates:
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
              space: SearchSpace, config: PyramidConfig, gen: np.random.Generator,
              strain: NDArray[np.float64] | None = None,
              offsets0: NDArray[np.float64] | None = None) -> SearchResult:
    """The finer levels' refinement of ``objective`` (pyramid ``level``, ``f0`` at ``x``,
    where it found the light offsets ``offsets0`` when given) from ``x``: Gauss-Newton or
    ``LocalCMA`` as ``config`` says for ``level``, steps scaled by 2**level. With a
    ``strain``, Gauss-Newton refines it with the pose, and CMA-ES holds it; the result
    carries it. Gauss-Newton starts from ``f0`` and ``offsets0`` instead of evaluating
    ``x`` again (one level-0 evaluation a refinement, 0.3-0.8 ms)."""
    def cma_from(x0: NDArray[np.float64], f_x0: float,
                 held: NDArray[np.float64] | None) -> SearchResult:
        found = run_search(LocalCMA(space, x0, f_x0, config.local.scaled(2.0**level), gen),
                           _strained(objective, held))
        return replace(found, strain=held)

    if not (config.local_method == "gauss-newton" and level <= config.gauss_newton_max_level):
        return cma_from(x, f0, strain)
    if not conforms(objective, ResidualFitness):
        raise TypeError("local_method 'gauss-newton' needs a fitness with residuals "
                        "(SoftFitness)")
    result = gauss_newton_refine(objective, x, space, level, config.gauss_newton,
                                 strain=strain,
                                 start=None if offsets0 is None else (f0, offsets0))
    stalled = config.stalled_to_cma and result.stop_reason == NO_ASCENT
    climbing = (config.unconverged_to_cma and level > 0
                and result.stop_reason == out_of_iterations(config.gauss_newton))
    if not (stalled or climbing):
        return result
    cma = cma_from(result.x, result.fitness, result.strain)
    return SearchResult(cma.x, cma.fitness, result.evaluations + cma.evaluations,
                        result.iterations + cma.iterations,
                        f"{result.stop_reason}, then {cma.stop_reason}",
                        np.concatenate([result.best_history, cma.best_history]),
                        np.concatenate([result.mean_history, cma.mean_history]), cma.strain)


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
