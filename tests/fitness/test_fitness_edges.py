"""Outline evidence: the edge a garment shows at its outline, which a region of its colour
does not."""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from photomodel.experiments import ExperimentConfig, Trial, trial_inputs
from photomodel.fitness import SoftFitness, StereoFeatures, edge_evidence
from photomodel.image._features import features_from_linear, linear_intensity, log_opponent


@lru_cache(maxsize=4)
def _case(garment: str, condition: str = "paper"):
    config = ExperimentConfig(garments=(garment,), conditions=(condition,), trials=1, seed=0)
    return trial_inputs(config, Trial(f"{condition}_{garment}_0000", garment, condition, 0))


def test_features_from_linear_inverts_linear_intensity() -> None:
    bgr = np.random.default_rng(1).integers(0, 256, (6, 4, 3), dtype=np.uint8)
    features = log_opponent(bgr).astype(np.float64)
    np.testing.assert_allclose(features_from_linear(linear_intensity(features)), features,
                               atol=1e-12)


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
