"""The motion model in SE(3) and the window features a tracked frame is measured on."""

from __future__ import annotations

from functools import lru_cache

import numpy as np
import pytest

from photomodel.experiments import ExperimentConfig, Trial, trial_inputs
from photomodel.fitness import SoftFitness, StereoFeatures
from photomodel.geometry import make_transform
from photomodel.track import (
    ConstantVelocity,
    Window,
    WindowFeatures,
    se3_exp,
    se3_log,
    window_of_points,
)


@lru_cache(maxsize=2)
def _case(garment: str = "No.6"):
    config = ExperimentConfig(garments=(garment,), conditions=("paper",), trials=1, seed=0)
    return trial_inputs(config, Trial(f"paper_{garment}_0000", garment, "paper", 0))


def test_se3_exp_and_log_are_inverse() -> None:
    rng = np.random.default_rng(0)
    for _ in range(20):
        xi = np.concatenate([rng.normal(0, 0.5, 3), rng.normal(0, 100, 3)])
        np.testing.assert_allclose(se3_log(se3_exp(xi)), xi, atol=1e-9)
    np.testing.assert_allclose(se3_exp(np.zeros(6)), np.eye(4))
    np.testing.assert_allclose(se3_exp([0, 0, 0, 1, 2, 3])[:3, 3], [1, 2, 3])


def test_a_constant_twist_is_predicted_exactly() -> None:
    xi = np.array([0.0, 0.0, 0.3, 200.0, -50.0, 10.0])      # rad/s, mm/s
    T0 = make_transform(np.eye(3), [0.0, 0.0, 685.0])
    motion = ConstantVelocity(smoothing=1.0)
    assert motion.predict(0.0) is None
    for k in range(3):
        motion.update(se3_exp(xi * k / 30) @ T0, k / 30)
    np.testing.assert_allclose(motion.predict(3 / 30), se3_exp(xi * 3 / 30) @ T0, atol=1e-9)
    mm_s, rad_s = motion.speed()
    assert mm_s == pytest.approx(np.linalg.norm(xi[3:]), rel=1e-6)
    assert rad_s == pytest.approx(0.3)
    # a gap longer than max_gap_s starts the velocity over; a time in the past holds still
    motion.update(T0, 10.0)
    assert np.all(motion.velocity == 0)
    np.testing.assert_allclose(motion.predict(5.0), T0)
    motion.reset()
    assert motion.predict(1.0) is None


def test_windows_are_aligned_clipped_and_none_off_the_image() -> None:
    uv = np.array([[100.3, 50.2], [300.9, 260.1]])
    w = window_of_points(uv, (800, 600), 10.0, 8)
    assert w == Window(88, 40, 312, 272)
    assert w.x0 % 8 == 0 and w.width % 8 == 0
    edge = window_of_points(np.array([[-40.0, -30.0], [20.0, 590.0]]), (800, 600), 10.0, 8)
    assert edge is not None and edge.x0 == 0 and edge.y0 == 0 and edge.y1 == 600
    assert window_of_points(np.array([[900.0, 10.0], [950.0, 40.0]]), (800, 600), 10.0, 8) is None
    assert window_of_points(np.full((3, 2), np.nan), (800, 600), 10.0, 8) is None


@pytest.mark.parametrize("level_offset", [0, 1])
def test_a_fitness_on_windows_matches_the_whole_images(level_offset: int) -> None:
    """Windows around the garment, same pose: the same fitness as on the whole images (at the
    images' level ``level + level_offset``), apart from the windows' border effects."""
    model, rig, right, left, T_true, _ = _case()
    full = StereoFeatures(rig, right, left)
    outline = SoftFitness(model, full, 0).samples.p_out
    uv1, uv2 = rig.project_poses(T_true, outline)
    windows = (window_of_points(uv1, rig.cam1.image_size, 40.0, 16),
               window_of_points(uv2, rig.cam2.image_size, 40.0, 16))
    assert windows[0] is not None and windows[1] is not None
    part = WindowFeatures(rig, right, left, windows, levels=2, level_offset=level_offset)
    x1, y1 = windows[0].x0, windows[0].y0
    x2, y2 = windows[1].x0, windows[1].y0
    for level in (0, 1):
        K1, K2 = part.camera_matrices(level)
        F1, F2 = full.camera_matrices(level + level_offset)
        np.testing.assert_allclose(K1[:, :2], F1[:, :2])
        scale = 0.5 ** (level + level_offset)
        np.testing.assert_allclose(K1[:2, 2], F1[:2, 2] - scale * np.array([x1, y1]))
        np.testing.assert_allclose(K2[:2, 2], F2[:2, 2] - scale * np.array([x2, y2]))
    for level in (0, 1):
        a = SoftFitness(model, full, level).evaluate_transforms(T_true[None])[0]
        b = SoftFitness(model, part, level).evaluate_transforms(T_true[None])[0]
        if level_offset == 0:
            assert b == pytest.approx(a, abs=0.01)
        else:   # images reduced twice: coarser than the samples expect, the peak still there
            assert b > 0.3
