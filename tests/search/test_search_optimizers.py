"""The optimisers behind ask/tell: decoding, determinism, and finding a known maximum."""

from __future__ import annotations

import numpy as np
import pytest

from photomodel.search import (
    BinaryGA,
    FullSearch,
    FullSearchConfig,
    GAConfig,
    GlobalThenLocal,
    SearchSpace,
    run_search,
)

SPACE = SearchSpace.from_ranges()
TARGET = np.array([37.0, -52.0, 702.0, 0.03, -0.02, 0.21])
SCALE = np.array([30.0, 30.0, 60.0, 0.05, 0.05, 0.1])


def peaked(x: np.ndarray) -> np.ndarray:
    """A smooth single-peak fitness with its maximum 1 at TARGET."""
    return np.exp(-0.5 * np.sum(((x - TARGET) / SCALE) ** 2, axis=-1))


@pytest.mark.parametrize("gray", [False, True])
def test_ga_decodes_all_zero_and_all_one_chromosomes_to_the_bounds(gray: bool) -> None:
    ga = BinaryGA(SPACE, GAConfig(gray=gray), rng=0)
    bits = np.zeros((2, 72), np.uint8)
    bits[1] = 1 if not gray else np.tile([1] + [0] * 11, 6)  # Gray 100..0 = binary 111..1
    x = ga.decode(bits)
    np.testing.assert_allclose(x[0], SPACE.lower)
    np.testing.assert_allclose(x[1], SPACE.upper)


def test_ga_is_seeded_and_finds_the_peak() -> None:
    results = [run_search(BinaryGA(SPACE, GAConfig(), rng=7), peaked) for _ in range(2)]
    np.testing.assert_array_equal(results[0].x, results[1].x)
    assert results[0].fitness > 0.99
    assert np.all(np.abs(results[0].x - TARGET) < SCALE * 0.15)
    assert len(results[0].best_history) == results[0].iterations
    assert np.all(np.diff(results[0].best_history) >= 0)


def test_ga_min_improvement_ends_the_tail_of_small_gains() -> None:
    """Rises below ``min_improvement`` do not reset the patience; the best is still kept."""
    config = GAConfig(patience=10, restarts=0)
    plain = run_search(BinaryGA(SPACE, config, rng=5), peaked)
    coarse = run_search(BinaryGA(SPACE, GAConfig(patience=10, restarts=0, min_improvement=0.05),
                                 rng=5), peaked)
    assert coarse.iterations < plain.iterations
    assert coarse.fitness <= plain.fitness
    assert coarse.fitness == pytest.approx(max(coarse.best_history))
    # the same generations up to the earlier stop: the threshold changes only when to stop
    np.testing.assert_array_equal(coarse.best_history, plain.best_history[: coarse.iterations])
    with pytest.raises(ValueError, match="min_improvement"):
        GAConfig(min_improvement=-0.1)


def test_paper_ga_has_sixty_individuals_of_72_bits() -> None:
    ga = BinaryGA(SPACE, GAConfig.paper(), rng=1)
    assert ga.ask().shape == (60, 6)
    assert ga.bits.shape == (60, 72)
    assert not ga.config.gray and ga.config.restarts == 0


def test_ga_keeps_the_elite() -> None:
    ga = BinaryGA(SPACE, GAConfig(restarts=0), rng=2)
    x = ga.ask()
    f = peaked(x)
    best = x[np.argmax(f)]
    ga.tell(x, f)
    assert np.any(np.all(np.isclose(ga.ask(), best), axis=1))


def test_full_search_scans_the_grid_then_refines() -> None:
    single = FullSearch(SPACE, FullSearchConfig(coarse_steps=(9, 7, 5, 1, 1, 5), levels=1))
    res1 = run_search(single, peaked)
    assert res1.evaluations == 9 * 7 * 5 * 5
    multi = FullSearch(SPACE, FullSearchConfig(coarse_steps=(9, 7, 5, 1, 1, 5), levels=6))
    res6 = run_search(multi, peaked)
    assert res6.fitness > res1.fitness
    assert np.all(np.abs(res6.x - TARGET) < SCALE * 0.2)


def test_local_refinement_improves_a_rough_start() -> None:
    ga = BinaryGA(SPACE, GAConfig(max_generations=5, restarts=0), rng=3)
    chained = GlobalThenLocal(ga, SPACE, rng=3)
    res = run_search(chained, peaked)
    assert res.fitness >= run_search(BinaryGA(SPACE, GAConfig(max_generations=5, restarts=0),
                                              rng=3), peaked).fitness
    assert "refine" in res.stop_reason


def test_search_space_rejects_bad_bounds() -> None:
    with pytest.raises(ValueError, match="z_mm"):
        SearchSpace.from_ranges(z_mm=(-10.0, 100.0))
    with pytest.raises(ValueError):
        SearchSpace(np.zeros(6), -np.ones(6))
