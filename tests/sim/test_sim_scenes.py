"""Ready-made scenes: model-station photos and stereo pairs with ground truth."""

from __future__ import annotations

import itertools

import cv2
import numpy as np
import pytest

from photomodel.geometry import transform_points
from photomodel.sim import (
    MODEL_DISTANCE_MM,
    StereoScene,
    garment_placement,
    hand_table_pose,
    make_garment,
    model_station_camera,
    random_stereo_scene,
    render_model_photos,
    render_stereo_scene,
)


@pytest.fixture(scope="module")
def tshirt():
    return make_garment("tshirt", "plaid", (220.0, 180.0), rng=11)


def _not_green(image: np.ndarray) -> np.ndarray:
    hsv = cv2.cvtColor(image, cv2.COLOR_BGR2HSV).astype(float)
    return np.abs(hsv[..., 0] - 62) > 18


def test_model_photos_show_the_garment_at_the_model_scale(tshirt):
    camera = model_station_camera()
    photo, background = render_model_photos(tshirt, camera, rng=2)
    assert photo.shape == background.shape == (480, 640, 3) and photo.dtype == np.uint8
    garment = _not_green(photo)
    assert not _not_green(background).any()
    # Area: silhouette mm^2 times (f / Z)^2 pixels per mm^2 (barrel distortion shrinks it a bit).
    area_mm2 = tshirt.texture.alpha.sum() * tshirt.texture.mm_per_px**2
    expected_px = area_mm2 * (camera.K[0, 0] / MODEL_DISTANCE_MM) ** 2
    assert 0.93 * expected_px < garment.sum() < 1.01 * expected_px
    # Its centroid is near the projection of the garment origin (offset (6, -4) mm).
    v, u = np.nonzero(garment)
    origin_uv = camera.project([6.0, -4.0, MODEL_DISTANCE_MM])
    assert np.linalg.norm([u.mean(), v.mean()] - origin_uv) < 2.0
    # Away from the garment the two photos differ by independent sensor noise only.
    diff = photo.astype(float) - background.astype(float)
    far = cv2.dilate(garment.astype(np.uint8), np.ones((9, 9), np.uint8)) == 0
    assert 1.7 < diff[far].std() < 2.6 and abs(diff[far].mean()) < 0.1


def test_stereo_scene_truth_and_visibility(tshirt, rig):
    scene = render_stereo_scene(tshirt, rig, 5, x_mm=30.0, y_mm=-20.0, theta_deg=40.0)
    assert isinstance(scene, StereoScene)
    for image in (scene.right_bgr, scene.left_bgr):
        assert image.shape == (480, 640, 3) and image.dtype == np.uint8
    expected = hand_table_pose(rig) @ garment_placement(30.0, -20.0, 40.0)
    np.testing.assert_allclose(scene.T_cam1_model, expected)
    # The garment origin is on the plaid in both images, not on the grey table.
    origin1 = rig.cam1.project(scene.T_cam1_model[:3, 3])
    origin2 = rig.cam2.project(transform_points(rig.T_cam2_cam1, scene.T_cam1_model[None, :3, 3]))
    for image, uv in ((scene.right_bgr, origin1), (scene.left_bgr, origin2[0])):
        u, v = np.rint(uv).astype(int)
        hsv = cv2.cvtColor(image[v - 2:v + 3, u - 2:u + 3], cv2.COLOR_BGR2HSV)
        assert hsv[..., 1].mean() > 60


def test_scenes_are_deterministic_per_seed(tshirt, rig):
    a = random_stereo_scene(tshirt, rig, 9)
    b = random_stereo_scene(tshirt, rig, np.random.default_rng(9))
    c = random_stereo_scene(tshirt, rig, 10)
    assert a.right_bgr.tobytes() == b.right_bgr.tobytes()
    assert a.left_bgr.tobytes() == b.left_bgr.tobytes()
    np.testing.assert_array_equal(a.T_cam1_model, b.T_cam1_model)
    assert not np.array_equal(a.right_bgr, c.right_bgr)
    assert not np.array_equal(a.T_cam1_model, c.T_cam1_model)
    p1, _ = render_model_photos(tshirt, model_station_camera(), 3)
    p2, _ = render_model_photos(tshirt, model_station_camera(), 3)
    p3, _ = render_model_photos(tshirt, model_station_camera(), 4)
    assert p1.tobytes() == p2.tobytes() and p1.tobytes() != p3.tobytes()


def test_default_ranges_keep_a_200_by_160_mm_garment_inside_both_images(rig):
    towel = make_garment("towel", "plain", (200.0, 160.0), rng=0)  # the fullest silhouette
    contours, _ = cv2.findContours((towel.texture.alpha > 0).astype(np.uint8),
                                   cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
    edge_mm = towel.texture.mm_from_px(contours[0].reshape(-1, 2))
    pts = np.column_stack([edge_mm, np.zeros(len(edge_mm))])
    T_cam1_table = hand_table_pose(rig)
    for x, y, theta in itertools.product((-120, 120), (-80, 80), np.linspace(-53, 53, 11)):
        P = transform_points(T_cam1_table @ garment_placement(x, y, theta), pts)
        for cam, T_cam_cam1 in ((rig.cam1, np.eye(4)), (rig.cam2, rig.T_cam2_cam1)):
            uv = cam.project(transform_points(T_cam_cam1, P))
            assert uv.min() > 0 and uv[:, 0].max() < 639 and uv[:, 1].max() < 479
