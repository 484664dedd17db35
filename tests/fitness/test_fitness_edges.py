"""Outline evidence (the edge a garment shows at its outline, which a region of its colour
does not) and the score with patch slack."""

from __future__ import annotations

from functools import lru_cache

import numpy as np
import pytest

from photomodel.experiments import ExperimentConfig, Trial, trial_inputs
from photomodel.fitness import (
    NO_SLACK,
    ScoreSlack,
    SoftFitness,
    StereoFeatures,
    edge_evidence,
    score_terms,
)
from photomodel.locate import load_threshold, locate, soft_score
from photomodel.sim import scene_rng


@lru_cache(maxsize=4)
def _case(garment: str, condition: str = "paper"):
    config = ExperimentConfig(garments=(garment,), conditions=(condition,), trials=1, seed=0)
    return trial_inputs(config, Trial(f"{condition}_{garment}_0000", garment, condition, 0))


def test_a_garment_shows_its_outline_a_region_of_its_colour_does_not() -> None:
    model, rig, right, left, T_true, _ = _case("No.6")
    garment = SoftFitness(model, StereoFeatures(rig, right, left), 0)
    in_view = edge_evidence(garment, T_true)
    assert in_view > 0.6
    # The same pose on images of the garment's colour everywhere: every inner point agrees
    # (the score's inner term is high) but no band point shows an edge.
    x, y = np.round(rig.project_poses(T_true, np.zeros((1, 3)))[0][0]).astype(int)
    colour = right[y, x]
    flat_right = np.broadcast_to(colour, right.shape).copy()
    flat_left = np.broadcast_to(colour, left.shape).copy()
    region = SoftFitness(model, StereoFeatures(rig, flat_right, flat_left), 0)
    region.evaluate_transforms(T_true[None])
    assert region.last_terms[0, :, 1].min() > 0.5     # S_in: the inside agrees
    assert edge_evidence(region, T_true) < 0.1
    # Out of both images: no evidence at all.
    far = T_true.copy()
    far[:3, 3] += [5000.0, 0.0, 0.0]
    assert edge_evidence(garment, far) == 0.0


def test_a_hidden_half_shows_half_the_outline() -> None:
    model, rig, right, left, T_true, visible = _case("No.6", "gripper")
    fitness = SoftFitness(model, StereoFeatures(rig, right, left), 0)
    hidden = edge_evidence(fitness, T_true)
    model_p, rig_p, right_p, left_p, T_p, _ = _case("No.6")
    full = edge_evidence(SoftFitness(model_p, StereoFeatures(rig_p, right_p, left_p), 0), T_p)
    assert 0.3 * full < hidden < 0.95 * full, (hidden, full, visible)


def test_slack_shifts_start_with_no_slide_and_cover_the_square() -> None:
    shifts = ScoreSlack().shifts_mm()
    assert shifts.shape == (25, 2)
    np.testing.assert_array_equal(shifts[0], [0.0, 0.0])
    assert np.abs(shifts).max() == 1.0
    assert len(np.unique(shifts, axis=0)) == 25
    assert NO_SLACK.shifts_mm().shape == (1, 2)
    with pytest.raises(ValueError):
        ScoreSlack(cell_mm=0.0)


def test_the_rigid_score_is_the_mean_of_the_fitness_and_the_outline_evidence() -> None:
    model, rig, right, left, T_true, _ = _case("No.9")
    fitness = SoftFitness(model, StereoFeatures(rig, right, left), 0)
    terms = score_terms(fitness, T_true, NO_SLACK)
    assert terms.fitness == pytest.approx(float(fitness.evaluate_transforms(T_true[None])[0]),
                                          abs=1e-9)
    assert terms.edge_evidence == edge_evidence(fitness, T_true)
    assert terms.score == pytest.approx(soft_score(terms.fitness, terms.edge_evidence), abs=1e-12)
    assert terms.slid_fraction == 0.0
    slack = score_terms(fitness, T_true)
    assert slack.fitness == terms.fitness and slack.edge_evidence == terms.edge_evidence
    assert terms.score <= slack.score < terms.score + 0.05


def test_slack_finds_patches_where_the_pose_misplaced_them() -> None:
    """A pose 1 mm off along the model's x axis: rigidly scored it loses, but every cell can
    slide back by the slack's 1 mm, so its slack score is at least the true pose's rigid
    score, with nearly every cell slid."""
    model, rig, right, left, T_true, _ = _case("No.1")
    fitness = SoftFitness(model, StereoFeatures(rig, right, left), 0)
    off = T_true.copy()
    off[:3, 3] += T_true[:3, 0] * 1.0
    truth = score_terms(fitness, T_true, NO_SLACK).score
    rigid = score_terms(fitness, off, NO_SLACK).score
    slack = score_terms(fitness, off)
    assert rigid < truth - 0.02
    assert slack.score >= truth - 1e-4     # the slid pixels are linearised over 1 mm
    assert slack.slid_fraction > 0.8


def test_a_wrinkled_striped_shirt_at_a_good_pose_is_found() -> None:
    """Folds pull the cloth beside them by a few mm: the rigid score of this scene's good
    pose (1.5 mm, 0.3 deg) is under the threshold, the slack score above it."""
    model, rig, right, left, T_true, _ = _case("No.1", "wrinkles")
    result = locate(model, rig, right, left, rng=scene_rng(0, "search", "wrinkles_No.1_0000"))
    assert np.linalg.norm(result.position_mm - T_true[:3, 3]) < 3.0
    fitness = SoftFitness(model, StereoFeatures(rig, right, left), 0,
                          optics_blur_mm=result.optics_blur_mm)
    rigid = score_terms(fitness, result.A_cam1_model, NO_SLACK).score
    threshold = load_threshold().min_score
    assert rigid < threshold <= result.score
    assert result.found
