"""The pyramid's choice of the camera blur (``_sharpest_fit``)."""

from __future__ import annotations

import numpy as np

from photomodel.search._pyramid import PyramidConfig, _sharpest_fit

TARGET = np.array([37.0, -52.0, 702.0, 0.03, -0.02, 0.21])


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
    climbed = _sharpest_fit(_fitness_at(peaked), 0, x, config, 0.7)
    assert climbed[0] == 1.4 and climbed[2][0] == 0.62
    assert climbed[3] == 5    # 0.7, 0.5 (lower), 1.0, 1.4, 2.0; not 2.8
    # Staying put costs the two neighbours, one at the grid's end.
    assert _sharpest_fit(_fitness_at(peaked), 0, x, config, 1.4)[::3] == (1.4, 3)
    falling = {b: 1.0 - b for b in peaked}
    assert _sharpest_fit(_fitness_at(falling), 0, x, config, 0.5)[::3] == (0.5, 2)
    # A blur whose value the caller has is taken, not evaluated (nor counted).
    calls: list[float] = []

    def counting(level: int, weight: float, blur: float):  # type: ignore[no-untyped-def]
        calls.append(blur)
        return _fitness_at(peaked)(level, weight, blur)

    taken = _sharpest_fit(counting, 0, x, config, 1.4, known={1.4: (0.62, np.zeros((2, 3)))})
    assert taken[0] == 1.4 and taken[3] == 2 and 1.4 not in calls[:2]
    # A current blur off the grid: every candidate.
    assert _sharpest_fit(_fitness_at({**peaked, 0.6: 0.3}), 0, x, config, 0.6)[::3] == (1.4, 7)
