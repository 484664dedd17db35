"""The simulator's truth is exact: known points of a garment are found where the truth says.

A garment printed with Gaussian dots on a 40 mm grid is rendered by :func:`simulate_scene`
without noise, blur or vignetting; every dot's centre (its 3D point: on the plane, or on the
wrinkled surface ``Wrinkles.surface_mm``) is projected with ``T_cam1_model`` and the calibration
into both cameras and compared with the dot found in the image. The same holds for the files of
a written dataset (``stereo.yaml``, ``truth.json``, the PNGs; projected here with OpenCV) and for
the model station (``model_camera.yaml``, ``photo.bmp``).

Wrinkled cloth is shaded (Lambertian, folds 4-9 mm wide), which biases a plain centroid by up to
a few pixels; so there the dot is flat-fielded by a render of the same scene with an undotted
card (shading cancels), and compared both with the projected centre and with the centroid the
dot must have once the surface's curvature and foreshortening are integrated in.
"""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
import pytest
from numpy.typing import NDArray
from sim_helpers import (
    blank_texture,
    dot_card,
    dot_centroid,
    flat_field_dot_centroid,
    plane_fit_dot_centroid,
    scaled_texture,
    surface_dot_centroid,
)

from photomodel.camera import PinholeCamera, StereoRig, load_camera, load_distance_mm, load_stereo
from photomodel.geometry import transform_points
from photomodel.sim import (
    Garment,
    hand_stereo_rig,
    parse_conditions,
    simulate_scene,
    write_dataset,
)

CARD_MM = (240.0, 180.0)  # 6 x 4 dots, small enough for every placement in the paper's range
MODEL_OFFSET_MM = (6.0, -4.0)  # render_model_photos' default: garment origin on the plane


def _dot_garment(gain: float = 1.0) -> tuple[Garment, Garment, NDArray[np.float64]]:
    """A dotted card as a garment (colours times ``gain``), the same card without dots, centres.

    The dotless twin has the same silhouette and size, so a scene drawn from the same seed has
    the same placement, folds and light.
    """
    card, centres = dot_card(CARD_MM, 0.5)
    dotted = scaled_texture(card, gain) if gain != 1.0 else card
    blank = blank_texture(card, round(255 * gain))
    return Garment("dots", dotted, CARD_MM), Garment("dots", blank, CARD_MM), centres


def _views(rig: StereoRig) -> list[tuple[PinholeCamera, NDArray[np.float64]]]:
    return [(rig.cam1, np.eye(4)), (rig.cam2, rig.T_cam2_cam1)]


def _errors(found: list[NDArray[np.float64] | None],
            expected: NDArray[np.float64]) -> NDArray[np.float64]:
    """Distances (N,) between found and expected pixels; NaN where nothing was found."""
    return np.array([np.nan if f is None else float(np.linalg.norm(f - e))
                     for f, e in zip(found, expected, strict=True)])


def _summary(err: NDArray[np.float64]) -> str:
    return (f"n={np.isfinite(err).sum()} median={np.nanmedian(err):.4f} "
            f"p95={np.nanpercentile(err, 95):.4f} max={np.nanmax(err):.4f} px")


@pytest.mark.parametrize("spec", ["clean", "clean+no-distortion", "clean+wide-lens",
                                  "clean+tilt"])
def test_flat_dots_are_where_the_truth_projects_them(spec: str) -> None:
    conditions = parse_conditions(spec)
    rig = hand_stereo_rig(lens=conditions.lens)
    garment, _, centres = _dot_garment()
    scene = simulate_scene(garment, rig, conditions, 3)
    assert scene.wrinkles is None and scene.T_cam1_model is not None
    if spec == "clean+tilt":
        assert scene.info["tilt_deg"] > 1.0  # the truth must carry the tilt
    points = np.column_stack([centres, np.zeros(len(centres))])
    err = []
    for (camera, T_cam_cam1), image in zip(_views(rig), (scene.right_bgr, scene.left_bgr),
                                           strict=True):
        uv = camera.project(transform_points(T_cam_cam1 @ scene.T_cam1_model, points))
        err.append(_errors([dot_centroid(image, p) for p in uv], uv))
    err = np.concatenate(err)
    assert np.isfinite(err).sum() == 2 * len(centres), _summary(err)
    # Measured: median about 0.003 px, max about 0.009 px in every case.
    assert np.nanmedian(err) < 0.02 and np.nanmax(err) < 0.05, _summary(err)


@pytest.mark.parametrize("spec", ["clean+wrinkles", "clean+no-distortion+wrinkles",
                                  "clean+wide-lens+wrinkles"])
def test_wrinkled_dots_are_where_the_truth_projects_them(spec: str) -> None:
    conditions = parse_conditions(spec)
    rig = hand_stereo_rig(lens=conditions.lens)
    # A light-grey card: lit folds (shading up to about 1.15) stay below 255, unclipped.
    garment, blank, centres = _dot_garment(gain=0.8)
    scene = simulate_scene(garment, rig, conditions, 3)
    plain = simulate_scene(blank, rig, conditions, 3)
    assert scene.wrinkles is not None and scene.wrinkles == plain.wrinkles
    assert np.array_equal(scene.T_cam1_model, plain.T_cam1_model)
    assert scene.info["wrinkle_height_mm"] == 8.0
    surface = scene.wrinkles.surface_mm(centres)
    assert np.ptp(surface[:, 2]) > 2.0  # the dots really lie at different heights
    to_centre, to_surface = [], []
    for (camera, T_cam_cam1), image, white in zip(
            _views(rig), (scene.right_bgr, scene.left_bgr), (plain.right_bgr, plain.left_bgr),
            strict=True):
        T_cam_model = T_cam_cam1 @ scene.T_cam1_model

        def to_image(material: NDArray[np.float64], T: NDArray[np.float64] = T_cam_model,
                     cam: PinholeCamera = camera) -> NDArray[np.float64]:
            return cam.project(transform_points(T, scene.wrinkles.surface_mm(material)))

        uv = to_image(centres)
        found = [flat_field_dot_centroid(image, white, p) for p in uv]
        to_centre.append(_errors(found, uv))
        to_surface.append(_errors(found, np.array([surface_dot_centroid(to_image, c)
                                                   for c in centres])))
    centre_err, surface_err = np.concatenate(to_centre), np.concatenate(to_surface)
    assert np.isfinite(centre_err).sum() == 2 * len(centres), _summary(centre_err)
    # The dot is found where the truth puts its centre, to a fraction of a pixel; dots on the
    # flanks of narrow folds are skewed by the curvature (measured: median 0.02, p95 0.19,
    # max 0.28 px) ...
    assert np.nanmedian(centre_err) < 0.05, _summary(centre_err)
    assert np.nanpercentile(centre_err, 95) < 0.35, _summary(centre_err)
    assert np.nanmax(centre_err) < 0.5, _summary(centre_err)
    # ... and exactly where the dot integrated over the true surface lands (measured: median
    # 0.009, max 0.03 px).
    assert np.nanmedian(surface_err) < 0.03, _summary(surface_err)
    assert np.nanmax(surface_err) < 0.08, _summary(surface_err)


def test_shading_of_wrinkles_is_what_the_flat_field_removes() -> None:
    """Without the flat field the shading of folds moves dots by pixels: it is really there."""
    conditions = parse_conditions("clean+wrinkles")
    rig = hand_stereo_rig()
    garment, _, centres = _dot_garment(gain=0.8)
    scene = simulate_scene(garment, rig, conditions, 3)
    assert scene.wrinkles is not None and scene.T_cam1_model is not None
    uv = rig.cam1.project(transform_points(scene.T_cam1_model,
                                           scene.wrinkles.surface_mm(centres)))
    err = _errors([plane_fit_dot_centroid(scene.right_bgr, p) for p in uv], uv)
    assert np.nanmax(err) > 0.5, _summary(err)  # measured: 1-2.7 px on the worst dot


# --- through the files of a dataset ----------------------------------------------------------


@pytest.fixture(scope="module")
def dot_dataset(tmp_path_factory: pytest.TempPathFactory) -> Path:
    garment, _, _ = _dot_garment()
    out = tmp_path_factory.mktemp("truth") / "dots_dataset"
    summary = write_dataset(out, garments=[], conditions=["clean"], scenes=1, seed=5,
                            extra_garments={"dots": garment})
    assert summary.scenes == ("clean_dots_0000",) and summary.models == ("dots",)
    return out


def test_written_calibration_and_truth_explain_the_written_images(dot_dataset: Path) -> None:
    _, _, centres = _dot_garment()
    rig = load_stereo(dot_dataset / "stereo.yaml")
    truth = json.loads((dot_dataset / "truth.json").read_text())["clean_dots_0000"]
    assert truth["model"] == "dots"
    T_cam1_model = np.array(truth["T_cam1_model"])
    points = np.column_stack([centres, np.zeros(len(centres))])
    err = []
    for (camera, T_cam_cam1), name in zip(_views(rig), ("right.png", "left.png"), strict=True):
        image = cv2.imread(str(dot_dataset / "scenes" / "clean_dots_0000" / name))
        assert image is not None and image.shape == (camera.height_px, camera.width_px, 3)
        T = T_cam_cam1 @ T_cam1_model
        # Projected with OpenCV itself: the file's K, D, R, T mean what OpenCV means by them.
        uv, _ = cv2.projectPoints(points, cv2.Rodrigues(T[:3, :3])[0], T[:3, 3], camera.K,
                                  camera.dist)
        uv = uv.reshape(-1, 2)
        err.append(_errors([dot_centroid(image, p) for p in uv], uv))
    err = np.concatenate(err)
    assert np.isfinite(err).sum() == 2 * len(centres), _summary(err)
    assert np.nanmedian(err) < 0.02 and np.nanmax(err) < 0.05, _summary(err)


def test_written_model_photo_puts_material_points_at_400_mm(dot_dataset: Path) -> None:
    _, _, centres = _dot_garment()
    path = dot_dataset / "model_camera.yaml"
    camera = load_camera(path)
    assert load_distance_mm(path) == 400.0
    photo = cv2.imread(str(dot_dataset / "models" / "dots" / "photo.bmp"))
    assert photo is not None and photo.shape == (camera.height_px, camera.width_px, 3)
    # Material point m lies on the plane at m + offset, 400 mm in front of the camera.
    points = np.column_stack([centres + MODEL_OFFSET_MM, np.full(len(centres), 400.0)])
    uv = camera.project(points)
    err = _errors([plane_fit_dot_centroid(photo, p) for p in uv], uv)
    assert np.isfinite(err).sum() == len(centres), _summary(err)
    # The photo has sensor noise (1.5 grey levels) and blur: measured median 0.012, max 0.023 px.
    assert np.nanmedian(err) < 0.04 and np.nanmax(err) < 0.1, _summary(err)
