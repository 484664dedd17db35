"""Outline evidence (the edge a garment shows at its outline, which a region of its colour
does not) and the score with patch slack."""

from __future__ import annotations

from functools import lru_cache

import numpy as np
import pytest
from fitness_helpers import bilinear_samples

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


def _slid_sums_reference(fitness: SoftFitness, T: np.ndarray, shifts: np.ndarray,
                         offsets: np.ndarray, cell_in: np.ndarray, cell_out: np.ndarray,
                         cells: int) -> np.ndarray:
    """``SoftFitness.slack_sums`` written out in numpy (level 0) from its docstring: each
    point's pixel moved by the projection's forward differences over 1 mm along the model's
    x and y, times the slide."""
    s, feats = fitness.samples, fitness.features
    m = feats.match
    iv_l, iv_c = 1.0 / m.sigma_l**2, 1.0 / m.sigma_c**2
    opponent = np.array([[1 / 3, 1 / 3, 1 / 3], [0.0, -1.0, 1.0], [-1.0, 0.5, 0.5]])
    to_logs = np.linalg.inv(opponent)
    t = fitness.edge_mix_fraction
    table = s.table_out if s.table_out is not None else np.full(len(s.p_in), -1)

    def pixels(points: np.ndarray) -> np.ndarray:    # (3 [at, +x, +y], 2 cams, N, 2)
        out = []
        for step in ((0.0, 0.0), (1.0, 0.0), (0.0, 1.0)):
            p = np.column_stack([points[:, :2] + step, np.zeros(len(points))])
            out.append(np.stack(feats.rig.project_poses(T, p)))
        return np.stack(out)

    def agree(d: np.ndarray) -> np.ndarray:
        return np.exp(-0.5 * (d[:, 0] ** 2 * iv_l + (d[:, 1] ** 2 + d[:, 2] ** 2) * iv_c))

    pix_in, pix_out = pixels(s.p_in), pixels(s.p_out)
    out = np.zeros((len(shifts), 2, 3, cells))
    for q, (sx, sy) in enumerate(shifts):
        for cam in range(2):
            img = feats.pyramids[cam][0].astype(np.float64)
            o = offsets[cam]
            slid_in = pix_in[0, cam] + (pix_in[1, cam] - pix_in[0, cam]) * sx + (
                pix_in[2, cam] - pix_in[0, cam]) * sy
            slid_out = pix_out[0, cam] + (pix_out[1, cam] - pix_out[0, cam]) * sx + (
                pix_out[2, cam] - pix_out[0, cam]) * sy
            x_in, ok_in = bilinear_samples(img, slid_in)
            x_out, ok_out = bilinear_samples(img, slid_out)
            a_out = np.where(ok_out, agree(x_out - s.f_out - o), 1.0)
            expected = s.f_in + o
            mixed = (t > 0.0) & (table >= 0) & ok_out[np.maximum(table, 0)]
            if mixed.any():   # the model colour mixed with the slid band point's, linear
                own = s.lin_in[mixed] * np.exp(to_logs @ o)     # lin_in: exp of f_in's logs
                seen = np.exp(x_out[table[mixed]] @ to_logs.T)
                expected[mixed] = np.log((1 - t) * own + t * seen) @ opponent.T
            a_in = np.where(ok_in, agree(x_in - expected), 0.0)
            pair = (table >= 0) & ok_in & ok_out[np.maximum(table, 0)]
            both = np.where(pair, a_in * (1.0 - a_out[np.maximum(table, 0)]), 0.0)
            out[q, cam, 0] = np.bincount(cell_in, a_in, cells)
            out[q, cam, 1] = np.bincount(cell_out, a_out, cells)
            out[q, cam, 2] = np.bincount(cell_in, both, cells)
    return out


@pytest.mark.parametrize(("garment", "condition"), [("No.1", "paper"), ("No.6", "gripper")])
def test_slack_sums_match_a_numpy_reference(garment: str, condition: str) -> None:
    """Every slide's, camera's and cell's sums of the score with patch slack, against the
    same sums written out in numpy, 1 mm off the true pose (cells slide both ways)."""
    from photomodel.fitness._edges import _sample_cells

    model, rig, right, left, T_true, _ = _case(garment, condition)
    fitness = SoftFitness(model, StereoFeatures(rig, right, left), 0)
    T = T_true.copy()
    T[:3, 3] += T_true[:3, 0] * 0.7 - T_true[:3, 1] * 0.4
    fitness.evaluate_transforms(T[None])
    offsets = np.ascontiguousarray(fitness.last_terms[0][:, 3:])
    cell_in, cell_out, cells = _sample_cells(fitness.samples, ScoreSlack().cell_mm)
    shifts = ScoreSlack().shifts_mm()
    got = fitness.slack_sums(T, shifts, offsets, cell_in, cell_out, cells)
    expected = _slid_sums_reference(fitness, T, shifts, offsets, cell_in, cell_out, cells)
    assert fitness.edge_mix_fraction > 0.0
    np.testing.assert_allclose(got, expected, rtol=0.0, atol=1e-8)


def test_the_visible_outline_tells_a_hidden_garment_from_a_region_of_its_colour() -> None:
    model, rig, right, left, T_true, visible = _case("No.6", "gripper")
    hidden = score_terms(SoftFitness(model, StereoFeatures(rig, right, left), 0), T_true)
    assert visible < 0.95
    # Where its inside is seen, the hidden garment's outline shows as well as in full view.
    assert hidden.visible_outline > 0.65 and hidden.visible_outline_cells >= 3
    assert hidden.edge_evidence < hidden.visible_outline
    x, y = np.round(rig.project_poses(T_true, np.zeros((1, 3)))[0][0]).astype(int)
    flat_right = np.broadcast_to(right[y, x], right.shape).copy()
    flat_left = np.broadcast_to(right[y, x], left.shape).copy()
    region = score_terms(SoftFitness(model, StereoFeatures(rig, flat_right, flat_left), 0),
                         T_true)
    assert region.visible_outline < 0.3
    far = T_true.copy()
    far[:3, 3] += [5000.0, 0.0, 0.0]
    gone = score_terms(SoftFitness(model, StereoFeatures(rig, right, left), 0), far)
    assert gone.visible_outline == 0.0 and gone.visible_outline_cells == 0
