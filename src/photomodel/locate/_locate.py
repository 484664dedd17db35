"""``locate``: find a photo-model's pose in one stereo pair (paper secs. 2.3-2.5)."""

from __future__ import annotations

import functools
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from typing import Any, Literal

import numpy as np
from numpy.typing import NDArray

from photomodel.camera import StereoRig
from photomodel.fitness import (
    PreparedModel,
    ScanConfig,
    ScanResult,
    ScoreTerms,
    SoftFitness,
    StereoFeatures,
    as_prepared,
    make_fitness,
    relight_scan,
    scan_flat_poses,
    score_terms,
)
from photomodel.geometry import (
    in_plane_angle_rad,
    pose_vectors_to_matrices,
    quat_wxyz_from_matrix,
    strained_matrices,
)
from photomodel.locate._prepare import prepare_model
from photomodel.locate._threshold import load_threshold
from photomodel.model import PhotoModel
from photomodel.search import (
    BinaryGA,
    FullSearch,
    FullSearchConfig,
    GAConfig,
    GlobalThenLocal,
    Optimizer,
    PyramidConfig,
    RefineConfig,
    SearchResult,
    SearchSpace,
    run_search,
)

__all__ = [
    "DEFAULT_FITNESS",
    "DEFAULT_MIN_SCORE",
    "PAPER_METHOD",
    "LocateResult",
    "Method",
    "PaperMethod",
    "LocateSettings",
    "locate",
    "locate_in_features",
    "make_optimizer",
    "paper_method",
    "soft_score",
]

OptimizerName = Literal["ga", "full", "rga", "cma", "de"]

DEFAULT_FITNESS = "soft"


@dataclass(frozen=True)
class PaperMethod:
    """The paper's method (sec. 2.5) and its comparison variants: a fitness of
    :data:`~photomodel.fitness.FITNESS_PRESETS` searched by a global optimiser.

    ``PaperMethod()`` is the paper as read here: the ``paper`` fitness (eq. 9's votes), the
    binary GA (60 individuals, 6 genes of 12 bits) without restarts, no local refinement.

    Attributes
    ----------
    fitness : str
        A name of :data:`~photomodel.fitness.FITNESS_PRESETS` (``paper``, ``balanced``).
    optimizer : {"ga", "full", "rga", "cma", "de"}
        The binary GA, the full grid search, or the comparison optimisers (real-coded GA,
        CMA-ES, differential evolution).
    refine : bool
        Follow the global search with :class:`~photomodel.search.LocalRefine`.
    ga : GAConfig
        The binary GA's settings (default ``GAConfig.paper()``).
    full : FullSearchConfig, optional
        The grid of ``optimizer="full"``.
    refine_config : RefineConfig, optional
    min_score : float
        Score in [0, 1] from which the garment counts as found (not calibrated).
    """

    fitness: str = "paper"
    optimizer: OptimizerName = "ga"
    refine: bool = False
    ga: GAConfig = field(default_factory=GAConfig.paper)
    full: FullSearchConfig | None = None
    refine_config: RefineConfig | None = None
    min_score: float = 0.5

    def __post_init__(self) -> None:
        from photomodel.fitness import FITNESS_PRESETS

        if self.fitness not in FITNESS_PRESETS:
            raise ValueError(f"fitness: expected one of {sorted(FITNESS_PRESETS)}, "
                             f"got {self.fitness!r}")
        if self.optimizer not in ("ga", "full", "rga", "cma", "de"):
            raise ValueError(f"optimizer: expected 'ga', 'full', 'rga', 'cma' or 'de', "
                             f"got {self.optimizer!r}")
        if not 0.0 <= self.min_score <= 1.0:
            raise ValueError(f"min_score: expected a score in [0, 1], got {self.min_score}")


PAPER_METHOD = PaperMethod()
"""The paper's method as read here (:class:`PaperMethod` with its defaults)."""

Method = Literal["default", "paper"] | PaperMethod
"""A locate method: ``"default"`` (the ``soft`` fitness searched coarse to fine),
``"paper"`` (:data:`PAPER_METHOD`) or a :class:`PaperMethod`."""

DEFAULT_MIN_SCORE = PAPER_METHOD.min_score
"""Score from which the garment counts as found with the paper's method (not calibrated).
The default method uses the calibrated threshold (:func:`~photomodel.locate.load_threshold`)."""


def paper_method(method: Method) -> PaperMethod | None:
    """The :class:`PaperMethod` that ``method`` names, None for the default method."""
    if isinstance(method, PaperMethod):
        return method
    if method == "default":
        return None
    if method == "paper":
        return PAPER_METHOD
    raise ValueError(f"method: expected 'default', 'paper' or a PaperMethod, got {method!r}")


@dataclass(frozen=True)
class LocateResult:
    """The pose found for one model in one stereo pair (the ``locate --json`` contract,
    docs/contracts.md: :meth:`to_json_dict`).

    Attributes
    ----------
    model : str
        The model's name.
    found : bool
        ``score >= min_score`` (the calibrated threshold for the default method, the
        :class:`PaperMethod`'s ``min_score`` for the paper's).
    T_cam1_model : ndarray (4, 4)
        The best pose found, found or not: maps model coordinates (mm) to camera 1's
        (OpenCV frame, the reference camera). Rigid; the fitted :attr:`strain` is in
        :attr:`A_cam1_model`.
    fitness : float
        The search's best fitness, in its fitness's own units: the ``soft`` fitness for the
        default method, the :class:`PaperMethod`'s (eq. 9's ``F`` for the paper's).
    score : float
        The score in [0, 1] that ``found`` compares: the default method's mean of the
        level-0 fitness and the outline evidence, each patch free to slide up to 1 mm
        (:func:`~photomodel.fitness.score_terms`; a tracked frame's without the slack); a
        :class:`PaperMethod`'s fitness over its maximum, clipped (eq. 9: ``F / (2 N_in)``).
    seconds : float
        Wall-clock time of the call, s (the images' features and the search; on a model's
        first pair its preparation too).
    search : SearchResult
        The search that gave the pose: pose vector, evaluations (summed over every search
        of the call), iterations, why it stopped, the fitted strain and camera blur.
    edge_evidence : float
        Share of the model's outline both cameras see as an edge at the pose (no slack), in
        [0, 1]; NaN with the paper's method.
    visible_outline : float
        Outline evidence where the model's inside agrees
        (:attr:`~photomodel.fitness.ScoreTerms.visible_outline`), in [0, 1]; NaN when not
        measured.
    scale : float or None
        For a model of unknown scale, real millimetres per nominal millimetre measured from
        this pair (:func:`~photomodel.locate.locate_unknown_scale`); None otherwise.
    """

    model: str
    found: bool
    T_cam1_model: NDArray[np.float64]
    fitness: float
    score: float
    seconds: float
    search: SearchResult
    edge_evidence: float = float("nan")
    visible_outline: float = float("nan")
    scale: float | None = None

    @property
    def position_mm(self) -> NDArray[np.float64]:
        """Origin of the model frame in camera 1, (3,) mm."""
        return self.T_cam1_model[:3, 3].copy()

    @property
    def quat_wxyz(self) -> NDArray[np.float64]:
        """Orientation of the model in camera 1, (w, x, y, z), w >= 0."""
        return quat_wxyz_from_matrix(self.T_cam1_model[:3, :3])

    @property
    def theta_deg(self) -> float:
        """In-plane angle of the model x axis about camera 1's z axis, degrees."""
        return float(np.rad2deg(in_plane_angle_rad(self.T_cam1_model[:3, :3])))

    @property
    def strain(self) -> NDArray[np.float64] | None:
        """In-plane strain ``(e_xx, e_yy, e_xy)`` of the model that the ``soft`` search fitted
        with the pose (:func:`~photomodel.geometry.strained_matrices`), None for the other
        fitnesses. Negative: the garment lies shorter along that model axis than in its
        photo (gathered by wrinkles); -0.02 is 2 mm on 100 mm."""
        strain = self.search.strain
        return None if strain is None else np.asarray(strain, dtype=np.float64).copy()

    @property
    def A_cam1_model(self) -> NDArray[np.float64]:
        """The affine map (4, 4) of model points into camera 1 that the score was measured
        at: ``T_cam1_model`` with the fitted :attr:`strain` (``T_cam1_model`` without one).
        The outline drawn on the images."""
        return _affine(self.search)

    @property
    def optics_blur_mm(self) -> float | None:
        """The camera blur the ``soft`` search estimated (Gaussian sigma, mm on the garment;
        about 0.86 mm per pixel at the working distance), None for the other fitnesses. A
        camera in focus gives about 0.5; much more says focus, motion or a dirty lens."""
        blur = getattr(self.search, "optics_blur_mm", None)
        return None if blur is None else float(blur)

    def to_json_dict(self) -> dict[str, Any]:
        """The ``locate --json`` object (docs/contracts.md), plus search details; ``scale``
        only for a model of unknown scale."""
        return {
            "model": self.model,
            "found": self.found,
            "T_cam1_model": self.T_cam1_model.tolist(),
            "position_mm": self.position_mm.tolist(),
            "quat_wxyz": self.quat_wxyz.tolist(),
            "theta_deg": self.theta_deg,
            "fitness": self.fitness,
            "score": self.score,
            "seconds": self.seconds,
            "evaluations": self.search.evaluations,
            "generations": self.search.iterations,
            "stop_reason": self.search.stop_reason,
            "optics_blur_mm": self.optics_blur_mm,
            "strain": None if self.strain is None else self.strain.tolist(),
            "edge_evidence": None if np.isnan(self.edge_evidence) else self.edge_evidence,
        } | ({} if self.scale is None else {"scale": self.scale})


def make_optimizer(name: OptimizerName, space: SearchSpace,
                   rng: int | np.random.Generator | None = None,
                   ga_config: GAConfig | None = None,
                   full_config: FullSearchConfig | None = None) -> Optimizer:
    """Build the named optimiser over ``space``.

    "ga" and "full" are the paper's methods (with ``ga_config`` / ``full_config``); "rga"
    (real-coded GA), "cma" (CMA-ES with IPOP restarts) and "de" (differential evolution)
    use their default settings.
    """
    from photomodel.search import CMAES, DifferentialEvolution, RealGA

    if name == "ga":
        return BinaryGA(space, ga_config, rng=rng)
    if name == "full":
        return FullSearch(space, full_config)
    if name == "rga":
        return RealGA(space, rng=rng)
    if name == "cma":
        return CMAES(space, rng=rng)
    if name == "de":
        return DifferentialEvolution(space, rng=rng)
    raise ValueError(f"optimizer: expected 'ga', 'full', 'rga', 'cma' or 'de', got {name!r}")


def locate(
    model: PhotoModel | PreparedModel,
    rig: StereoRig,
    right_bgr: NDArray[np.uint8],
    left_bgr: NDArray[np.uint8],
    *,
    method: Method = "default",
    rng: int | np.random.Generator | None = None,
    space: SearchSpace | None = None,
    min_score: float | None = None,
    progress: Callable[[Optimizer], None] | None = None,
) -> LocateResult:
    """Search the pose ``T_cam1_model`` of ``model`` that best explains both images.

    One call of a new :class:`~photomodel.Locator`: for one pair only. A cell that locates
    one model in many stereo pairs keeps a ``Locator``, so that the model is prepared once.

    Parameters
    ----------
    model : PhotoModel or PreparedModel
    rig : StereoRig
        Camera 1 is the reference (the paper's right camera).
    right_bgr, left_bgr : ndarray (H, W, 3) uint8
        Images of camera 1 and camera 2; sizes are checked against the calibration.
    method : {"default", "paper"} or PaperMethod
        ``"default"``: :class:`~photomodel.fitness.SoftFitness` searched coarse to fine over
        a feature pyramid (:func:`locate_in_features`). ``"paper"`` or a
        :class:`PaperMethod`: a fitness of :data:`~photomodel.fitness.FITNESS_PRESETS`
        searched by a global optimiser.
    rng : int, Generator or None
        Seed of the stochastic search.
    space : SearchSpace, optional
        Defaults to the paper's experiment with the tilt measured from the table that faces
        the rig (``SearchSpace.from_ranges(R_cam1_plane=rig.R_cam1_facing)``).
    min_score : float, optional
        Score in [0, 1] from which the garment counts as found. Default: the calibrated
        threshold (:func:`~photomodel.locate.load_threshold`) for the default method, the
        :class:`PaperMethod`'s ``min_score`` otherwise.
    progress : callable, optional
        Called with the optimiser after each generation (paper methods).

    Returns
    -------
    LocateResult
    """
    from photomodel.locate._locator import Locator

    locator = Locator(model, rig, space, method, min_score=min_score)
    return locator(right_bgr, left_bgr, rng, progress=progress)


def locate_paper(model: PhotoModel, rig: StereoRig, right_bgr: NDArray[np.uint8],
                 left_bgr: NDArray[np.uint8], paper: PaperMethod, *, space: SearchSpace,
                 min_score: float, rng: int | np.random.Generator | None = None,
                 progress: Callable[[Optimizer], None] | None = None,
                 t0: float | None = None) -> LocateResult:
    """The paper's way (:class:`PaperMethod`): its fitness of both images searched by a
    global optimiser (``progress`` called after each generation), on images of checked
    sizes; ``found`` from ``min_score``."""
    t0 = time.perf_counter() if t0 is None else t0
    gen = np.random.default_rng(rng)
    objective = make_fitness(paper.fitness, model, rig, right_bgr, left_bgr)
    opt = make_optimizer(paper.optimizer, space, gen, paper.ga, paper.full)
    if paper.refine:
        opt = GlobalThenLocal(opt, space, paper.refine_config, gen)
    result = run_search(opt, objective, progress)
    T = pose_vectors_to_matrices(result.x)[0]
    score = objective.score(result.fitness)
    return LocateResult(model.name, bool(score >= min_score), T, float(result.fitness), score,
                        time.perf_counter() - t0, result)


COARSE_SCAN = ScanConfig(level=4, detail_level=3, theta_step_deg=8.0, rank_margin=0.15)
"""The first scan of :func:`locate_in_features`: level 4 with level 3's sample points, angles
8 deg apart, hypotheses within 0.15 of the best; level 3's scan follows only when it is not
trusted (after relighting) or the search from its peaks scores under :data:`COARSE_MIN_SCORE`
(or the threshold, where higher). Why these values: docs/method/scan.md."""

COARSE_MIN_SCORE = 0.6
"""The score from which the search from :data:`COARSE_SCAN`'s peaks ends the work (or the
threshold, where higher); below it level 3's scan and search follow and the better score
wins. Level 4's peaks lie up to half its pixel (7 mm) off, so a striped print can end one
stripe off at a score above the found threshold yet well below its true pose's."""


@dataclass(frozen=True)
class LocateSettings:
    """How :func:`locate_in_features` searches (its tuning, the same for every pair).

    Attributes
    ----------
    retries : int
        The first search starts from the peaks of
        :func:`~photomodel.fitness.scan_flat_poses`. The scan sees the garment as lit at the
        model station; when its best score is too low to trust
        (``ScanConfig.trusted_score``), it looks again with the light offsets the scene's
        colours suggest (:func:`~photomodel.fitness.relight_scan`), and only when that is
        not trusted either does the first search run the GA beside the peaks. While the
        best score stays below ``min_score``, it searches again, at most this many times,
        with the GA beside the same peaks (continuing the random stream, with more
        restarts: :meth:`~photomodel.search.PyramidConfig.for_retry`), and keeps the best;
        after a trusted scan, the first retry also starts from the relit scan's peaks (an
        overexposed print can keep a wrong peak above ``trusted_score``). A scene without
        the garment costs ``1 + retries`` searches (one more after a trusted coarse scan).
    pyramid : PyramidConfig
        Settings of the coarse-to-fine search; a retry runs their
        :meth:`~photomodel.search.PyramidConfig.for_retry`.
    coarse_scan : ScanConfig or None
        Before all this, a cheaper scan (default :data:`COARSE_SCAN`, level 4, when the
        features have it; relit when it is not trusted and its ``relight`` allows); when it
        is trusted, a search from its peaks comes first, and when that scores at least
        ``min_score`` and ``coarse_min_score`` it is the result. Otherwise the above
        follows, and the result is the best of every search. None: no coarse scan.
    coarse_min_score : float
        The score from which the coarse scan's search ends the work (default
        :data:`COARSE_MIN_SCORE`; a garment partly under others scores less in full truth).
    """

    retries: int = 1
    pyramid: PyramidConfig = field(default_factory=PyramidConfig)
    coarse_scan: ScanConfig | None = COARSE_SCAN
    coarse_min_score: float = COARSE_MIN_SCORE

    def __post_init__(self) -> None:
        if self.retries < 0:
            raise ValueError(f"retries: expected >= 0, got {self.retries}")


def locate_in_features(
    model: PhotoModel | PreparedModel,
    features: StereoFeatures,
    *,
    space: SearchSpace | None = None,
    rng: int | np.random.Generator | None = None,
    min_score: float | None = None,
    t0: float | None = None,
    settings: LocateSettings | None = None,
    scan: ScanResult | None = None,
    coarse: ScanResult | None = None,
    second_look: bool = False,
    seeds: Sequence[NDArray[np.float64]] | None = None,
) -> LocateResult:
    """Locate ``model`` with the ``soft`` method in a stereo pair already turned into features.

    Computing :class:`~photomodel.fitness.StereoFeatures` once and calling this for several
    models shares the image conversion and pyramids between them (``identify``). A model's
    first stereo pair with a rig and search box also prepares the model for them
    (:func:`~photomodel.locate.prepare_model`: its samples at every level and camera blur,
    its scans' kernels), so that no later pair pays for them. The stages: the coarse scan
    and a search from its peaks, then, unless that scored enough, the full scan and its
    searches (:class:`LocateSettings` says how).

    Parameters
    ----------
    model : PhotoModel or PreparedModel
    features : StereoFeatures
        Both images' feature pyramids and the rig.
    space : SearchSpace, optional
        Defaults to the paper's experiment, the tilt measured from the table that faces the
        rig (as in :func:`locate`).
    rng : int, Generator or None
        Seed of the stochastic search.
    min_score : float, optional
        Score in [0, 1] from which the garment counts as found (default: the calibrated
        threshold, :func:`~photomodel.locate.load_threshold`).
    t0 : float, optional
        ``time.perf_counter()`` at which the work began (default: now); ``seconds`` counts
        from it.
    settings : LocateSettings, optional
        How it searches (default ``LocateSettings()``).
    scan : ScanResult, optional
        This model's :func:`~photomodel.fitness.scan_flat_poses` of ``features`` with
        ``space``'s bounds, when the caller has it already (it is deterministic; an
        untrusted one is relit here). No coarse scan runs then.
    coarse : ScanResult, optional
        This model's scan of ``features`` with the settings' ``coarse_scan`` and ``space``'s
        bounds, when the caller has it already (``identify`` scans its candidates to order
        them).
    second_look : bool
        The caller searched once already (``identify``'s second look): every search runs the
        retry configuration.
    seeds : sequence of ndarray (6,), optional
        Pose vectors near the answer (a tracker's last pose): one search from these, at the
        pyramid's coarse level, and no scan.

    Returns
    -------
    LocateResult
    """
    t0 = time.perf_counter() if t0 is None else t0
    model = as_prepared(model)
    if min_score is None:
        min_score = load_threshold().min_score
    run = _Search(model, features, space or SearchSpace.from_ranges(
        R_cam1_plane=features.rig.R_cam1_facing), settings or LocateSettings(),
        np.random.default_rng(rng), second_look)
    prepare_model(model, features, space=run.space, pyramid=run.settings.pyramid,
                  scans=() if seeds is not None else (None if scan is not None
                                                      else run.settings.coarse_scan,
                                                      ScanConfig()))
    if seeds is not None:
        run.search([np.asarray(s, dtype=np.float64) for s in seeds], run.settings.pyramid)
    else:
        if scan is None:
            run.coarse_stage(coarse)
        if not run.attempts or run.best_score() < max(min_score,
                                                      run.settings.coarse_min_score):
            run.full_stage(scan, min_score)
    return run.result(model.name, min_score, t0)


class _Search:
    """The searches of one :func:`locate_in_features` call and their results."""

    def __init__(self, model: PreparedModel, features: StereoFeatures, space: SearchSpace,
                 settings: LocateSettings, gen: np.random.Generator, second_look: bool
                 ) -> None:
        self.model, self.features, self.space = model, features, space
        self.settings, self.gen, self.second_look = settings, gen, second_look
        self.attempts: list[tuple[Any, ScoreTerms]] = []
        # one fitness object per (level, palette weight, blur) for every search and score
        self.fitness_at = functools.cache(
            lambda level, weight, blur: SoftFitness(model, features, level,
                                                    palette_weight=weight,
                                                    optics_blur_mm=blur))

    def search(self, seeds: list[NDArray[np.float64]], settings: PyramidConfig) -> None:
        """One coarse-to-fine search from ``seeds``, scored at level 0."""
        from photomodel.search import pyramid_search

        attempt = pyramid_search(self.fitness_at, self.space, settings, rng=self.gen,
                                 seeds=seeds, R_cam1_facing=self.features.rig.R_cam1_facing)
        terms = score_terms(self.fitness_at(0, 0.0, attempt.optics_blur_mm), _affine(attempt))
        self.attempts.append((attempt, terms))

    def best_score(self) -> float:
        return max(a[1].score for a in self.attempts)

    def _scan(self, config: ScanConfig | None = None) -> ScanResult:
        lower, upper = self.space.lower, self.space.upper
        return (scan_flat_poses(self.model, self.features, lower, upper, config)
                if config is not None else scan_flat_poses(self.model, self.features, lower,
                                                           upper))

    def coarse_stage(self, coarse: ScanResult | None) -> None:
        """The coarse scan (given, or made), relit when not trusted, and a search from its
        peaks when it is trusted (not on a second look)."""
        config = self.settings.coarse_scan
        if config is None or config.level >= self.features.levels:
            return
        first = coarse or self._scan(config)
        if not first.trusted and config.relight:
            first = relight_scan(self.model, self.features, self.space.lower,
                                 self.space.upper, config, keep=first) or first
        if first.trusted and not self.second_look:
            self.search(list(first.poses), self.settings.pyramid)

    def full_stage(self, scan: ScanResult | None, min_score: float) -> None:
        """Level 3's scan (relit when not trusted) and searches from its peaks, again with
        the retry configuration while the best score is under ``min_score``."""
        config = self.settings.pyramid
        scan = scan or self._scan()
        relit = not scan.trusted
        if relit:
            scan = relight_scan(self.model, self.features, self.space.lower, self.space.upper,
                                keep=scan) or scan
        if not scan.trusted:
            config = replace(config, ga_with_seeds=True)
        seeds = list(scan.poses)
        searches = 0
        while searches <= self.settings.retries and (searches == 0
                                                     or self.best_score() < min_score):
            if searches == 1 and not relit:  # a trusted scan's peaks missed: relight them too
                again = relight_scan(self.model, self.features, self.space.lower,
                                     self.space.upper)
                seeds = [*(again.poses if again is not None else []), *seeds]
            self.search(seeds, config if searches == 0 and not self.second_look
                        else config.for_retry())
            searches += 1

    def result(self, name: str, min_score: float, t0: float) -> LocateResult:
        """The best attempt as a :class:`LocateResult`."""
        best, terms = max(self.attempts, key=lambda a: a[1].score)
        if len(self.attempts) > 1:
            best = replace(best, evaluations=sum(a[0].evaluations for a in self.attempts),
                           stop_reason=f"best of {len(self.attempts)} searches: "
                                       f"{best.stop_reason}")
        T = pose_vectors_to_matrices(best.x)[0]
        return LocateResult(name, bool(terms.score >= min_score), T, float(best.fitness),
                            terms.score, time.perf_counter() - t0, best, terms.edge_evidence,
                            terms.visible_outline)


def _affine(search: SearchResult) -> NDArray[np.float64]:
    """The map of model points into camera 1 at ``search``'s pose and strain."""
    if search.strain is None:
        return pose_vectors_to_matrices(search.x)[0]
    return strained_matrices(search.x, search.strain)[0]


def soft_score(fitness: float, edge_evidence: float) -> float:
    """The ``soft`` method's rigid score in [0, 1]: the mean of the level-0 fitness (clipped
    to [0, 1]) and the outline evidence (:func:`~photomodel.fitness.edge_evidence`).
    ``locate`` measures the same mean with each patch of the model free to slide by up to
    1 mm (:func:`~photomodel.fitness.score_terms`); without the slack it is this.

    The fitness says how well the model's colours agree inside and disagree in the band
    around it; the outline evidence, how much of the outline shows as an edge. A garment
    half hidden by a gripper keeps a sharp visible outline (fitness 0.3, evidence 0.5); a
    plain model laid in a region of about its colour agrees inside but shows no outline
    (fitness 0.3-0.4, evidence 0.2-0.3): the sum separates the two where the fitness alone
    does not.
    """
    return 0.5 * (float(np.clip(fitness, 0.0, 1.0)) + float(np.clip(edge_evidence, 0.0, 1.0)))
