"""The fitness: numba kernel equals the numpy reference; the truth scores highest."""

from __future__ import annotations

import numpy as np
import pytest

from photomodel.fitness import FITNESS_PRESETS, make_fitness
from photomodel.geometry import eps_from_rotation
from photomodel.search import SearchSpace
from photomodel.sim import random_stereo_scene


def _truth_vector(T: np.ndarray) -> np.ndarray:
    return np.r_[T[:3, 3], eps_from_rotation(T[:3, :3])]


@pytest.mark.parametrize("name", sorted(FITNESS_PRESETS))
def test_numba_kernel_matches_numpy_reference(name: str, plaid_case) -> None:
    scene = random_stereo_scene(plaid_case.garment, plaid_case.rig, rng=3)
    rng = np.random.default_rng(0)
    space = SearchSpace.from_ranges()
    x0 = _truth_vector(scene.T_cam1_model)
    X = np.vstack([space.lower + space.span * rng.random((40, 6)),
                   space.clip(x0 + rng.normal(0, [3, 3, 5, 0.01, 0.01, 0.02], (20, 6)))])
    fast = make_fitness(name, plaid_case.built.model, plaid_case.rig, scene.right_bgr,
                        scene.left_bgr)
    ref = make_fitness(name, plaid_case.built.model, plaid_case.rig, scene.right_bgr,
                       scene.left_bgr, backend="numpy")
    np.testing.assert_allclose(fast(X), ref(X), rtol=0, atol=1e-9)
    np.testing.assert_array_equal(fast.last_counts, ref.last_counts)


@pytest.mark.parametrize("case_name", ["plaid_case", "plain_case"])
def test_truth_scores_near_one_and_beats_perturbed_poses(case_name: str, request) -> None:
    case = request.getfixturevalue(case_name)
    scene = random_stereo_scene(case.garment, case.rig, rng=4)
    f = make_fitness("balanced", case.built.model, case.rig, scene.right_bgr, scene.left_bgr)
    x0 = _truth_vector(scene.T_cam1_model)
    truth = f(x0[None])[0]
    assert f.score(truth) > 0.95
    for delta in ([5, 0, 0, 0, 0, 0], [0, -5, 0, 0, 0, 0], [0, 0, 0, 0, 0, 0.03]):
        assert f(x0[None] + np.array(delta))[0] < truth


def test_paper_votes_are_plus_two_and_minus_0_005(plaid_case) -> None:
    scene = random_stereo_scene(plaid_case.garment, plaid_case.rig, rng=5)
    f = make_fitness("paper", plaid_case.built.model, plaid_case.rig, scene.right_bgr,
                     scene.left_bgr)
    X = np.array([_truth_vector(scene.T_cam1_model)])
    X = np.repeat(X, 3, axis=0) + np.array([[0] * 6, [8, 0, 0, 0, 0, 0], [0, 0, 30, 0, 0, 0]])
    values = f(X)
    c = f.last_counts
    np.testing.assert_allclose(values, ((2 * c[:, 0] - 0.005 * c[:, 1])
                                        + (2 * c[:, 2] - 0.005 * c[:, 3])) / 2)
