"""Objects other than the target: solid boxes show the faces a camera should see, lifted items
show the parallax of their height, and poses compose."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from numpy.typing import NDArray
from scipy.spatial.transform import Rotation
from sim_helpers import dot_card, dot_centroid

from photomodel.camera import PinholeCamera
from photomodel.geometry import invert_transform, make_transform, transform_points
from photomodel.sim import (
    OBJECT_KINDS,
    Layer,
    PlaneTexture,
    garment_placement,
    gripper,
    hand_table_pose,
    make_object,
    render_view_linear,
    uniform_plane,
)
from photomodel.sim._objects import place_layers

HEIGHT_MM = 685.0  # camera above the table


@pytest.fixture(scope="module")
def camera() -> PinholeCamera:
    """An undistorted camera looking straight down at the table (image x = table x)."""
    K = np.array([[800.0, 0.0, 319.5], [0.0, 800.0, 239.5], [0.0, 0.0, 1.0]])
    return PinholeCamera(K, np.zeros(5), 640, 480)


@pytest.fixture(scope="module")
def table() -> PlaneTexture:
    return uniform_plane((128, 128, 128), (1000.0, 800.0), 1.0, rng=0, noise=0.0)


T_CAM_TABLE = make_transform(np.eye(3), [0.0, 0.0, HEIGHT_MM])


def _box(seed: int = 2) -> tuple[list[Layer], Layer, float]:
    """A box's layers, its top and its height."""
    layers = make_object("box", seed)
    tops = [layer for layer in layers if not layer.cull_back]
    assert len(tops) == 1 and len(layers) == 5
    height = -float(tops[0].T_plane_item[2, 3])
    return layers, tops[0], height


def _render(camera: PinholeCamera, table: PlaneTexture, layers: list[Layer],
            track: int | None = None):
    return render_view_linear(camera, T_CAM_TABLE, table, layers, track=track)


def test_box_is_a_closed_solid() -> None:
    layers, top, height = _box()
    assert 40.0 <= height <= 90.0
    w, d = top.texture.size_mm
    sides = [layer for layer in layers if layer.cull_back]
    centres = np.array([layer.T_plane_item[:3, 3] for layer in sides])
    # Each side stands upright at the middle of an edge of the top, half the height up.
    np.testing.assert_allclose(centres[:, 2], -height / 2)
    np.testing.assert_allclose(sorted(np.abs(centres[:, :2]).max(axis=1)),
                               sorted([d / 2, d / 2, w / 2, w / 2]), atol=0.5)  # 1 mm texels
    for layer in sides:
        R = layer.T_plane_item[:3, :3]
        inward = R[:, 2]
        assert abs(inward[2]) < 1e-12  # vertical face
        # Its z points into the box (towards the box's axis), so -z faces outwards.
        assert float(inward[:2] @ layer.T_plane_item[:2, 3]) < 0
        np.testing.assert_allclose(layer.texture.size_mm[1], height, atol=1.0)


def test_box_seen_from_straight_above_shows_only_its_top(camera, table) -> None:
    layers, top, height = _box()
    full = _render(camera, table, layers, track=len(layers) - 1)
    only_top = _render(camera, table, [top])
    np.testing.assert_array_equal(full.image, only_top.image)  # every side culled
    # The top is seen at its height: its area scales with (f / (685 - h))^2.
    w, d = top.texture.size_mm
    expected = w * d * (800.0 / (HEIGHT_MM - height)) ** 2
    assert full.coverage.sum() == pytest.approx(expected, rel=0.02)
    on_table = _render(camera, table, [Layer(top.texture, np.eye(4))], track=0)
    assert on_table.coverage.sum() == pytest.approx(w * d * (800.0 / HEIGHT_MM) ** 2, rel=0.02)
    # And it shows the top's colours (the same mean as its texture: tape, label and all).
    inside = full.coverage > 0.999
    np.testing.assert_allclose(full.image[inside].mean(axis=0),
                               top.texture.image_bgr.reshape(-1, 3).mean(axis=0), atol=4.0)


def _side(layers: list[Layer], pick) -> Layer:
    sides = [layer for layer in layers if layer.cull_back]
    return pick(sides, key=lambda layer: layer.T_plane_item[0, 3])


def test_box_off_to_one_side_shows_its_near_face_and_culls_the_far_one(camera, table) -> None:
    x_mm = 250.0
    layers, top, height = _box()
    placed = place_layers(layers, garment_placement(x_mm, 0.0, 0.0))
    near, far = _side(placed, min), _side(placed, max)
    full = _render(camera, table, placed).image
    without_far = _render(camera, table, [layer for layer in placed if layer is not far]).image
    without_near = _render(camera, table, [layer for layer in placed if layer is not near]).image
    np.testing.assert_array_equal(full, without_far)
    changed = np.abs(full - without_near).max(axis=2) > 10.0
    rows, cols = np.nonzero(changed)
    assert len(cols) > 0
    # The near face fills the band between its foot and its top edge as the camera sees them.
    face_x = float(near.T_plane_item[0, 3])
    u_foot = 319.5 + 800.0 * face_x / HEIGHT_MM
    u_edge = 319.5 + 800.0 * face_x / (HEIGHT_MM - height)
    assert u_edge - u_foot > 5.0
    assert cols.min() >= np.floor(u_foot) - 1 and cols.max() <= np.ceil(u_edge) + 1
    length = near.texture.size_mm[0]
    band = (u_edge - u_foot) * length * 800.0 / (HEIGHT_MM - height / 2)
    assert 0.7 * band < changed.sum() < 1.1 * band
    # The face is darker than the top: it is lit at a grazing angle.
    top_view = _render(camera, table, place_layers([top], garment_placement(x_mm, 0.0, 0.0)),
                       track=0)
    assert full[changed].mean() < 0.9 * full[top_view.coverage > 0.999].mean()


def _triangulate(rig, uv1: NDArray[np.float64], uv2: NDArray[np.float64]) -> NDArray[np.float64]:
    """Points (N, 3) in camera 1's frame from undistorted pixel pairs, by OpenCV."""
    P1 = rig.cam1.K @ np.hstack([np.eye(3), np.zeros((3, 1))])
    P2 = rig.cam2.K @ np.hstack([rig.R, rig.T.reshape(3, 1)])
    X = cv2.triangulatePoints(P1, P2, uv1.T.astype(np.float64), uv2.T.astype(np.float64))
    return (X[:3] / X[3]).T


def _grid_dots(image: NDArray[np.uint8], rows: int, columns: int) -> NDArray[np.float64]:
    """Centroids (rows * columns, 2) of the dark dots of a card on a grey table, found without
    knowing where they are, in the card's row-major order (the card is roughly upright)."""
    dark = (image.max(axis=2) < 100).astype(np.uint8)  # the table is 128, the card 255
    _, _, stats, blobs = cv2.connectedComponentsWithStats(dark)
    blobs = blobs[1:][stats[1:, cv2.CC_STAT_AREA] >= 3]
    assert len(blobs) == rows * columns, len(blobs)
    blobs = blobs[np.argsort(blobs[:, 1])].reshape(rows, columns, 2)
    blobs = np.take_along_axis(blobs, np.argsort(blobs[..., 0], axis=1)[..., None], axis=1)
    return np.array([dot_centroid(image, b, 8) for b in blobs.reshape(-1, 2)])


@pytest.mark.parametrize("lift_mm", [0.0, 100.0])
def test_lifted_flat_item_shows_the_parallax_of_its_height(rig_undistorted, table,
                                                          lift_mm: float) -> None:
    rig = rig_undistorted
    card, centres = dot_card((120.0, 80.0), 0.5)
    T_table_card = make_transform(np.eye(3), [20.0, -10.0, -lift_mm])
    T_cam1_table = hand_table_pose(rig)
    found = []
    for cam, T_cam_cam1 in ((rig.cam1, np.eye(4)), (rig.cam2, rig.T_cam2_cam1)):
        view = render_view_linear(cam, T_cam_cam1 @ T_cam1_table, table,
                                  [Layer(card, T_table_card)])
        image = np.clip(np.rint(view.image), 0, 255).astype(np.uint8)
        found.append(_grid_dots(image, rows=2, columns=3))
    points_cam1 = _triangulate(rig, *found)
    points_table = transform_points(invert_transform(T_cam1_table), points_cam1)
    np.testing.assert_allclose(points_table[:, 2], -lift_mm, atol=0.3)
    np.testing.assert_allclose(points_table[:, :2], centres + [20.0, -10.0], atol=0.3)


def test_place_layers_composes_poses() -> None:
    layers = make_object("box", 5)
    originals = [layer.T_plane_item.copy() for layer in layers]
    A = make_transform(Rotation.from_rotvec([0.1, -0.2, 0.7]).as_matrix(), [10.0, -4.0, 3.0])
    B = garment_placement(-60.0, 25.0, 33.0)
    placed = place_layers(layers, A)
    assert len(placed) == len(layers)
    for old, new, T_old in zip(layers, placed, originals, strict=True):
        np.testing.assert_allclose(new.T_plane_item, A @ T_old)
        assert new.texture is old.texture and new.cull_back == old.cull_back
        assert new.wrinkles is old.wrinkles
        np.testing.assert_array_equal(old.T_plane_item, T_old)  # the input is not changed
    twice = place_layers(placed, B)
    for once, layer in zip(place_layers(layers, B @ A), twice, strict=True):
        np.testing.assert_allclose(layer.T_plane_item, once.T_plane_item, atol=1e-12)


def test_objects_are_seeded_and_sit_on_the_table() -> None:
    for kind in OBJECT_KINDS:
        a, b, c = make_object(kind, 3), make_object(kind, 3), make_object(kind, 4)
        assert [x.texture.image_bgr.tobytes() for x in a] == [
            x.texture.image_bgr.tobytes() for x in b]
        assert [x.texture.image_bgr.tobytes() for x in a] != [
            x.texture.image_bgr.tobytes() for x in c]
        for layer in a:  # nothing below the table (z into the table)
            texture = layer.texture
            w, h = texture.size_px
            corners = texture.mm_from_px([[-0.5, -0.5], [w - 0.5, -0.5], [-0.5, h - 0.5],
                                          [w - 0.5, h - 0.5]])
            z = transform_points(layer.T_plane_item,
                                 np.column_stack([corners, np.zeros(4)]))[:, 2]
            assert z.max() <= 1e-9
    (tape,) = make_object("tape", 0)
    assert -55.0 < tape.T_plane_item[2, 3] < -40.0  # a roll's top, about 50 mm up
    (tray,) = make_object("tray", 0)
    np.testing.assert_array_equal(tray.T_plane_item, np.eye(4))
    with pytest.raises(ValueError, match="kind"):
        make_object("chair", 0)


def test_gripper_fingers_straddle_its_origin() -> None:
    layers, finger_mm = gripper(3)
    assert 50.0 <= finger_mm <= 70.0 and len(layers) == 1
    texture = layers[0].texture

    def alpha_at(x_mm: float, y_mm: float) -> float:
        u, v = np.rint(texture.px_from_mm([x_mm, y_mm])).astype(int)
        return float(texture.alpha[v, u])

    assert alpha_at(-1.0, 0.0) == 0.0  # the gap between the fingertips
    assert alpha_at(-(finger_mm + 20.0), 0.0) == 1.0  # the palm
    assert alpha_at(-200.0, 0.0) == 1.0 and alpha_at(-200.0, 35.0) == 0.0  # the arm, 48 mm wide
    # Across the fingers, half-way along them: two 12 mm bars, mirror images about the axis.
    ys = np.arange(-80.0, 80.5, 0.5)
    inside = np.abs(ys) < texture.size_mm[1] / 2 - 1.0
    column = np.array([alpha_at(-finger_mm / 2, y) > 0.5 if ok else False
                       for y, ok in zip(ys, inside, strict=True)])
    starts = np.flatnonzero(np.diff(column.astype(int)) == 1) + 1
    ends = np.flatnonzero(np.diff(column.astype(int)) == -1)
    assert len(starts) == len(ends) == 2
    centres = (ys[starts] + ys[ends]) / 2
    widths = ys[ends] - ys[starts] + 0.5
    assert centres[0] == pytest.approx(-centres[1], abs=1.0) and centres[1] > 25.0
    np.testing.assert_allclose(widths, 12.0, atol=2.0)
