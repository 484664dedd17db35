"""Photo-models of unknown scale (``photomodel.model._scale``) and their first locate, which
measures the scale (``photomodel.locate.locate_unknown_scale`` through ``Locator``).

The true factor is fitted independently of the locate (:func:`photomodel.sim.station_scale`:
the station model's outline, mm through the station camera's lens, against the same photo
pixels at the nominal scale, least squares with a shift; ``benchmarks/bench_register.py``
uses it too).
"""

from __future__ import annotations

import time
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest
from numpy.typing import NDArray
from scipy.spatial import cKDTree

import photomodel as pm
from photomodel.camera import StereoRig
from photomodel.errors import NoGarmentError
from photomodel.locate import LocateResult
from photomodel.model import PhotoModel, load_model, save_model
from photomodel.model._scale import (
    NOMINAL_PHOTO_MM,
    build_unknown_scale,
    resampled_model,
    scale_known,
    scaled_model,
)
from photomodel.sim import (
    catalogue_garment,
    hand_stereo_rig,
    model_station_camera,
    parse_conditions,
    render_model_photos,
    simulate_scene,
    station_model,
    station_scale,
)

SCALE_TOL = 0.005
"""The first locate's factor against the fitted truth (0.5 %)."""
POSE_TOL_MM = 2.0


@dataclass(frozen=True)
class ScaleData:
    """No.2's station photo built at the nominal scale, its station model, the true factor,
    and a Locator of the nominal model after two calls on paper shots of No.2."""

    photo: NDArray[np.uint8]
    nominal: PhotoModel
    station: PhotoModel
    factor: float
    carry: NDArray[np.float64]
    rig: StereoRig
    locator: pm.Locator
    first: LocateResult
    first_s: float
    second: LocateResult
    second_s: float
    second_truth: NDArray[np.float64]


@pytest.fixture(scope="module")
def data() -> ScaleData:
    photo, _ = render_model_photos(catalogue_garment("No.2"), model_station_camera(), rng=3)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        nominal = build_unknown_scale(photo, name="No.2").model
    station = station_model("No.2", 0)
    factor, carry = station_scale(station, nominal)
    rig = hand_stereo_rig()
    shots = [simulate_scene(catalogue_garment("No.2"), rig, parse_conditions("paper"), seed)
             for seed in (21, 22)]
    locator = pm.Locator(nominal, rig)
    t0 = time.perf_counter()
    first = locator(shots[0].right_bgr, shots[0].left_bgr, rng=0)
    first_s = time.perf_counter() - t0
    t0 = time.perf_counter()
    second = locator(shots[1].right_bgr, shots[1].left_bgr, rng=0)
    second_s = time.perf_counter() - t0
    assert shots[1].T_cam1_model is not None
    return ScaleData(photo, nominal, station, factor, carry, rig, locator, first, first_s,
                     second, second_s, shots[1].T_cam1_model @ carry)


# --- the model of unknown scale -------------------------------------------------------------


def test_build_has_unknown_scale(data: ScaleData) -> None:
    model = data.nominal
    assert not scale_known(model)
    scale = model.meta["scale"]
    assert scale["known"] is False and scale["photo_shrink"] == 1.0
    h, w = data.photo.shape[:2]
    assert scale["nominal_mm_per_px"] == pytest.approx(NOMINAL_PHOTO_MM / max(h, w))
    assert scale_known(data.station)
    # the fitted truth agrees with the areas' ratio
    assert data.factor == pytest.approx(np.sqrt(data.station.area_mm2 / model.area_mm2),
                                        rel=0.01)


def test_scaled_model_scales_every_length(data: ScaleData) -> None:
    model, f = data.nominal, 0.5
    scaled = scaled_model(model, f)
    np.testing.assert_allclose(scaled.points_in_mm, model.points_in_mm * f)
    np.testing.assert_allclose(scaled.points_out_mm, model.points_out_mm * f)
    np.testing.assert_allclose(scaled.outline_mm, model.outline_mm * f)
    assert scaled.meta["distance_mm"] == pytest.approx(model.meta["distance_mm"] * f)
    np.testing.assert_allclose(scaled.meta["centroid_in_camera_mm"],
                               np.asarray(model.meta["centroid_in_camera_mm"]) * f)
    assert scaled.area_mm2 == pytest.approx(model.area_mm2 * f**2, rel=1e-9)
    assert scaled.n_in == model.n_in and scaled.n_out == model.n_out
    # a trial scale (no source) stays unknown; factors compose
    assert not scale_known(scaled) and scaled.meta["scale"]["factor"] == pytest.approx(f)
    again = scaled_model(scaled, 3.0, source="measured")
    assert scale_known(again) and again.meta["scale"]["source"] == "measured"
    assert again.meta["scale"]["factor"] == pytest.approx(1.5)
    assert not scale_known(model)            # the original is untouched


@pytest.mark.parametrize("factor", [0.0, 0.01, 100.0, float("nan"), float("inf")])
def test_scaled_model_refuses_a_factor_out_of_range(data: ScaleData, factor: float) -> None:
    with pytest.raises(ValueError, match="^scale: expected a factor"):
        scaled_model(data.nominal, factor)


def test_resampled_model_is_a_station_like_model(data: ScaleData) -> None:
    model = resampled_model(data.nominal, data.factor, source="x")
    assert scale_known(model) and model.meta["scale"]["source"] == "x"
    assert model.meta["scale"]["factor"] == pytest.approx(data.factor)
    points = model.points_in_mm[:, :2]
    spacing, _ = cKDTree(points).query(points, k=2)
    assert np.median(spacing[:, 1]) == pytest.approx(3.0, abs=0.1)
    assert model.n_in == pytest.approx(data.station.n_in, rel=0.03)
    assert model.area_mm2 == pytest.approx(data.station.area_mm2, rel=0.01)
    assert model.n_in < data.nominal.n_in / 2     # the nominal pitch was far finer


def test_save_and_load_keep_the_scale(data: ScaleData, tmp_path: Path) -> None:
    for model, name in ((data.nominal, "nominal.model"),
                        (resampled_model(data.nominal, data.factor, source="x"),
                         "known.model")):
        loaded = load_model(save_model(model, tmp_path / name))
        assert loaded.meta["scale"] == model.meta["scale"]
        assert scale_known(loaded) == scale_known(model)
        np.testing.assert_allclose(loaded.points_in_mm, model.points_in_mm)


def test_photo_without_garment_is_refused() -> None:
    plain = np.full((480, 640, 3), (90, 140, 60), np.uint8)
    with pytest.raises(NoGarmentError, match="surface") as exc:
        build_unknown_scale(plain, name="nothing", photo_source="plain.png")
    assert str(exc.value).startswith("plain.png: ")


# --- the first locate measures the scale ------------------------------------------------------


def test_first_locate_measures_the_scale(data: ScaleData) -> None:
    first = data.first
    assert first.found and first.scale is not None
    assert first.scale == pytest.approx(data.factor, rel=SCALE_TOL)
    assert data.locator.scale == first.scale
    assert first.to_json_dict()["scale"] == first.scale
    # the Locator now holds the model at that scale (stored only by ``models set-scale``)
    kept = data.locator.model
    assert data.locator.nominal is data.nominal
    assert kept.meta["scale"]["factor"] == first.scale
    assert kept.area_mm2 == pytest.approx(data.station.area_mm2, rel=0.01)


def test_later_calls_are_ordinary_and_carry_the_scale(data: ScaleData) -> None:
    second = data.second
    assert second.found and second.scale == data.first.scale
    assert second.to_json_dict()["scale"] == data.first.scale
    assert data.second_s < data.first_s, (data.second_s, data.first_s)
    error_mm = np.linalg.norm(second.T_cam1_model[:3, 3] - data.second_truth[:3, 3])
    assert error_mm < POSE_TOL_MM


def test_a_known_scale_model_has_no_scale_in_its_result(data: ScaleData) -> None:
    locator = pm.Locator(data.station, data.rig)
    assert locator.scale is None and locator.nominal is None
    shot = simulate_scene(catalogue_garment("No.2"), data.rig, parse_conditions("paper"), 22)
    result = locator(shot.right_bgr, shot.left_bgr, rng=0)
    assert result.found and result.scale is None
    assert "scale" not in result.to_json_dict()


def test_unknown_scale_needs_the_default_method(data: ScaleData) -> None:
    with pytest.raises(ValueError, match="unknown scale"):
        pm.Locator(data.nominal, data.rig, method="paper")
