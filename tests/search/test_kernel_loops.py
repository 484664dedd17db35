"""The local searches' numba loops give what their ask/tell optimisers give, to the bit."""

from __future__ import annotations

from functools import lru_cache

import numpy as np
import pytest

from photomodel.experiments._trials import ExperimentConfig, Trial, trial_inputs
from photomodel.fitness import SoftFitness, StereoFeatures
from photomodel.geometry import eps_from_rotation, flat_pose_vectors
from photomodel.search import KernelFitness, LocalRefine, RefineConfig, SearchSpace, run_search
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
        objective: SoftFitness | OnPlane = OnPlane(level3, space, rig.R_cam1_facing)
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
