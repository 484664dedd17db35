"""Ground-truth recovery: render a garment at a known pose, locate it, compare.

Acceptance (issue 2): x-y position error under 3 mm and in-plane angle error under 1 deg in at
least 9 of 10 seeded scenes, for a textured (plaid) and a plain single-colour garment. The
position criterion is the x-y error in camera 1's frame, the paper's "position (x-y)"; the
depth error is checked against a looser bound and reported by the experiment.
"""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from photomodel.camera import PinholeCamera, StereoRig, load_stereo
from photomodel.geometry import in_plane_angle_rad
from photomodel.locate import LocateResult, locate
from photomodel.model import build_photo_model
from photomodel.sim import (
    MODEL_DISTANCE_MM,
    hand_stereo_rig,
    random_stereo_scene,
    render_model_photos,
    render_stereo_scene,
)

XY_TOL_MM = 3.0
THETA_TOL_DEG = 1.0
Z_TOL_MM = 15.0


def pose_errors(result: LocateResult, T_true: np.ndarray) -> tuple[float, float, float]:
    """(x-y error mm, |z error| mm, |theta error| deg)."""
    d = result.T_cam1_model[:3, 3] - T_true[:3, 3]
    dth = np.rad2deg(in_plane_angle_rad(result.T_cam1_model) - in_plane_angle_rad(T_true))
    dth = (dth + 180.0) % 360.0 - 180.0
    return float(np.hypot(d[0], d[1])), float(abs(d[2])), float(abs(dth))


@pytest.mark.parametrize("case_name", ["plaid_case", "plain_case"])
def test_locate_recovers_pose_in_nine_of_ten_scenes(case_name: str, request) -> None:
    case = request.getfixturevalue(case_name)
    good = 0
    report = []
    for k in range(10):
        scene = random_stereo_scene(case.garment, case.rig, rng=1000 + k)
        result = locate(case.built.model, case.rig, scene.right_bgr, scene.left_bgr, rng=k)
        exy, ez, eth = pose_errors(result, scene.T_cam1_model)
        ok = exy < XY_TOL_MM and eth < THETA_TOL_DEG and ez < Z_TOL_MM and result.found
        good += ok
        report.append(f"scene {k}: xy {exy:.2f} mm, z {ez:.2f} mm, theta {eth:.2f} deg, "
                      f"score {result.score:.3f}")
    assert good >= 9, "\n".join(report)


def _strong_distortion_rig() -> StereoRig:
    base = hand_stereo_rig()
    d1 = np.array([-0.32, 0.14, 0.0015, -0.001, -0.02])
    d2 = np.array([-0.30, 0.12, -0.001, 0.0012, -0.02])
    return StereoRig(PinholeCamera(base.cam1.K, d1, 640, 480),
                     PinholeCamera(base.cam2.K, d2, 640, 480), base.R, base.T)


def _write_with_filestorage(path, rig: StereoRig) -> None:
    fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_WRITE)
    fs.write("image_width", 640)
    fs.write("image_height", 480)
    fs.write("M1", rig.cam1.K)
    fs.write("D1", rig.cam1.dist.reshape(1, -1))
    fs.write("M2", rig.cam2.K)
    fs.write("D2", rig.cam2.dist.reshape(1, -1))
    fs.write("R", rig.R)
    fs.write("T", rig.T.reshape(3, 1))
    fs.release()


def _without_distortion(rig: StereoRig) -> StereoRig:
    c1, c2 = rig.cameras
    return StereoRig(PinholeCamera(c1.K, np.zeros(5), 640, 480),
                     PinholeCamera(c2.K, np.zeros(5), 640, 480), rig.R, rig.T)


def test_distortion_from_filestorage_calibration_is_honoured(tmp_path, plaid_case) -> None:
    """Strong lens distortion, calibration written by cv2.FileStorage: the pose comes out
    right with the calibration, and ignoring its distortion would fail the same test."""
    rig_true = _strong_distortion_rig()
    path = tmp_path / "stereo.xml"
    _write_with_filestorage(path, rig_true)
    rig = load_stereo(path)
    assert rig.cam1.has_distortion and rig.cam2.has_distortion

    # The model station's camera is distorted too (sim default); build with and without it.
    camera = plaid_case.camera
    assert camera.has_distortion
    photo, background = render_model_photos(plaid_case.garment, camera, rng=5,
                                            offset_mm=(40.0, 30.0))
    model = build_photo_model(photo, background, camera, MODEL_DISTANCE_MM).model
    naive_camera = PinholeCamera(camera.K, np.zeros(5), camera.width_px, camera.height_px)
    naive_model = build_photo_model(photo, background, naive_camera, MODEL_DISTANCE_MM).model

    # Garment towards the corner of the images, where the lenses bend most.
    scene = render_stereo_scene(plaid_case.garment, rig_true, rng=8, x_mm=135.0, y_mm=95.0,
                                theta_deg=20.0)
    good = locate(model, rig, scene.right_bgr, scene.left_bgr, rng=1)
    naive = locate(naive_model, _without_distortion(rig), scene.right_bgr, scene.left_bgr, rng=1)

    exy, ez, eth = pose_errors(good, scene.T_cam1_model)
    assert exy < XY_TOL_MM and eth < THETA_TOL_DEG and ez < Z_TOL_MM, (exy, ez, eth)
    nxy, nz, nth = pose_errors(naive, scene.T_cam1_model)
    # Ignoring the distortion costs several mm of depth even where the fit still holds.
    assert nz >= 3.0 * ez + 3.0 or nxy >= XY_TOL_MM or nth >= THETA_TOL_DEG, (ez, nxy, nz, nth)
    assert good.score > naive.score


def test_locate_searches_again_while_the_score_is_below_the_threshold(plaid_case) -> None:
    scene = random_stereo_scene(plaid_case.garment, plaid_case.rig, rng=1000)
    once = locate(plaid_case.built.model, plaid_case.rig, scene.right_bgr, scene.left_bgr, rng=0)
    assert once.found and "searches" not in once.search.stop_reason   # found: no second search
    assert 0.0 <= once.to_json_dict()["optics_blur_mm"] <= 1.0         # rendered in focus
    blank = np.full_like(scene.right_bgr, 128)                         # nothing on the table
    from photomodel.fitness import StereoFeatures
    from photomodel.locate import LocateSettings, locate_in_features

    features = StereoFeatures(plaid_case.rig, blank, blank)
    twice = locate_in_features(plaid_case.built.model, features, rng=0)
    assert not twice.found and twice.search.stop_reason.startswith("best of 2 searches")
    single = locate_in_features(plaid_case.built.model, features, rng=0,
                                settings=LocateSettings(retries=0))
    assert twice.search.evaluations > single.search.evaluations
    with pytest.raises(ValueError, match="retries"):
        LocateSettings(retries=-1)


def test_locate_looks_with_the_level_3_scan_when_the_coarse_one_scores_under(plaid_case) -> None:
    from photomodel.fitness import StereoFeatures
    from photomodel.locate import LocateSettings, locate_in_features

    scene = random_stereo_scene(plaid_case.garment, plaid_case.rig, rng=1001)
    features = StereoFeatures(plaid_case.rig, scene.right_bgr, scene.left_bgr)
    model = plaid_case.built.model
    coarse = locate_in_features(model, features, rng=0)
    fine = locate_in_features(model, features, rng=0, settings=LocateSettings(coarse_scan=None))
    assert coarse.found and fine.found and "searches" not in coarse.search.stop_reason
    assert np.abs(coarse.T_cam1_model[:3, 3] - fine.T_cam1_model[:3, 3]).max() < 1.0
    # A threshold no search reaches: the coarse search, level 3's and its retry.
    strict = locate_in_features(model, features, rng=0, min_score=1.01)
    assert not strict.found and strict.search.stop_reason.startswith("best of 3 searches")
    assert strict.score >= coarse.score - 1e-9
