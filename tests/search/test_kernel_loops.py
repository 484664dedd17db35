"""The local searches' numba loops give what their ask/tell optimisers give, to the bit."""

from __future__ import annotations

from functools import lru_cache

import numpy as np
import pytest

from photomodel.experiments._trials import ExperimentConfig, Trial, trial_inputs
from photomodel.fitness import KernelFitness, KernelNormalEquations, SoftFitness, StereoFeatures
from photomodel.geometry import eps_from_rotation, flat_pose_vectors, quat_wxyz_from_matrix
from photomodel.search import (
    GaussNewtonConfig,
    LocalRefine,
    NormalEquationsFitness,
    RefineConfig,
    SearchSpace,
    TransformFitness,
    gauss_newton_refine,
    run_search,
)
from photomodel.search._base import conforms
from photomodel.search._gauss_newton import NO_ASCENT
from photomodel.search._kernel_loops import OnPlane, refine_kernel


@lru_cache(maxsize=1)
def _scene() -> tuple[SoftFitness, SoftFitness, np.ndarray, SearchSpace]:
    config = ExperimentConfig(garments=("No.4",), conditions=("paper",), trials=1, seed=0)
    model, rig, right, left, T, _ = trial_inputs(
        config, Trial("paper_No.4_0000", "No.4", "paper", 0))
    features = StereoFeatures(rig, right, left)
    truth = np.concatenate([T[:3, 3], eps_from_rotation(T[:3, :3])])
    space = SearchSpace.from_ranges(R_cam1_plane=rig.R_cam1_facing)
    return SoftFitness(model, features, 2), SoftFitness(model, features, 3), truth, space


@lru_cache(maxsize=2)
def _level(level: int) -> SoftFitness:
    fitness = _scene()[0]
    return SoftFitness(fitness.model, fitness.features, level)


def _flat_space(space: SearchSpace) -> SearchSpace:
    lo, hi = space.lower.copy(), space.upper.copy()
    lo[3:5] = hi[3:5] = 0.0
    return SearchSpace(lo, hi)


@pytest.mark.parametrize(("on_plane", "seed"), [(False, 0), (False, 1), (True, 2)])
def test_the_numba_evolution_strategy_repeats_local_refine(on_plane: bool, seed: int) -> None:
    level2, level3, truth, space = _scene()
    kick = np.random.default_rng(seed).normal(size=6) * [6.0, 6.0, 15.0, 0.01, 0.01, 0.02]
    config = RefineConfig(population=8, max_iterations=60, min_step_fraction=0.2).scaled(4.0)
    if on_plane:
        rig = level3.features.rig
        q_facing = quat_wxyz_from_matrix(rig.R_cam1_facing)
        objective: SoftFitness | OnPlane = OnPlane(level3, space, q_facing)
        search_space = _flat_space(space)
        x0 = flat_pose_vectors(truth + kick, rig.R_cam1_facing)[0]
    else:
        objective, search_space, x0 = level2, space, truth + kick
    assert isinstance(level2, KernelFitness)
    rng_a, rng_b = np.random.default_rng(seed), np.random.default_rng(seed)
    f0 = float(objective(x0[None])[0])
    expected = run_search(LocalRefine(search_space, x0, f0, config, rng_a), objective)
    got = refine_kernel(objective, search_space, x0, config, rng_b)
    assert got.fitness == expected.fitness and got.fitness > f0
    np.testing.assert_array_equal(got.x, expected.x)
    assert (got.iterations, got.evaluations, got.stop_reason) == (
        expected.iterations, expected.evaluations, expected.stop_reason)
    np.testing.assert_array_equal(got.best_history, expected.best_history)
    np.testing.assert_allclose(got.mean_history, expected.mean_history, rtol=0, atol=1e-12)
    assert rng_a.random() == rng_b.random()     # the generator left where LocalRefine leaves it


def test_an_iteration_limit_stops_the_numba_evolution_strategy_as_local_refine() -> None:
    level2, _, truth, space = _scene()
    config = RefineConfig(population=4, max_iterations=3)
    got = refine_kernel(level2, space, truth + [3.0, 0, 0, 0, 0, 0], config,
                        np.random.default_rng(0))
    assert got.iterations == 3 and got.stop_reason == "refine max_iterations (3)"


def test_refine_kernel_needs_a_fitness_with_a_kernel() -> None:
    _, _, truth, space = _scene()
    with pytest.raises(TypeError, match="KernelFitness"):
        refine_kernel(lambda x: np.zeros(len(x)), space, truth, RefineConfig(),  # type: ignore[arg-type]
                      np.random.default_rng(0))


def test_conforms_decides_as_isinstance_once_per_type() -> None:
    level2, _, _, _ = _scene()
    python_only = _PythonOnly(level2)
    for _ in range(2):     # the second time from the kept decision
        for obj in (level2, python_only, lambda x: x, OnPlane(level2, _scene()[3],
                                                              np.array([1.0, 0, 0, 0]))):
            for protocol in (KernelFitness, KernelNormalEquations, TransformFitness,
                             NormalEquationsFitness):
                assert conforms(obj, protocol) == isinstance(obj, protocol)
    assert conforms(level2, KernelNormalEquations)
    assert not conforms(python_only, KernelFitness)
    assert conforms(python_only, NormalEquationsFitness)


class _PythonOnly:
    """``fitness`` without its numba kernels: Gauss-Newton takes its Python loop."""

    def __init__(self, fitness: SoftFitness) -> None:
        self.f = fitness

    def __call__(self, poses: np.ndarray) -> np.ndarray:
        return self.f(poses)

    def evaluate_transforms(self, T: np.ndarray) -> np.ndarray:
        return self.f.evaluate_transforms(T)

    def last_offsets(self) -> np.ndarray:
        return self.f.last_offsets()

    def normal_equations(self, A: np.ndarray, dA: np.ndarray, offsets: np.ndarray,
                         with_offsets: bool = False) -> tuple[np.ndarray, np.ndarray]:
        return self.f.normal_equations(A, dA, offsets, with_offsets)


@pytest.mark.parametrize(("level", "strain", "free"), [
    (1, None, None), (0, (0.01, -0.02, 0.005), None),
    (0, (0.0, 0.0, 0.0), (True, True, True, False, False, True))])
def test_the_numba_gauss_newton_repeats_the_python_loop(level: int, strain: tuple | None,
                                                        free: tuple | None) -> None:
    _, _, truth, space = _scene()
    fitness = _level(level)
    assert isinstance(fitness, KernelNormalEquations)
    assert not isinstance(_PythonOnly(fitness), KernelFitness)
    x0 = truth + np.array([0.8, -0.6, 2.0, 0.002, -0.002, 0.001]) * 2.0**level
    mask = None if free is None else np.array(free)
    got = gauss_newton_refine(fitness, x0, space, level, free=mask, strain=strain)
    expected = gauss_newton_refine(_PythonOnly(fitness), x0, space, level, free=mask,
                                   strain=strain)
    assert got.fitness == expected.fitness and got.iterations >= 2
    np.testing.assert_array_equal(got.x, expected.x)
    assert (got.iterations, got.evaluations, got.stop_reason) == (
        expected.iterations, expected.evaluations, expected.stop_reason)
    np.testing.assert_array_equal(got.best_history, expected.best_history)
    if strain is None:
        assert got.strain is None and expected.strain is None
    else:
        np.testing.assert_array_equal(got.strain, expected.strain)
    if mask is not None:
        np.testing.assert_array_equal(got.x[~mask], np.clip(x0, space.lower, space.upper)[~mask])


def test_the_numba_gauss_newton_takes_the_fitness_own_differences_on_a_stall() -> None:
    """Started at the Python loop's end, neither accepts a step along the analytic gradient
    alone; both then difference the fitness itself and stop where the other stops."""
    _, _, truth, space = _scene()
    fitness = _level(1)
    start = gauss_newton_refine(_PythonOnly(fitness), truth, space, 1, strain=(0, 0, 0))
    x0, strain = start.x, start.strain
    config = GaussNewtonConfig(max_iterations=3, min_gain=0.0, converged_steps=0.0)
    got = gauss_newton_refine(fitness, x0, space, 1, config, strain=strain)
    expected = gauss_newton_refine(_PythonOnly(fitness), x0, space, 1, config, strain=strain)
    assert got.fitness == expected.fitness and got.evaluations == expected.evaluations
    assert got.stop_reason == expected.stop_reason == NO_ASCENT
    assert got.evaluations > 9      # the differences of nine genes were taken
    np.testing.assert_array_equal(got.x, expected.x)
