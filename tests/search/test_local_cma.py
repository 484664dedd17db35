"""LocalCMA: the fine levels' refinement, and the pyramid's choice of the camera blur."""

from __future__ import annotations

import numpy as np
import pytest

from photomodel.search import LocalCMA, LocalCMAConfig, SearchSpace, run_search
from photomodel.search._pyramid import PyramidConfig, _sharpest_fit

SPACE = SearchSpace.from_ranges()
TARGET = np.array([37.0, -52.0, 702.0, 0.03, -0.02, 0.21])


def ridge(x: np.ndarray) -> np.ndarray:
    """A narrow, tilted ridge: tilt (eps1) and x trade off, as on the stereo fitness."""
    d = x - TARGET
    along = d[..., 0] / 2.0 + d[..., 3] / 0.01       # moving along the ridge costs little
    across = d[..., 0] / 0.2 - d[..., 3] / 0.002     # moving across it costs a lot
    rest = d[..., 1] / 0.5 + 0.0 * d[..., 4]
    return np.exp(-0.5 * (along**2 + across**2 + rest**2 + (d[..., 2] / 3.0) ** 2
                          + (d[..., 4] / 0.005) ** 2 + (d[..., 5] / 0.005) ** 2))


def test_local_cma_climbs_a_tilted_ridge() -> None:
    x0 = TARGET + np.array([1.5, 0.8, 4.0, 0.004, 0.003, -0.004])
    f0 = float(ridge(x0[None])[0])
    cma_result = run_search(LocalCMA(SPACE, x0, f0, rng=0), ridge)
    assert cma_result.fitness > 0.99, cma_result
    assert np.abs(cma_result.x[0] - TARGET[0]) < 0.1
    assert cma_result.stop_reason.startswith("local cma")


def test_local_cma_is_seeded_never_worse_than_its_start_and_stays_near_it() -> None:
    x0 = TARGET + np.array([40.0, 0.0, 0.0, 0.0, 0.0, 0.0])   # far outside the peak: flat
    f0 = 0.5                                                  # better than anything nearby
    results = [run_search(LocalCMA(SPACE, x0, f0, rng=3), ridge) for _ in range(2)]
    np.testing.assert_array_equal(results[0].x, results[1].x)
    assert results[0].fitness == 0.5
    np.testing.assert_array_equal(results[0].x, x0)
    # Every candidate lies within ``radius`` start steps of the start (ray coordinates).
    opt = LocalCMA(SPACE, x0, f0, LocalCMAConfig(radius=2.0), rng=0)
    for _ in range(20):
        x = opt.ask()
        assert np.all(np.abs(x[:, 2] - x0[2]) <= 2.0 * 4.0 + 1e-6)
        opt.tell(x, np.zeros(len(x)))
        if opt.stop():
            break


def test_local_cma_checks_its_input() -> None:
    opt = LocalCMA(SPACE, TARGET, rng=0)
    with pytest.raises(ValueError, match="call ask first"):
        opt.tell(TARGET[None], np.zeros(1))
    x = opt.ask()
    with pytest.raises(ValueError, match="fitness values"):
        opt.tell(x, np.zeros(len(x) + 1))
    with pytest.raises(ValueError, match="radius"):
        LocalCMAConfig(radius=0.5)
    assert LocalCMAConfig().scaled(4.0).depth_step_mm == 16.0


def _fitness_at(curve: dict[float, float]):
    """``fitness_at`` whose value at any pose is ``curve[blur]``."""
    def fitness_at(level: int, weight: float, blur: float):
        return lambda x: np.full(len(x), curve[blur])
    return fitness_at


def test_the_blur_changes_only_when_a_candidate_fits_clearly_better() -> None:
    config = PyramidConfig(optics_blur_candidates_mm=(0.0, 0.5, 1.4, 2.8))
    x = TARGET
    sharp = {0.0: 0.30, 0.5: 0.31, 1.4: 0.62, 2.8: 0.50}     # a print in a blurred scene
    blur, fit, (f0, offsets), used = _sharpest_fit(_fitness_at(sharp), 0, x, config, 0.5)
    assert blur == 1.4 and fit(x[None])[0] == 0.62 and f0 == 0.62
    assert offsets is None      # a fitness without light offsets
    assert used == 4  # the current blur is one of the candidates: evaluated once
    flat = {0.0: 0.905, 0.5: 0.90, 1.4: 0.91, 2.8: 0.915}    # a plain garment: noise only
    blur, fit, (f0, _), _ = _sharpest_fit(_fitness_at(flat), 0, x, config, 0.5)
    assert blur == 0.5 and fit(x[None])[0] == 0.90 and f0 == 0.90
    none = PyramidConfig(optics_blur_candidates_mm=())
    assert _sharpest_fit(_fitness_at(sharp), 0, x, none, 2.8)[0] == 2.8


def test_the_blur_climb_finds_the_peak_with_fewer_evaluations() -> None:
    config = PyramidConfig(optics_blur_candidates_mm=(0.5, 0.7, 1.0, 1.4, 2.0, 2.8))
    x = TARGET
    peaked = {0.5: 0.30, 0.7: 0.36, 1.0: 0.45, 1.4: 0.62, 2.0: 0.55, 2.8: 0.40}
    every = _sharpest_fit(_fitness_at(peaked), 0, x, config, 0.7)
    climbed = _sharpest_fit(_fitness_at(peaked), 0, x, config, 0.7, climb=True)
    assert every[0] == climbed[0] == 1.4 and climbed[2][0] == 0.62
    assert every[3] == 6 and climbed[3] == 5    # 0.7, 0.5 (lower), 1.0, 1.4, 2.0
    # Staying put costs the two neighbours, one at the grid's end.
    assert _sharpest_fit(_fitness_at(peaked), 0, x, config, 1.4, climb=True)[::3] == (1.4, 3)
    falling = {b: 1.0 - b for b in peaked}
    assert _sharpest_fit(_fitness_at(falling), 0, x, config, 0.5, climb=True)[::3] == (0.5, 2)
    # A blur whose value the caller has is taken, not evaluated (nor counted).
    calls: list[float] = []

    def counting(level: int, weight: float, blur: float):  # type: ignore[no-untyped-def]
        calls.append(blur)
        return _fitness_at(peaked)(level, weight, blur)

    taken = _sharpest_fit(counting, 0, x, config, 1.4, climb=True,
                          known={1.4: (0.62, np.zeros((2, 3)))})
    assert taken[0] == 1.4 and taken[3] == 2 and 1.4 not in calls[:2]
    # A current blur off the grid: every candidate, as without the climb.
    assert _sharpest_fit(_fitness_at({**peaked, 0.6: 0.3}), 0, x, config, 0.6,
                         climb=True)[::3] == (1.4, 7)
