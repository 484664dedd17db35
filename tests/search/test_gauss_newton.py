"""Gauss-Newton refinement: its walk to the peak, its stop rules and the pyramid's use of it."""

from __future__ import annotations

from dataclasses import replace
from functools import lru_cache

import numpy as np
import pytest

from photomodel.experiments._trials import ExperimentConfig, Trial, trial_inputs
from photomodel.fitness import SoftFitness, StereoFeatures
from photomodel.geometry import (
    eps_from_rotation,
    pose_vectors_to_matrices,
    strained_matrices,
)
from photomodel.search import (
    GaussNewtonConfig,
    NormalEquationsFitness,
    PyramidConfig,
    SearchSpace,
    gauss_newton_refine,
)
from photomodel.search._gauss_newton import NO_ASCENT, _map_derivatives
from photomodel.search._pyramid import _local_at

SPACE = SearchSpace.from_ranges()


def _genes(T: np.ndarray) -> np.ndarray:
    """Pose vectors and strains (P, 9) of maps (P, 4, 4): the rotation is the polar factor."""
    U, _, Vt = np.linalg.svd(T[:, :3, :3])
    R = U @ Vt
    S = np.einsum("pji,pjk->pik", R, T[:, :3, :3])
    strain = np.stack([S[:, 0, 0] - 1, S[:, 1, 1] - 1, 0.5 * (S[:, 0, 1] + S[:, 1, 0])], 1)
    return np.concatenate([T[:, :3, 3], np.stack([eps_from_rotation(M) for M in R]), strain], 1)


class LinearResiduals:
    """A fitness of the ``soft`` form whose residuals are linear in the pose and the model's
    strain: ``r_j = B_j (x - target)`` in pixel-like units, mean agreement of 200 points.

    Its normal equations are the residuals' exact gradient and Gauss-Newton metric (times
    ``metric_scale``: a metric steeper than the fitness's curvature, as the ``soft``
    fitness's inner-point metric is), the genes' Jacobian taken through the map derivatives
    ``dA`` it is given."""

    def __init__(self, target: np.ndarray, seed: int = 0,
                 strain: tuple[float, float, float] = (0.0, 0.0, 0.0),
                 metric_scale: float = 1.0) -> None:
        rng = np.random.default_rng(seed)
        unit = np.array([1.0, 1.0, 0.2, 800.0, 800.0, 400.0])   # mm and eps to ~pixels
        self.B = rng.normal(size=(200, 3, 6)) * unit / 3.0
        self.B_strain = rng.normal(size=(200, 3, 3)) * 100.0 / 3.0   # 1 % to ~a pixel
        self.target = np.concatenate([target, strain])
        self.metric_scale = metric_scale
        self.calls = 0
        self.normal_calls = 0

    def _r(self, genes: np.ndarray) -> np.ndarray:
        d = genes - self.target
        return (np.einsum("nij,pj->pni", self.B, d[:, :6])
                + np.einsum("nij,pj->pni", self.B_strain, d[:, 6:]))

    def _value(self, genes: np.ndarray) -> np.ndarray:
        return np.exp(-0.5 * np.sum(self._r(genes) ** 2, axis=-1)).mean(axis=1)

    def __call__(self, poses: np.ndarray) -> np.ndarray:
        return self.evaluate_transforms(pose_vectors_to_matrices(poses))

    def evaluate_transforms(self, T: np.ndarray) -> np.ndarray:
        self.calls += len(T)
        return self._value(_genes(T))

    def last_offsets(self) -> np.ndarray:
        return np.zeros((2, 3))

    def normal_equations(self, A: np.ndarray, dA: np.ndarray, offsets: np.ndarray,
                         with_offsets: bool = False) -> tuple[np.ndarray, np.ndarray]:
        self.normal_calls += 1
        genes = _genes(A[None])[0]
        every = _map_derivatives(genes, np.ones(9, dtype=bool)).reshape(9, 16)
        motion = np.linalg.lstsq(every.T, dA.reshape(len(dA), 16).T, rcond=None)[0]  # (9, G)
        J = np.einsum("nij,jg->nig", np.concatenate([self.B, self.B_strain], axis=2), motion)
        r = self._r(genes[None])[0]
        a = np.exp(-0.5 * np.sum(r**2, axis=-1)) / len(r)
        return (-np.einsum("n,nig,ni->g", a, J, r),
                self.metric_scale * np.einsum("n,nig,nih->gh", a, J, J))


TARGET = np.array([37.0, -52.0, 702.0, 0.03, -0.02, 0.21])


def test_gauss_newton_solves_linear_residuals_in_a_few_steps() -> None:
    fitness = LinearResiduals(TARGET)
    assert isinstance(fitness, NormalEquationsFitness)
    x0 = TARGET + np.array([0.6, -0.4, 2.0, 0.0008, -0.0005, 0.0006])
    result = gauss_newton_refine(fitness, x0, SPACE)
    np.testing.assert_allclose(result.x[:3], TARGET[:3], atol=0.02)
    np.testing.assert_allclose(result.x[3:], TARGET[3:], atol=2e-5)
    assert result.fitness > 0.999 and result.iterations <= 8
    assert result.stop_reason == "gauss-newton: converged"
    # One set of normal equations per accepted step, every fitness call counted.
    assert fitness.normal_calls == result.iterations
    assert result.evaluations == fitness.calls + fitness.normal_calls


def test_gauss_newton_moves_only_the_free_genes_and_never_falls_below_its_start() -> None:
    fitness = LinearResiduals(TARGET, seed=1)
    x0 = TARGET + np.array([0.5, 0.3, 1.0, 0.0007, 0.0, 0.0])
    free = np.array([True, True, True, False, False, True])
    result = gauss_newton_refine(fitness, x0, SPACE, free=free)
    np.testing.assert_array_equal(result.x[~free], x0[~free])
    assert result.fitness >= float(fitness(x0[None])[0])
    at_peak = gauss_newton_refine(fitness, TARGET, SPACE)
    np.testing.assert_allclose(at_peak.x, TARGET, atol=1e-9)
    assert at_peak.fitness == pytest.approx(1.0)


def test_gauss_newton_fits_the_strain_of_a_shrunk_garment() -> None:
    """With a start strain, the strain is refined with the pose: the rigid refinement of a
    model that is 2 % too long on one axis cannot reach the peak, the strained one does."""
    fitness = LinearResiduals(TARGET, strain=(-0.02, 0.01, 0.005))
    x0 = TARGET + np.array([0.6, -0.4, 2.0, 0.0008, -0.0005, 0.0006])
    rigid = gauss_newton_refine(fitness, x0, SPACE)
    assert rigid.strain is None and rigid.fitness < 0.6
    fitness.calls = fitness.normal_calls = 0
    free = GaussNewtonConfig(strain_weights=(0.0, 0.0))
    strained = gauss_newton_refine(fitness, x0, SPACE, strain=np.zeros(3), config=free)
    np.testing.assert_allclose(strained.strain, [-0.02, 0.01, 0.005], atol=1e-4)
    np.testing.assert_allclose(strained.x[:3], TARGET[:3], atol=0.02)
    assert strained.fitness > 0.999
    assert strained.evaluations == fitness.calls + fitness.normal_calls
    capped = gauss_newton_refine(fitness, x0, SPACE, strain=np.zeros(3),
                                 config=replace(free, max_strain=0.01))
    assert np.all(np.abs(capped.strain) <= 0.01 + 1e-12)
    # The prior holds the strain back, the more so the more it weighs, and the shape
    # (e_xx - e_yy, e_xy) by its own weight: the mean strain -0.005 is kept.
    held = [gauss_newton_refine(fitness, x0, SPACE, strain=np.zeros(3),
                                config=replace(free, strain_weights=(0.0, w))).strain
            for w in (30.0, 1e6)]
    moved = [float(np.abs(h - strained.strain).max()) for h in held]
    assert 1e-4 < moved[0] < moved[1]
    assert np.abs(held[1][0] - held[1][1]) < 1e-3 and abs(held[1][2]) < 1e-3
    assert held[1][:2].mean() == pytest.approx(-0.005, abs=1e-3)
    prior = GaussNewtonConfig(strain_weights=(2.0, 5.0)).strain_prior()
    e = np.array([-0.02, 0.01, 0.005])
    assert e @ prior @ e == pytest.approx(2.0 * 0.005**2 + 5.0 * (0.015**2 + 0.005**2))


@lru_cache(maxsize=2)
def _case(garment: str):
    config = ExperimentConfig(garments=(garment,), conditions=("paper",), trials=1, seed=0)
    model, rig, right, left, T, _ = trial_inputs(
        config, Trial(f"paper_{garment}_0000", garment, "paper", 0))
    return model, StereoFeatures(rig, right, left), T


@pytest.mark.parametrize("level", [0, 1])
def test_residuals_give_the_fitness_at_the_offsets_the_fitness_found(level: int) -> None:
    """Residuals at the light offsets of a full evaluation reproduce each camera's term,
    the edge mixture of the inner ring included."""
    model, features, T = _case("No.1")
    fitness = SoftFitness(model, features, level)
    assert fitness.edge_mix_fraction > 0
    poses = np.stack([T, T @ pose_vectors_to_matrices([[1.5, -1.0, 3.0, 0.01, 0, 0.02]])[0]])
    fitness.evaluate_transforms(poses)
    for p in range(2):
        offsets = fitness.last_terms[p, :, 3:6]
        r, ok = fitness.residuals(poses[p:p + 1], offsets)
        agreement = np.exp(-0.5 * np.sum(r[0] ** 2, axis=-1)) * ok[0]
        agreement[:, len(fitness.samples.p_in):] += ~ok[0, :, len(fitness.samples.p_in):]
        term = agreement @ fitness.residual_weights()   # a band point off the image agrees 1
        penalty = features.match.wb_weight * (offsets[:, 1] ** 2 + offsets[:, 2] ** 2)
        np.testing.assert_allclose(term - penalty, fitness.last_terms[p, :, 0], atol=1e-9)


def test_gauss_newton_refines_a_rendered_garment_from_a_pixel_away() -> None:
    model, features, T = _case("No.1")
    fitness = SoftFitness(model, features, 0)
    truth = np.concatenate([T[:3, 3], eps_from_rotation(T[:3, :3])])
    f_truth = float(fitness(truth[None])[0])
    for seed in range(2):
        kick = np.random.default_rng(seed).normal(size=6) * [0.5, 0.5, 1.5, 0.002, 0.002, 0.001]
        result = gauss_newton_refine(fitness, truth + kick, SPACE)
        M = pose_vectors_to_matrices(result.x)[0]
        assert np.linalg.norm(M[:3, 3] - T[:3, 3]) < 0.5
        angle = np.degrees(np.arccos(np.clip((np.trace(M[:3, :3].T @ T[:3, :3]) - 1) / 2, -1, 1)))
        assert angle < 0.5
        assert result.fitness >= f_truth - 0.005 and result.evaluations < 200


def test_a_start_the_caller_evaluated_is_not_evaluated_again() -> None:
    """Given the fitness and light offsets at the start (the pyramid's blur choice evaluated
    it), Gauss-Newton walks the same way to the same pose with one evaluation fewer; a start
    outside the box is clipped and evaluated as before."""
    model, features, T = _case("No.1")
    fitness = SoftFitness(model, features, 0)
    x0 = np.concatenate([T[:3, 3] + [0.4, -0.3, 1.0], eps_from_rotation(T[:3, :3]) + 0.001])
    strain = np.array([-0.004, 0.002, 0.001])
    f0 = float(fitness.evaluate_transforms(strained_matrices(x0[None], strain))[0])
    start = (f0, fitness.last_offsets())
    alone = gauss_newton_refine(fitness, x0, SPACE, strain=strain)
    started = gauss_newton_refine(fitness, x0, SPACE, strain=strain, start=start)
    np.testing.assert_array_equal(started.x, alone.x)
    np.testing.assert_array_equal(started.strain, alone.strain)
    assert started.fitness == alone.fitness and started.iterations == alone.iterations
    assert started.evaluations == alone.evaluations - 1
    # Its own evaluation at the end, as the fitness returns it there (the pyramid's blur
    # check takes it instead of evaluating again).
    assert alone.at_x is not None
    end = float(fitness.evaluate_transforms(strained_matrices(alone.x[None], alone.strain))[0])
    assert alone.at_x[0] == end
    np.testing.assert_array_equal(alone.at_x[1], fitness.last_offsets())
    outside = x0.copy()
    outside[2] = SPACE.upper[2] + 5.0
    wrong = (f0 + 1.0, start[1])    # not the clipped pose's: must not be used
    clipped = gauss_newton_refine(fitness, outside, SPACE, strain=strain, start=wrong)
    plain = gauss_newton_refine(fitness, outside, SPACE, strain=strain)
    np.testing.assert_array_equal(clipped.x, plain.x)
    assert clipped.evaluations == plain.evaluations and clipped.fitness < f0 + 1.0


def test_gauss_newton_checks_its_input() -> None:
    with pytest.raises(TypeError, match="normal equations"):
        gauss_newton_refine(lambda x: np.zeros(len(x)), TARGET, SPACE)  # type: ignore[arg-type]
    with pytest.raises(TypeError, match="normal equations"):
        _local_at(lambda x: np.zeros(len(x)), 0.0, 0, TARGET, SPACE, PyramidConfig())
    with pytest.raises(ValueError, match="difference_steps"):
        GaussNewtonConfig(difference_steps=(0.1,) * 5)
    with pytest.raises(ValueError, match="coarse_level"):
        PyramidConfig(coarse_level=0)


class KinkedPeak(LinearResiduals):
    """Normal equations that point at ``target`` while the fitness itself peaks, with a
    kink, at ``start``: no Gauss-Newton step is accepted, nor one along the fitness's own
    differences."""

    def __init__(self, target: np.ndarray, start: np.ndarray) -> None:
        super().__init__(target)
        self.start = start

    def _value(self, genes: np.ndarray) -> np.ndarray:
        return -np.abs((genes[:, :6] - self.start) / [1, 1, 1, 1e-3, 1e-3, 1e-3]).sum(axis=1)


def test_a_stall_ends_the_refinement_on_every_level() -> None:
    start = TARGET + np.array([0.6, -0.4, 2.0, 0.0008, -0.0005, 0.0006])
    fitness = KinkedPeak(TARGET, start)
    stalled = gauss_newton_refine(fitness, start, SPACE)
    assert stalled.stop_reason == NO_ASCENT and stalled.iterations == 0
    np.testing.assert_array_equal(stalled.x, start)
    for level in (0, 1):
        alone = _local_at(fitness, 0.0, level, start, SPACE, PyramidConfig())
        assert alone.stop_reason == NO_ASCENT


class MisledResiduals(LinearResiduals):
    """Normal equations whose gradient points away from the fitness's peak, as the ``soft``
    fitness's held light offsets can where the band's agreement moves them (a plain
    garment): they see the peak at ``decoy``."""

    def __init__(self, target: np.ndarray, decoy: np.ndarray) -> None:
        super().__init__(target)
        self.decoy = np.concatenate([decoy, np.zeros(3)])

    def normal_equations(self, A: np.ndarray, dA: np.ndarray, offsets: np.ndarray,
                         with_offsets: bool = False) -> tuple[np.ndarray, np.ndarray]:
        true_target, self.target = self.target, self.decoy
        try:
            return super().normal_equations(A, dA, offsets, with_offsets)
        finally:
            self.target = true_target


def test_a_stall_takes_the_gradient_from_the_fitness_itself() -> None:
    x0 = TARGET + np.array([0.3, -0.2, 1.0, 0.0004, -0.0003, 0.0003])
    fitness = MisledResiduals(TARGET, decoy=2 * x0 - TARGET)
    gradient, _ = fitness.normal_equations(pose_vectors_to_matrices(x0)[0],
                                           _map_derivatives(x0, np.ones(6, dtype=bool)),
                                           np.zeros((2, 3)))
    assert gradient @ (TARGET - x0) < 0      # downhill: no step along it is accepted
    result = gauss_newton_refine(fitness, x0, SPACE)
    assert np.all(np.abs(result.x[:3] - TARGET[:3]) <= [0.05, 0.05, 0.25]), result.x
    np.testing.assert_allclose(result.x[3:], TARGET[3:], atol=5e-5)
    assert result.fitness > 0.99


def test_hypotheses_that_walked_to_one_peak_go_on_once() -> None:
    """After the coarse level: best first, a repeat of a better one dropped, and one more
    than ``hypothesis_margin`` below the best dropped."""
    from photomodel.search._base import SearchResult
    from photomodel.search._pyramid import _survivors

    space = SearchSpace.from_ranges()

    def result(x: list[float], fitness: float) -> SearchResult:
        return SearchResult(np.array(x), fitness, 10, 1, "", np.zeros(1), np.zeros(1))

    peak = [10.0, 20.0, 700.0, 0.0, 0.0, 0.1]
    near = [12.0, 21.0, 703.0, 0.0, 0.0, 0.105]     # within 2 % of every range
    other = [-150.0, 20.0, 700.0, 0.0, 0.0, 0.1]
    weak = [150.0, -100.0, 600.0, 0.0, 0.0, -0.2]
    kept = _survivors([result(near, 0.61), result(other, 0.50), result(peak, 0.62),
                       result(weak, 0.30)], space, margin=0.2)
    np.testing.assert_array_equal(np.array(kept), np.array([peak, other]))
    assert len(_survivors([result(weak, 0.30), result(peak, 0.62)], space, np.inf)) == 2
    with pytest.raises(ValueError, match="hypothesis_margin"):
        PyramidConfig(hypothesis_margin=-0.1)


def test_an_unconverged_gauss_newton_is_the_result_on_every_level() -> None:
    """A refinement still climbing after its iterations ends there (the next level, or the
    blur check after level 0, goes on from it)."""
    fitness = LinearResiduals(TARGET)
    x0 = TARGET + np.array([0.6, -0.4, 2.0, 0.0008, -0.0005, 0.0006])
    f0 = float(fitness(x0[None])[0])
    short = PyramidConfig(gauss_newton=GaussNewtonConfig(max_iterations=1))
    level1 = _local_at(fitness, f0, 1, x0, SPACE, short)
    assert level1.stop_reason == "gauss-newton: 1 iterations"
    level0 = _local_at(fitness, f0, 0, x0, SPACE, short)
    assert level0.stop_reason == "gauss-newton: 1 iterations"
    converged = _local_at(fitness, f0, 1, x0, SPACE, PyramidConfig())
    assert converged.stop_reason == "gauss-newton: converged"


def test_gauss_newton_stops_on_small_gains_and_short_rejected_steps() -> None:
    """``min_gain`` ends a creep after ``min_gain_steps`` small gains in a row (one by
    default); ``min_step`` ends the damping of a rejected step once it is under that many
    difference steps."""
    creeping = LinearResiduals(TARGET, metric_scale=3.0)   # a third of the way a step
    x0 = TARGET + np.array([0.6, -0.4, 2.0, 0.0008, -0.0005, 0.0006])
    base = GaussNewtonConfig(extrapolation=1.0)     # the stop rules alone
    full = gauss_newton_refine(creeping, x0, SPACE, config=replace(base, min_gain=0.0))
    early = gauss_newton_refine(creeping, x0, SPACE, config=replace(base, min_gain=0.05))
    assert early.stop_reason == "gauss-newton: converged" and early.iterations < full.iterations
    gains = np.diff(early.best_history)
    assert gains[-1] < 0.05 and gains[-2] >= 0.05
    two = gauss_newton_refine(creeping, x0, SPACE,
                              config=replace(base, min_gain=0.05, min_gain_steps=2))
    assert two.iterations == early.iterations + 1
    gains = np.diff(two.best_history)
    assert np.all(gains[-2:] < 0.05) and gains[-3] >= 0.05
    # Level 1 stops at ten times the gain (min_gain_per_level), level 0 refines after it.
    coarse = gauss_newton_refine(creeping, x0, SPACE, level=1,
                                 config=replace(base, min_gain=0.005))
    gains = np.diff(coarse.best_history)
    assert gains[-1] < 0.05 and gains[-2] >= 0.05
    flat = gauss_newton_refine(creeping, x0, SPACE, level=1,
                               config=replace(base, min_gain=0.005, min_gain_per_level=1.0))
    assert flat.iterations > coarse.iterations
    fitness = LinearResiduals(TARGET)
    # At the peak every step is rejected: with min_step the damping ends at the first
    # rejected step under it, without it only at max_damping.
    plain = GaussNewtonConfig()
    fitness.calls = 0
    at_peak = gauss_newton_refine(fitness, TARGET, SPACE, config=plain)
    short = fitness.calls
    fitness.calls = 0
    gauss_newton_refine(fitness, TARGET, SPACE, config=replace(plain, min_step=0.0,
                                                                  rejected_damping=0.0))
    assert at_peak.stop_reason == NO_ASCENT and short < fitness.calls
    for bad in ({"min_gain": -1.0}, {"min_step": -1.0}, {"rejected_damping": -1.0},
                {"min_gain_steps": 0}, {"min_gain_per_level": 0.5}):
        with pytest.raises(ValueError, match="min_gain"):
            GaussNewtonConfig(**bad)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="extrapolation"):
        GaussNewtonConfig(extrapolation=0.5)


def test_an_accepted_step_that_falls_short_is_taken_further() -> None:
    """Where the metric is steeper than the fitness the steps fall short; the parabola
    through the start, the slope and the accepted step's value takes them on to its peak
    (at most ``extrapolation`` steps), and the refinement needs fewer of them."""
    from photomodel.search._gauss_newton import _extrapolation

    # f(a) = a - c a^2 / 2 along the step: peak at 1 / c steps.
    for c, most, expected in ((0.25, 4.0, 4.0), (0.25, 3.0, 3.0), (0.5, 4.0, 2.0),
                              (1.0, 4.0, 1.0), (0.25, 1.0, 1.0)):
        assert _extrapolation(0.0, 1.0 - 0.5 * c, 1.0, most) == pytest.approx(expected)
    assert _extrapolation(0.0, 1.5, 1.0, 4.0) == 1.0      # convex along the step
    assert _extrapolation(0.0, 0.1, -1.0, 4.0) == 1.0     # no ascent at the start
    x0 = TARGET + np.array([0.6, -0.4, 2.0, 0.0008, -0.0005, 0.0006])
    runs = {}
    for most in (1.0, 4.0):
        fitness = LinearResiduals(TARGET, metric_scale=3.0)
        runs[most] = gauss_newton_refine(fitness, x0, SPACE, config=GaussNewtonConfig(
            min_gain=0.0, extrapolation=most))
        # One normal-equations pose per accepted step, every fitness call counted.
        assert runs[most].evaluations == fitness.calls + runs[most].iterations
    # A third of the way a step: the short steps end under converged_steps, short of the peak.
    np.testing.assert_allclose(runs[4.0].x[:3], TARGET[:3], atol=0.02)
    assert np.abs(runs[1.0].x[:3] - TARGET[:3]).max() > 0.1
    assert runs[4.0].fitness > runs[1.0].fitness


@pytest.mark.parametrize("strained", [False, True])
def test_the_maps_closed_form_derivatives_match_central_differences(strained: bool) -> None:
    rng = np.random.default_rng(4)
    for _ in range(5):
        x = np.concatenate([rng.normal(0, 50, 3) + [0, 0, 700], rng.normal(0, 0.2, 3),
                            rng.normal(0, 0.03, 3 if strained else 0)])
        free = rng.random(len(x)) > 0.3
        genes = np.flatnonzero(free)
        h = 1e-6
        poses = np.repeat(x[None], 2 * len(genes), axis=0)
        poses[np.arange(len(genes)), genes] += h
        poses[len(genes) + np.arange(len(genes)), genes] -= h
        T = (strained_matrices(poses[:, :6], poses[:, 6:]) if strained
             else pose_vectors_to_matrices(poses))
        central = (T[:len(genes)] - T[len(genes):]) / (2 * h)
        np.testing.assert_allclose(_map_derivatives(x, free), central, atol=1e-8)
