"""The renderer is exact: texture points land where the camera model projects them."""

from __future__ import annotations

import numpy as np
import pytest
from sim_helpers import dot_card, dot_centroid

from photomodel.camera import PinholeCamera, StereoRig
from photomodel.geometry import make_transform, transform_points
from photomodel.sim import (
    MODEL_DISTANCE_MM,
    PlaneTexture,
    blur,
    garment_placement,
    hand_table_pose,
    model_station_camera,
    render_view,
    uniform_plane,
)
from photomodel.sim._render import add_sensor_noise, pixel_rays

CARD_PLACEMENT = garment_placement(8.0, -5.0, 7.0)  # T_plane_card


def _table() -> PlaneTexture:
    return uniform_plane((128, 128, 128), (1000.0, 800.0), 1.0, rng=0, noise=0.0)


def _rig_views(rig: StereoRig) -> list[tuple[PinholeCamera, np.ndarray]]:
    T_cam1_table = hand_table_pose(rig)
    return [(rig.cam1, T_cam1_table), (rig.cam2, rig.T_cam2_cam1 @ T_cam1_table)]


def _measure(camera: PinholeCamera, T_cam_plane: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Predicted and detected pixels (N, 2) of the card's dots; NaN where outside the image."""
    card, dots_mm = dot_card()
    image = render_view(camera, T_cam_plane, _table(), [(CARD_PLACEMENT, card)])
    dots = np.column_stack([dots_mm, np.zeros(len(dots_mm))])
    predicted = camera.project(transform_points(T_cam_plane @ CARD_PLACEMENT, dots))
    found = [dot_centroid(image, uv) for uv in predicted]
    return predicted, np.array([np.full(2, np.nan) if f is None else f for f in found])


@pytest.mark.parametrize("distorted", [True, False])
def test_dots_land_on_the_projection_in_both_hand_cameras(distorted, rig, rig_undistorted):
    for camera, T_cam_table in _rig_views(rig if distorted else rig_undistorted):
        predicted, found = _measure(camera, T_cam_table)
        err = np.linalg.norm(found - predicted, axis=1)
        assert np.isfinite(err).sum() >= 80
        assert np.nanmax(err) < 0.05, np.nanmax(err)  # measured: about 0.01 px


def test_dots_land_on_the_projection_in_the_model_camera():
    camera = model_station_camera()
    predicted, found = _measure(camera, make_transform(np.eye(3), [0, 0, MODEL_DISTANCE_MM]))
    err = np.linalg.norm(found - predicted, axis=1)
    assert np.isfinite(err).sum() >= 40
    assert np.nanmax(err) < 0.05, np.nanmax(err)  # measured: about 0.01 px


def test_distortion_moves_corner_dots_by_several_pixels(rig, rig_undistorted):
    (cam_d, T_d), (cam_u, T_u) = _rig_views(rig)[0], _rig_views(rig_undistorted)[0]
    found_d = _measure(cam_d, T_d)[1]
    pred_u, found_u = _measure(cam_u, T_u)
    seen = np.isfinite(found_d[:, 0]) & np.isfinite(found_u[:, 0])
    radius = np.where(seen, np.linalg.norm(pred_u - cam_u.K[:2, 2], axis=1), 0.0)
    k = int(np.argmax(radius))
    assert radius[k] > 250  # a dot near an image corner
    assert np.linalg.norm(found_d[k] - found_u[k]) > 5.0


def test_plane_behind_camera_or_seen_edge_on_is_black():
    camera = model_station_camera()
    plane = uniform_plane(rng=0)
    behind = make_transform(np.eye(3), [0, 0, -MODEL_DISTANCE_MM])
    assert not render_view(camera, behind, plane).any()
    edge_on = make_transform([[1, 0, 0], [0, 0, -1], [0, 1, 0]], [0, 0, MODEL_DISTANCE_MM])
    image = render_view(camera, edge_on, plane)
    assert not image[:200].any() and not image[-200:].any()


def _flat(colour: tuple[int, int, int], size_px: int = 100) -> PlaneTexture:
    image = np.empty((size_px, size_px, 3), np.uint8)
    image[:] = colour
    return PlaneTexture(image, np.ones((size_px, size_px), np.float32), 1.0,
                        np.array([(size_px - 1) / 2] * 2))


def test_later_items_are_drawn_on_top_and_alpha_blends():
    camera = model_station_camera()
    T = make_transform(np.eye(3), [0, 0, MODEL_DISTANCE_MM])
    red, blue = _flat((0, 0, 255)), _flat((255, 0, 0))
    half = PlaneTexture(blue.image_bgr, np.full((100, 100), 0.5, np.float32), 1.0,
                        blue.origin_px)
    centre = np.rint(camera.project([0, 0, MODEL_DISTANCE_MM])).astype(int)
    at = (centre[1], centre[0])
    placed = np.eye(4)
    assert tuple(render_view(camera, T, _table(), [(placed, red), (placed, blue)])[at]) == (
        255, 0, 0)
    assert tuple(render_view(camera, T, _table(), [(placed, blue), (placed, red)])[at]) == (
        0, 0, 255)
    assert tuple(render_view(camera, T, _table(), [(placed, red), (placed, half)])[at]) == (
        128, 0, 128)


def test_items_may_be_lifted_and_must_be_rigid():
    camera = model_station_camera()
    T = make_transform(np.eye(3), [0, 0, MODEL_DISTANCE_MM])
    # A square 40 mm wide lifted 100 mm towards the camera looks 400/300 times as wide.
    square = PlaneTexture(np.full((80, 80, 3), 255, np.uint8), np.ones((80, 80), np.float32),
                          0.5, np.array([39.5, 39.5]))
    flat = render_view(camera, T, _table(), [(np.eye(4), square)])
    lifted = render_view(camera, T, _table(),
                         [(make_transform(np.eye(3), [0, 0, -100.0]), square)])
    width_flat = (flat[240, :, 2] > 200).sum()
    width_lifted = (lifted[240, :, 2] > 200).sum()
    assert width_lifted / width_flat == pytest.approx(400 / 300, rel=0.03)
    sheared = np.eye(4)
    sheared[0, 1] = 0.3
    with pytest.raises(ValueError, match="items\\[0\\]"):
        render_view(camera, T, _table(), [(sheared, _flat((0, 0, 255)))])
    with pytest.raises(ValueError, match="T_cam_plane"):
        render_view(camera, np.eye(3), _table())


def test_pixel_rays_are_cached_read_only_and_inverse_of_projection():
    camera = model_station_camera()
    rays = pixel_rays(camera, 2)
    assert rays is pixel_rays(camera, 2)
    assert rays.shape == (960, 1280, 2) and not rays.flags.writeable
    uv = camera.project(np.concatenate([rays[::97, ::89], np.ones(rays[::97, ::89].shape[:2]
                                                                  + (1,))], axis=-1))
    expected = np.stack(np.meshgrid((np.arange(0, 1280, 89) + 0.5) / 2 - 0.5,
                                    (np.arange(0, 960, 97) + 0.5) / 2 - 0.5), axis=-1)
    np.testing.assert_allclose(uv, expected, atol=1e-9)


def test_noise_and_blur():
    image = np.full((50, 60, 3), 100, np.uint8)
    noisy = add_sensor_noise(image, 2.0, 5)
    assert noisy.dtype == np.uint8 and 1.8 < noisy.astype(float).std() < 2.2
    np.testing.assert_array_equal(noisy, add_sensor_noise(image, 2.0, 5))
    assert not np.array_equal(noisy, add_sensor_noise(image, 2.0, 6))
    assert add_sensor_noise(np.full((4, 4, 3), 255, np.uint8), 50.0, 0).max() <= 255
    smooth = blur(noisy, 1.5)
    assert smooth.shape == image.shape and smooth.astype(float).std() < 1.0
