"""The soft fitness: colour features, light offsets, sub-pixel peaks and the pyramid search."""

from __future__ import annotations

from functools import lru_cache

import numpy as np
import pytest
from fitness_helpers import bilinear_samples
from scipy.spatial.transform import Rotation

from photomodel.experiments import ExperimentConfig, Trial, trial_inputs
from photomodel.fitness import (
    PreparedModel,
    SoftFitness,
    SoftMatch,
    StereoFeatures,
    model_samples,
)
from photomodel.fitness._soft import level_spacing
from photomodel.geometry import in_plane_angle_rad, pose_vectors_to_matrices
from photomodel.image._features import linear_intensity, log_opponent
from photomodel.search import (
    LocalRefine,
    PyramidConfig,
    SearchSpace,
    pyramid_search,
    run_search,
)


@lru_cache(maxsize=16)
def _case(garment: str, condition: str = "paper"):
    config = ExperimentConfig(garments=(garment,), conditions=(condition,), trials=1, seed=0)
    return trial_inputs(config, Trial(f"{condition}_{garment}_0000", garment, condition, 0))


def _vector(T: np.ndarray) -> np.ndarray:
    q = Rotation.from_matrix(T[:3, :3]).as_quat()  # x, y, z, w
    q = -q if q[3] < 0 else q
    return np.r_[T[:3, 3], q[:3]]


def test_log_opponent_matches_its_definition() -> None:
    img = np.random.default_rng(0).integers(0, 256, (20, 30, 3), dtype=np.uint8)
    b, g, r = (np.log(img[..., k].astype(float) + 8.0) for k in range(3))
    expected = np.stack([(b + g + r) / 3, r - g, (r + g) / 2 - b], axis=-1)
    np.testing.assert_allclose(log_opponent(img), expected, atol=1e-5)
    with pytest.raises(ValueError, match="image_bgr"):
        log_opponent(img[..., 0])



@pytest.mark.parametrize("shape", [(48, 64), (1, 1), (2, 3), (9, 4)])
def test_smoothed_log_opponent_is_opencvs_gaussian_blur_on_one_or_two_threads(
        shape: tuple[int, int]) -> None:
    """The smoothing runs in numba (rows in bands on the threads, borders reflected as
    OpenCV's default): ``cv2.GaussianBlur`` of the unsmoothed features to float rounding,
    images smaller than the kernel included, the same to the bit on any thread count."""
    import cv2
    import numba

    img = np.random.default_rng(1).integers(0, 256, (*shape, 3), dtype=np.uint8)
    plain = log_opponent(img)
    threads = numba.get_num_threads()
    try:
        for sigma in (0.2, 0.7, 1.3):
            expected = cv2.GaussianBlur(plain, (0, 0), sigma)
            smoothed = log_opponent(img, sigma)
            np.testing.assert_allclose(smoothed, expected.reshape(smoothed.shape), atol=3e-6)
            numba.set_num_threads(1)
            np.testing.assert_array_equal(log_opponent(img, sigma), smoothed)
            numba.set_num_threads(threads)
    finally:
        numba.set_num_threads(threads)

def test_fitnesses_of_one_pair_share_their_samples_arrays_and_cameras() -> None:
    """A search builds a dozen fitnesses of one pair: the samples' kernel arrays are made once
    per samples object and the camera matrices once per level, and each fitness evaluates as
    one with arrays of its own."""
    from photomodel.fitness._soft import _sample_arrays

    bare, rig, right, left, T, _ = _case("No.1", "paper")
    model = PreparedModel(bare)
    features = StereoFeatures(rig, right, left)
    a = SoftFitness(model, features, 1)
    b = SoftFitness(model, features, 1, palette_weight=0.3)
    assert a.samples is b.samples
    assert all(x is y for x, y in zip(a.kernel_args()[6:10], b.kernel_args()[6:10], strict=True))
    assert a.K1 is b.K1 and features.camera_matrices(1)[1] is a.K2
    np.testing.assert_array_equal(a.K1[:2], rig.cam1.K[:2] / 2)
    arrays = _sample_arrays(a.samples)
    np.testing.assert_array_equal(arrays.half_weights, a.residual_weights() / 2)
    assert arrays.table_out.dtype == np.int64 and np.all(arrays.no_table == -1)
    poses = T @ pose_vectors_to_matrices(np.array([[0.5, -0.3, 1.0, 0.001, 0.0, 0.002]]))
    shared = a.evaluate_transforms(np.concatenate([T[None], poses]))
    other = SoftFitness(model, StereoFeatures(rig, right, left), 1)
    assert other.K1 is not a.K1
    np.testing.assert_array_equal(other.evaluate_transforms(np.concatenate([T[None], poses])),
                                  shared)


def test_samples_straddle_the_outline() -> None:
    model = _case("No.6")[0]
    s = model_samples(model, level_spacing(0))
    assert len(s.p_in) > 500 and len(s.p_out) > 500 and s.palette.shape[1] == 3
    np.testing.assert_allclose(s.p_in[:, :2].mean(axis=0), 0.0, atol=3.0)  # model origin
    # Each inner-ring point knows the outermost band point beside it (1 + 5 mm apart).
    ring = s.table_out >= 0
    assert 0.1 < ring.mean() < 0.6 and np.all(s.table_out[ring] < len(s.p_out))
    gap = np.linalg.norm(s.p_in[ring, :2] - s.p_out[s.table_out[ring], :2], axis=1)
    assert np.median(gap) == pytest.approx(6.0, abs=0.5)
    # Band points lie farther from the centroid than the inner ring on average.
    assert np.linalg.norm(s.p_out[:, :2], axis=1).mean() > np.linalg.norm(
        s.p_in[:, :2], axis=1).mean()


@pytest.mark.parametrize(("garment", "condition"), [
    ("No.6", "paper"),       # grey sock on a grey table: no hue at all
    ("No.8", "paper"),       # white towel
    ("No.1", "dim"),         # plaid, 40 % of the light
    ("No.2", "warm-light"),  # navy trousers under a 3000 K lamp
])
def test_true_pose_is_the_peak(garment: str, condition: str) -> None:
    model, rig, right, left, T_true, _ = _case(garment, condition)
    fit = SoftFitness(model, StereoFeatures(rig, right, left), level=0)
    x0 = _vector(T_true)
    moves = np.array([[2, 0, 0, 0, 0, 0], [0, -2, 0, 0, 0, 0], [0, 0, 15, 0, 0, 0],
                      [0, 0, 0, 0, 0, 0.02], [6, 6, 0, 0, 0, 0]], dtype=float)
    f = fit(np.vstack([x0, x0 + moves]))
    assert f[0] > 0.45, f[0]
    assert np.all(f[0] > f[1:]), f


def test_light_offsets_are_estimated() -> None:
    model, rig, right, left, T_true, _ = _case("No.1", "dim")
    fit = SoftFitness(model, StereoFeatures(rig, right, left), level=1)
    fit(_vector(T_true)[None])
    lightness_offset = fit.last_terms[0, :, 3]
    assert np.all(lightness_offset < -0.3), lightness_offset  # darker than the model photo


def test_pyramid_search_finds_a_grey_garment() -> None:
    model, rig, right, left, T_true, _ = _case("No.6")
    features = StereoFeatures(rig, right, left)
    result = pyramid_search(
        lambda lv, w, b: SoftFitness(model, features, lv, palette_weight=w, optics_blur_mm=b),
        SearchSpace.from_ranges(), rng=0)
    T = pose_vectors_to_matrices(result.x)[0]
    assert np.hypot(*(T[:2, 3] - T_true[:2, 3])) < 2.0
    assert abs(T[2, 3] - T_true[2, 3]) < 10.0
    dtheta = np.degrees(in_plane_angle_rad(T[:3, :3]) - in_plane_angle_rad(T_true[:3, :3]))
    assert abs(dtheta) < 1.0


def test_coarse_own_colours_walk_in_to_a_print() -> None:
    """From where the palette GA leaves a dotted skirt (tens of mm and about 5 deg off),
    level 2's own colours settle a dot or so away; level 3's own colours first walk in
    (the coarse level's refinement of each hypothesis in :func:`pyramid_search`)."""
    model, rig, right, left, T_true, _ = _case("No.5")
    features = StereoFeatures(rig, right, left)
    x_true = _vector(T_true)
    space = SearchSpace.from_ranges()
    config = PyramidConfig().refine

    def refine(level: int, x0: np.ndarray, seed: int) -> np.ndarray:
        f = SoftFitness(model, features, level)
        opt = LocalRefine(space, x0, f(x0[None])[0], config.scaled(2.0**level), seed)
        return run_search(opt, f).x

    direct = coarse_first = 0
    for dx, dy, dtheta in [(30, 20, 5), (-25, 30, -5), (40, 0, 4), (0, -35, -5), (20, 20, 0)]:
        x0 = x_true.copy()
        x0[:2] += (dx, dy)
        x0[5] = np.sin(np.arcsin(x_true[5]) + np.deg2rad(dtheta) / 2)
        for seed in (0, 1):
            direct += np.linalg.norm(refine(2, x0, seed)[:2] - x_true[:2]) < 3.0
            walked = refine(2, refine(3, x0, seed), seed)
            coarse_first += np.linalg.norm(walked[:2] - x_true[:2]) < 3.0
    assert coarse_first >= 7 and direct <= 2, (coarse_first, direct)


def test_the_model_blur_stays_on_the_garment() -> None:
    """A heavy camera blur mixes the garment's own colours, not the model station's backdrop."""
    model = PreparedModel(_case("No.6")[0])
    sharp = model_samples(model, level_spacing(0, optics_blur_mm=0.0))
    blurred = model_samples(model, level_spacing(0, optics_blur_mm=2.8))
    assert blurred.p_in is sharp.p_in  # one geometry for every blur
    # The grey sock stays grey at its inner ring: the green backdrop (a = ln R - ln G about
    # -1) would pull a below the sharp ring's, whose outline pixels are part green already
    # (the mask's edge lies where they are half garment).
    ring = slice(0, 200)
    a_sharp, b_sharp = sharp.f_in[ring, 1:].mean(axis=0)
    a_blurred, b_blurred = blurred.f_in[ring, 1:].mean(axis=0)
    assert a_blurred >= a_sharp - 0.005, (a_blurred, a_sharp)
    assert abs(a_blurred) < 0.03 and abs(b_blurred) < 0.03 and abs(b_sharp) < 0.03


def test_pyramid_search_estimates_the_camera_blur() -> None:
    bare, rig, right, left, T_true, _ = _case("No.1", "blur")   # 1.8 px = 1.55 mm
    model = PreparedModel(bare)
    features = StereoFeatures(rig, right, left)
    result = pyramid_search(
        lambda lv, w, b: SoftFitness(model, features, lv, palette_weight=w, optics_blur_mm=b),
        SearchSpace.from_ranges(), rng=0)
    assert 1.0 <= result.optics_blur_mm <= 2.0, result.optics_blur_mm
    T = pose_vectors_to_matrices(result.x)[0]
    assert np.linalg.norm(T[:3, 3] - T_true[:3, 3]) < 2.0
    # With the in-focus model the same pose scores far lower: the blur is what made it fit.
    in_focus = SoftFitness(model, features, 0, optics_blur_mm=0.5)(result.x[None])[0]
    assert result.fitness > in_focus + 0.15, (result.fitness, in_focus)


_OPPONENT_FROM_LOGS = np.array([[1 / 3, 1 / 3, 1 / 3], [0.0, -1.0, 1.0], [-1.0, 0.5, 0.5]])


def _mix_linear(features_a: np.ndarray, features_b: np.ndarray, t: float) -> np.ndarray:
    """Features (n, 3) of (1 - t) a + t b mixed as intensities (+ the log offset)."""
    to_logs = np.linalg.inv(_OPPONENT_FROM_LOGS)
    logs_a, logs_b = features_a @ to_logs.T, features_b @ to_logs.T
    return np.log((1.0 - t) * np.exp(logs_a) + t * np.exp(logs_b)) @ _OPPONENT_FROM_LOGS.T


def _reference_terms(fitness: SoftFitness, T: np.ndarray) -> np.ndarray:
    """Per-camera terms (2, 6) of one pose, written out in numpy from the module docstring."""
    s, feats = fitness.samples, fitness.features
    m = feats.match
    iv_l, iv_c, wb = 1.0 / m.sigma_l**2, 1.0 / m.sigma_c**2, m.wb_weight
    scale = 0.5**fitness.level
    uv_in = feats.rig.project_poses(T, s.p_in)
    uv_out = feats.rig.project_poses(T, s.p_out)
    terms = np.zeros((2, 6))

    def agree(d: np.ndarray, o: np.ndarray) -> np.ndarray:
        e = d - o
        return np.exp(-0.5 * (e[:, 0] ** 2 * iv_l + (e[:, 1] ** 2 + e[:, 2] ** 2) * iv_c))

    def with_palette(a: np.ndarray, x: np.ndarray, o: np.ndarray) -> np.ndarray:
        for colour in fitness.palette:
            a = np.maximum(a, fitness.palette_weight * agree(x - colour, o))
        return a

    for cam in range(2):
        img = feats.pyramids[cam][fitness.level].astype(np.float64)
        x_in, ok = bilinear_samples(img, uv_in[cam] * scale)
        d = (x_in - s.f_in)[ok]
        ridge = 2.0 * wb * len(s.p_in) / iv_c
        ends = []
        for start in (d.mean(axis=0), np.zeros(3)):
            o = start.copy()
            for _ in range(3):
                a = agree(d, o)
                o = np.array([a @ d[:, 0] / a.sum(), a @ d[:, 1] / (a.sum() + ridge),
                              a @ d[:, 2] / (a.sum() + ridge)])
            ends.append((agree(d, o).sum() / len(s.p_in) - wb * (o[1] ** 2 + o[2] ** 2), o))
        o = max(ends, key=lambda e: e[0])[1]
        x_out, ok_out = bilinear_samples(img, uv_out[cam] * scale)
        t = fitness.edge_mix_fraction
        if t > 0.0:  # inner-ring points expect their colour mixed with the band's table colour
            k = s.table_out
            mixed = ok & (k >= 0) & ok_out[np.maximum(k, 0)]
            expected = _mix_linear(s.f_in[mixed] + o, x_out[k[mixed]], t)
            d_all = np.zeros_like(x_in)
            d_all[ok] = d
            d_all[mixed] = x_in[mixed] - expected + o
            d = d_all[ok]
        s_in = with_palette(agree(d, o), x_in[ok], o).sum() / len(s.p_in)
        a_out = np.where(ok_out, with_palette(agree(x_out - s.f_out, o), x_out, o), 1.0)
        s_out = a_out.mean()
        terms[cam] = (s_in - s_out - wb * (o[1] ** 2 + o[2] ** 2), s_in, s_out, *o)
    return terms


@pytest.mark.parametrize(("level", "palette_weight"), [(0, 0.0), (2, 0.0), (3, 0.5)])
def test_kernel_matches_a_numpy_reference(level: int, palette_weight: float) -> None:
    """The numba kernel computes what the module docstring says, pose by pose."""
    model, rig, right, left, T_true, _ = _case("No.5", "gripper")
    fitness = SoftFitness(model, StereoFeatures(rig, right, left), level,
                          palette_weight=palette_weight)
    rng = np.random.default_rng(3)
    poses = np.repeat(T_true[None], 4, axis=0)
    poses[1:, :3, 3] += rng.normal(0.0, 6.0, (3, 3))
    f = fitness.evaluate_transforms(poses)
    for k in range(len(poses)):
        expected = _reference_terms(fitness, poses[k])
        np.testing.assert_allclose(fitness.last_terms[k], expected, atol=1e-6)
        assert f[k] == pytest.approx(expected[:, 0].mean(), abs=1e-6)


@pytest.mark.parametrize("level", [0, 2])
def test_kernel_matches_the_reference_with_the_garment_partly_out_of_the_image(level: int) -> None:
    """Points outside the image are weighed out, whatever their buffers hold: the kernel's
    passes run over every point without branches (the band counts 1 there)."""
    model, rig, right, left, T_true, _ = _case("No.5", "gripper")
    fitness = SoftFitness(model, StereoFeatures(rig, right, left), level)
    poses = np.repeat(T_true[None], 3, axis=0)
    poses[1, :3, 3] += [400.0, 0.0, 0.0]      # part of the garment past the right edge
    poses[2, :3, 3] += [0.0, -230.0, 10.0]    # past the top
    f = fitness.evaluate_transforms(poses)
    uv = rig.project_poses(poses[1], fitness.samples.p_in)[0] * 0.5**level
    width = fitness.features.pyramids[0][level].shape[1]
    outside = np.mean(uv[:, 0] > width - 1)
    assert 0.2 < outside < 0.8, outside
    for k in range(len(poses)):
        expected = _reference_terms(fitness, poses[k])
        np.testing.assert_allclose(fitness.last_terms[k], expected, atol=1e-6)
        assert f[k] == pytest.approx(expected[:, 0].mean(), abs=1e-6)


def _edge_mixture(model_lin: np.ndarray, gain: np.ndarray, table: np.ndarray, t: float,
                  out: np.ndarray) -> None:
    """One inner point's edge mixture with one table colour, through the kernels' passes."""
    from photomodel.fitness._soft_kernels import mixed_features, slide_mixtures

    work = np.empty((4, 3))
    slide_mixtures(model_lin, gain, table[None], np.ones(1, dtype=bool), t, work)
    mixed_features(work, 0, out)


def test_edge_mixture_mixes_intensities_not_logarithms() -> None:
    navy = log_opponent(np.array([[[90, 40, 30]]], dtype=np.uint8))[0, 0].astype(float)
    table = log_opponent(np.array([[[200, 205, 210]]], dtype=np.uint8))[0, 0].astype(float)
    out = np.empty(3)
    for t, expected_bgr in ((0.0, (90, 40, 30)), (1.0, (200, 205, 210)),
                            (0.25, (0.75 * 90 + 0.25 * 200, 0.75 * 40 + 0.25 * 205,
                                    0.75 * 30 + 0.25 * 210))):
        _edge_mixture(linear_intensity(navy), np.ones(3), table, t, out)
        b, g, r = (np.log(np.float64(x) + 8.0) for x in expected_bgr)
        np.testing.assert_allclose(out, [(b + g + r) / 3, r - g, (r + g) / 2 - b], atol=1e-5)
    # The model colour takes the scene's offsets before it mixes: a darker scene's navy.
    o = np.array([-0.3, 0.0, 0.0])
    _edge_mixture(linear_intensity(navy), linear_intensity(o), table, 0.0, out)
    np.testing.assert_allclose(out, navy + o, atol=1e-12)


@pytest.mark.parametrize("level", [0, 2])
def test_colourings_evaluated_together_equal_each_on_its_own(level: int) -> None:
    """The camera blurs' fitnesses of one pose in one pass over the images give each one's
    own evaluation to the bit, and its terms; a fitness of other points is evaluated alone."""
    model, rig, right, left, T_true, _ = _case("No.2", "gripper")
    features = StereoFeatures(rig, right, left)
    blurs = (0.5, 1.0, 2.0)
    T = T_true.copy()
    T[:3, 3] += (0.4, -0.3, 1.5)
    alone = [SoftFitness(model, features, level, optics_blur_mm=b) for b in blurs]
    expected = np.array([f.evaluate_transforms(T[None])[0] for f in alone])
    terms = [f.last_terms.copy() for f in alone]
    together = [SoftFitness(model, features, level, optics_blur_mm=b) for b in blurs]
    got = together[0].evaluate_colourings(together[1:], T)
    np.testing.assert_array_equal(got, expected)
    for f, t in zip(together, terms, strict=True):
        np.testing.assert_array_equal(f.last_terms, t)
        np.testing.assert_array_equal(f.last_offsets(), t[0, :, 3:6])
    other = SoftFitness(model, features, level + 1)
    assert not together[0]._same_points(other)
    mixed = together[0].evaluate_colourings([other], T)
    np.testing.assert_array_equal(mixed, [expected[0], other.evaluate_transforms(T[None])[0]])


def test_mix_logs_matches_the_library_exp_and_log() -> None:
    from photomodel.fitness._kernels import mix_logs

    rng = np.random.default_rng(5)
    a = np.concatenate([rng.uniform(1e-3, 500.0, 997), [1e-300, 1.0, 3e5]])
    w = np.concatenate([rng.uniform(-6.0, 9.0, 997), [-700.0, 0.0, 40.0]])
    for t in (0.0, 0.07, 0.5, 1.0):
        work = np.empty((4, len(a)))
        work[0], work[1] = a, w
        mix_logs(t, work)
        np.testing.assert_allclose(work[2], t * np.exp(w), rtol=5e-14, atol=0.0)
        np.testing.assert_allclose(work[3], np.log(a + t * np.exp(w)), rtol=1e-14, atol=1e-14)


def test_ring_mixtures_cover_the_ring_and_skip_unseen_tables() -> None:
    from photomodel.fitness._soft_kernels import mixed_features, ring_mixtures, ring_size

    table_out = np.array([2, -1, 0, 1, -1, -1], dtype=np.int64)
    assert ring_size(table_out) == 4
    assert ring_size(np.full(3, -1, dtype=np.int64)) == 0
    rng = np.random.default_rng(6)
    lin = rng.uniform(10.0, 200.0, (6, 3))
    band = rng.normal(4.0, 0.3, (3, 3))
    band_ok = np.array([True, False, True])
    gain = np.array([1.1, 0.9, 1.0])
    work = np.empty((4, 3 * 4))
    ring_mixtures(lin, gain, table_out, band, band_ok, 0.3, work)
    out = np.empty(3)
    expected = np.empty(3)
    for j in (0, 2):       # 3 has an unseen table (band point 1), 1 none
        mixed_features(work, j, out)
        _edge_mixture(lin[j], gain, band[table_out[j]], 0.3, expected)
        np.testing.assert_allclose(out, expected, rtol=1e-14)
        to_logs = np.linalg.inv(_OPPONENT_FROM_LOGS)
        logs = np.log(0.7 * lin[j] * gain + 0.3 * np.exp(to_logs @ band[table_out[j]]))
        np.testing.assert_allclose(out, _OPPONENT_FROM_LOGS @ logs, rtol=1e-13)


def test_edge_mix_takes_the_depth_bias_off_a_dark_garment() -> None:
    """Along camera 1's ray through the true pose of the navy trousers, the level-0 fitness
    peaks 4.8 mm too far without the edge mixture and within a millimetre with it."""
    model, rig, right, left, T_true, _ = _case("No.2")
    x_true = _vector(T_true)
    dz = np.arange(-10.0, 10.5, 0.5)
    poses = np.repeat(x_true[None], len(dz), axis=0)
    poses[:, :3] *= (1.0 + dz / x_true[2])[:, None]
    peaks = {}
    for mix in (False, True):
        features = StereoFeatures(rig, right, left, match=SoftMatch(edge_mix=mix))
        fitness = SoftFitness(model, features, 0)
        assert (fitness.edge_mix_fraction > 0.05) is mix
        peaks[mix] = dz[np.argmax(fitness(poses))]
    assert peaks[False] >= 3.0 and abs(peaks[True]) <= 1.0, peaks


def test_a_negligible_edge_mix_is_left_out() -> None:
    """The coarse levels' rings lie far inside the blur: a mixed fraction below
    ``min_edge_mix`` counts as none, and the fitness is the same to the rounding."""
    model, rig, right, left, T_true, _ = _case("No.2")
    poses = _vector(T_true)[None] + np.array([[0.0] * 6, [2.0, -1.0, 4.0, 0.0, 0.0, 0.002]])
    fractions, values = {}, {}
    for least in (0.0, 1e-3):
        features = StereoFeatures(rig, right, left, match=SoftMatch(min_edge_mix=least))
        for level in (0, 3):
            fitness = SoftFitness(model, features, level)
            fractions[least, level] = fitness.edge_mix_fraction
            values[least, level] = fitness(poses)
    assert fractions[1e-3, 0] == fractions[0.0, 0] > 0.05
    assert 0.0 < fractions[0.0, 3] < 1e-12 and fractions[1e-3, 3] == 0.0
    np.testing.assert_allclose(values[1e-3, 3], values[0.0, 3], atol=1e-12)
    with pytest.raises(ValueError, match="tolerances"):
        SoftMatch(min_edge_mix=-1.0)


def test_linear_intensity_inverts_log_opponent() -> None:
    bgr = np.random.default_rng(0).integers(0, 256, (7, 5, 3), dtype=np.uint8)
    np.testing.assert_allclose(linear_intensity(log_opponent(bgr)), bgr + 8.0, rtol=1e-5)


def test_the_navy_trousers_are_found_at_their_depth() -> None:
    """A plain garment's blur trades with its depth: with blurs sharper than a camera in
    focus to choose from, No.2 settled 2.4 mm too far (PyramidConfig's candidates)."""
    from photomodel.locate import locate
    from photomodel.sim import scene_rng

    model, rig, right, left, T_true, _ = _case("No.2")
    result = locate(model, rig, right, left, rng=scene_rng(0, "search", "paper_No.2_0000"))
    error = result.T_cam1_model[:3, 3] - T_true[:3, 3]
    assert result.found and abs(error[2]) < 1.0, error
    assert result.optics_blur_mm is not None and result.optics_blur_mm >= 0.5


def test_projection_jacobian_matches_differences_with_every_distortion_term() -> None:
    """``_projection_jacobian`` gives ``_project``'s pixel and its derivative, the rational,
    tangential and thin-prism terms included; ``plane_pixels`` and ``plane_pixel_jacobians``
    give the same for model-plane points at a pose, a point set at a time."""
    from photomodel.fitness._kernels import (
        _project,
        _projection_jacobian,
        plane_pixel_jacobians,
        plane_pixels,
    )
    from photomodel.geometry import rotation_from_eps

    K = np.array([[800.0, 0.4, 330.0], [0.0, 795.0, 245.0], [0.0, 0.0, 1.0]])
    D = np.array([-0.2, 0.08, 1e-3, -2e-3, -0.01, 0.02, -0.01, 0.005, 1e-3, -5e-4, 2e-3, 1e-4])
    for X in ([40.0, -30.0, 650.0], [-180.0, 120.0, 700.0], [0.0, 0.0, 500.0]):
        u, v, *rows = _projection_jacobian(*X, K, D)
        jac = np.reshape(rows, (2, 3))
        assert (u, v) == pytest.approx(_project(*X, K, D), abs=1e-9)
        for i in range(3):
            step = np.zeros(3)
            step[i] = 1e-4
            plus, minus = _project(*(X + step), K, D), _project(*(X - step), K, D)
            np.testing.assert_allclose(jac[:, i], (np.subtract(plus, minus)) / 2e-4,
                                       rtol=1e-6, atol=1e-9)
    R = rotation_from_eps(np.array([0.05, -0.08, 0.3]))
    t = np.array([25.0, -40.0, 680.0])
    points = np.random.default_rng(3).uniform(-120.0, 120.0, (7, 3))
    pixels, rows = np.empty((2, 7)), np.empty((8, 7))
    xy = np.ascontiguousarray(points[:, :2].T)    # the kernels take x and y by row
    plane_pixels(R, t, K, D, xy, pixels)
    plane_pixel_jacobians(R, t, K, D, xy, rows)
    for j, (x, y, _) in enumerate(points):
        X = R[:, 0] * x + R[:, 1] * y + t
        np.testing.assert_allclose(pixels[:, j], _project(*X, K, D), rtol=1e-12)
        np.testing.assert_allclose(rows[:, j], _projection_jacobian(*X, K, D), rtol=1e-12)


def _strained_maps(genes: np.ndarray) -> np.ndarray:
    """Maps (P, 4, 4) of pose vectors with strains (P, 9)."""
    from photomodel.geometry import strained_matrices

    return strained_matrices(genes[:, :6], genes[:, 6:])


def _strained_case(garment: str, condition: str, level: int, shift_mm: list[float],
                   eps_kick: float, strain: list[float]
                   ) -> tuple[SoftFitness, np.ndarray, np.ndarray]:
    """A scene's level fitness, a strained gene vector (9,) off its true pose by
    ``shift_mm`` and ``eps_kick``, and the light offsets the fitness found there."""
    from photomodel.geometry import eps_from_rotation

    model, rig, right, left, T, _ = _case(garment, condition)
    fitness = SoftFitness(model, StereoFeatures(rig, right, left), level)
    x = np.concatenate([T[:3, 3] + shift_mm, eps_from_rotation(T[:3, :3]) + eps_kick, strain])
    fitness.evaluate_transforms(_strained_maps(x[None]))
    return fitness, x, fitness.last_offsets()


@pytest.mark.parametrize(("garment", "level"), [("No.1", 0), ("No.1", 1), ("No.6", 0)])
def test_normal_equations_match_the_residuals_differences(garment: str, level: int) -> None:
    """The analytic gradient and metric (a strained map, nine genes, the edge mixture of the
    inner ring included) agree with those of forward differences of the residuals."""
    from fitness_helpers import residual_products

    from photomodel.search._gauss_newton import _map_derivatives

    fitness, x, offsets = _strained_case(garment, "paper", level, [0.8, -0.5, 2.0], 0.002,
                                         [-0.01, 0.005, 0.003])
    assert fitness.edge_mix_fraction > 0
    maps = _strained_maps
    h = np.array([0.02, 0.02, 0.1, 2e-5, 2e-5, 2e-5, 1e-4, 1e-4, 1e-4]) * 2.0**level
    poses = np.repeat(x[None], 10, axis=0)
    poses[1:] += np.diag(h)
    r, ok = fitness.residuals(maps(poses), offsets)
    g_diff, m_diff = residual_products(r, ok, fitness.residual_weights(), h)
    free = np.ones(9, dtype=bool)
    g, m = fitness.normal_equations(maps(x[None])[0], _map_derivatives(x, free), offsets)
    np.testing.assert_allclose(g, g_diff, atol=0.01 * np.abs(g_diff).max())
    scale = np.sqrt(np.outer(np.diag(m_diff), np.diag(m_diff)))
    assert np.abs((m - m_diff) / scale).max() < 0.03
    np.testing.assert_array_equal(m, m.T)
    # Fewer genes: the rows and columns of the free ones.
    free[[2, 7]] = False
    g5, m5 = fitness.normal_equations(maps(x[None])[0], _map_derivatives(x, free),
                                      offsets)
    np.testing.assert_allclose(g5, g[free], rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(m5, m[np.ix_(free, free)], rtol=1e-9, atol=1e-12)


def test_normal_equations_are_the_same_on_one_or_two_threads() -> None:
    """Each camera's sums (the offsets' Hessian and slope included) are its thread's own and
    reach the outputs once: the same to the bit whether the two cameras run on one thread or
    side by side (they once summed into outputs that share a cache line, 2x slower)."""
    import numba

    from photomodel.search._gauss_newton import _map_derivatives

    fitness, x, offsets = _strained_case("No.1", "paper", 0, [0.4, -0.3, 1.0], 0.001,
                                         [-0.004, 0.002, 0.001])
    A, dA = _strained_maps(x[None])[0], _map_derivatives(x, np.ones(9, dtype=bool))
    threads = numba.get_num_threads()
    try:
        numba.set_num_threads(1)
        one = fitness.normal_equations(A, dA, offsets, with_offsets=True)
        numba.set_num_threads(min(2, numba.config.NUMBA_NUM_THREADS))
        two = fitness.normal_equations(A, dA, offsets, with_offsets=True)
    finally:
        numba.set_num_threads(threads)
    for a, b in zip(one, two, strict=True):
        np.testing.assert_array_equal(a, b)
    assert np.all(np.isfinite(one[0])) and np.abs(one[0]).max() > 0


@pytest.mark.parametrize(("garment", "condition", "level"),
                         [("No.6", "paper", 0), ("No.6", "gripper", 1), ("No.1", "paper", 0)])
def test_the_full_gradient_follows_the_fitness_where_the_held_one_does_not(
        garment: str, condition: str, level: int) -> None:
    """With the offsets' motion (the implicit function theorem on their objective) the
    gradient is the fitness's own (central differences); with the offsets held it is not,
    where the band decides (the grey sock)."""
    from photomodel.search._gauss_newton import _map_derivatives

    fitness, x, offsets = _strained_case(garment, condition, level, [0.3, -0.2, 0.8], 0.0005,
                                         [-0.003, 0.002, 0.001])
    maps = _strained_maps
    dA = _map_derivatives(x, np.ones(9, dtype=bool))
    held, _ = fitness.normal_equations(maps(x[None])[0], dA, offsets)
    full, _ = fitness.normal_equations(maps(x[None])[0], dA, offsets, with_offsets=True)
    h = np.array([0.02, 0.02, 0.1, 2e-5, 2e-5, 2e-5, 1e-4, 1e-4, 1e-4]) * 2.0**level
    poses = np.repeat(x[None], 18, axis=0)
    poses[:9] += np.diag(h)
    poses[9:] -= np.diag(h)
    values = fitness.evaluate_transforms(maps(poses))
    central = (values[:9] - values[9:]) / (2 * h)
    scale = np.abs(central).max()
    assert np.abs(full - central).max() < 0.05 * scale
    if garment == "No.6":
        assert np.abs(held - central).max() > 0.3 * scale


def test_exp_neg_matches_exp_over_the_agreements_range() -> None:
    """The kernels' vectorisable exp(-y) agrees with the library exp to 4e-12 relative where
    an agreement counts (y < 30), 2e-9 up to 60, and stays tiny beyond."""
    from numba import njit

    from photomodel.fitness._kernels import exp_neg

    @njit
    def many(y: np.ndarray) -> np.ndarray:
        out = np.empty_like(y)
        for i in range(y.shape[0]):
            out[i] = exp_neg(y[i])
        return out

    y = np.linspace(0.0, 60.0, 120001)
    rel = np.abs(many(y) / np.exp(-y) - 1.0)
    assert rel[y < 30.0].max() < 4e-12
    assert rel.max() < 2e-9
    assert many(np.array([0.0]))[0] == 1.0
    far = many(np.array([60.0, 100.0, 1e6]))
    assert np.all(far > 0.0) and np.all(far < 1e-25)


def test_blank_features_have_a_pairs_sizes_and_cameras_without_images() -> None:
    """What a preparation reads of a pair: the rig, the levels, every level's size (as
    ``cv2.pyrDown`` halves odd sizes) and its cameras; a rig without image sizes is refused."""
    from dataclasses import replace

    from photomodel.camera import StereoRig

    _, rig, right, left, _, _ = _case("No.6")
    for levels in (1, 5):
        pair = StereoFeatures(rig, right, left, levels=levels)
        blank = StereoFeatures.blank(rig, levels=levels)
        assert blank.levels == pair.levels and blank.rig is rig
        assert blank.match == pair.match
        for ours, theirs in zip(blank.pyramids, pair.pyramids, strict=True):
            assert [a.shape for a in ours] == [a.shape for a in theirs]
            assert all(a.dtype == np.float32 and a.flags.c_contiguous and not a.any()
                       for a in ours)
        for level in range(levels):
            np.testing.assert_array_equal(blank.camera_matrices(level)[1],
                                          pair.camera_matrices(level)[1])
    odd = StereoRig(replace(rig.cam1, width_px=641, height_px=479),
                    replace(rig.cam2, width_px=321, height_px=241), rig.R, rig.T)
    images = (np.zeros((479, 641, 3), np.uint8), np.zeros((241, 321, 3), np.uint8))
    for ours, theirs in zip(StereoFeatures.blank(odd).pyramids,
                            StereoFeatures(odd, *images).pyramids, strict=True):
        assert [a.shape for a in ours] == [a.shape for a in theirs]
    unsized = StereoRig(replace(rig.cam1, width_px=0, height_px=0), rig.cam2, rig.R, rig.T)
    with pytest.raises(ValueError, match="rig"):
        StereoFeatures.blank(unsized)
    with pytest.raises(ValueError, match="levels"):
        StereoFeatures.blank(rig, levels=0)
