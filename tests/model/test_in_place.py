"""In-place registration (``photomodel.model.build_in_place``) on simulated stereo shots with
known truth: the table plane by stereo, the orthophoto's resolution, the model's frame on the
garment, the model located in other shots where its frame was carried with the garment, and
every refusal (with nothing written when it comes through the command line).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np
import pytest
from numpy.typing import NDArray

import photomodel as pm
from photomodel.camera import StereoRig, save_stereo
from photomodel.cli import main
from photomodel.errors import InputError, NoGarmentError
from photomodel.model import InPlaceBuild, build_in_place
from photomodel.model._in_place import TablePlane, orthophoto
from photomodel.sim import (
    SimulatedScene,
    catalogue_garment,
    hand_stereo_rig,
    parse_conditions,
    simulate_scene,
)

PLANE_TOL_MM = 1.0
PLANE_TOL_DEG = 1.0
POSE_TOL_MM = 2.0
POSE_TOL_DEG = 1.0
HAND_MM_PER_PX = 0.86
"""What the hand cameras resolve on the table (685 mm away)."""


@dataclass(frozen=True)
class Registered:
    """A registration shot (with its empty pair) and the models built from it."""

    garment: str
    shot: SimulatedScene
    with_empty: InPlaceBuild
    without_empty: InPlaceBuild


@dataclass(frozen=True)
class InPlaceData:
    rig: StereoRig
    cases: dict[str, Registered]


def _build(rig: StereoRig, shot: SimulatedScene, empty: bool, name: str) -> InPlaceBuild:
    """:func:`build_in_place` on ``shot``, with its empty pair or without; the warning that
    the table is no green plane silenced (the CLI and the service report it themselves)."""
    assert shot.empty_bgr is not None
    er, el = shot.empty_bgr if empty else (None, None)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return build_in_place(rig, shot.right_bgr, shot.left_bgr, empty_right_bgr=er,
                              empty_left_bgr=el, name=name)


@pytest.fixture(scope="module")
def data() -> InPlaceData:
    rig = hand_stereo_rig()
    cases = {}
    # No.5: red skirt with dots (texture to match); No.2: plain navy trousers (little texture)
    for name, seed, placement in (("No.5", 1, (40.0, -30.0, 0.0)),
                                  ("No.2", 2, (-30.0, 20.0, 0.0))):
        shot = simulate_scene(catalogue_garment(name), rig, parse_conditions("paper"), seed,
                              placement=placement, empty=True)
        assert shot.T_cam1_model is not None and shot.empty_bgr is not None
        cases[name] = Registered(name, shot, _build(rig, shot, True, name),
                                 _build(rig, shot, False, name))
    return InPlaceData(rig, cases)


def _builds(data: InPlaceData) -> list[tuple[str, Registered, InPlaceBuild]]:
    return [(f"{c.garment}-{kind}", c, b) for c in data.cases.values()
            for kind, b in (("empty", c.with_empty), ("colour", c.without_empty))]


def _angle_deg(a: NDArray[np.float64], b: NDArray[np.float64]) -> float:
    """The rotation angle between two rotations (3, 3), degrees."""
    c = (np.trace(a.T @ b) - 1.0) / 2.0
    return float(np.degrees(np.arccos(np.clip(c, -1.0, 1.0))))


def _true_silhouette_centroid(name: str, T_cam1_garment: NDArray[np.float64]
                              ) -> NDArray[np.float64]:
    """The garment's silhouette centroid in camera 1 (mm), from the simulator's texture."""
    texture = catalogue_garment(name).texture
    v, u = np.nonzero(texture.alpha > 0.5)
    xy = texture.mm_from_px(np.column_stack([u, v]).astype(np.float64)).mean(axis=0)
    return T_cam1_garment[:3, :3] @ np.array([xy[0], xy[1], 0.0]) + T_cam1_garment[:3, 3]


# --- the plane, the orthophoto, the model's frame ----------------------------------------


def test_plane_by_stereo_matches_the_table(data: InPlaceData) -> None:
    for label, case, made in _builds(data):
        T = case.shot.T_cam1_model
        assert T is not None
        normal = T[:3, 2]
        distance = float(normal @ T[:3, 3])
        plane = made.plane
        assert abs(plane.distance_mm - distance) < PLANE_TOL_MM, (label, plane, distance)
        tilt = np.degrees(np.arccos(min(1.0, float(plane.normal_cam1 @ normal))))
        assert tilt < PLANE_TOL_DEG, (label, tilt)
        assert np.linalg.norm(plane.normal_cam1) == pytest.approx(1.0)
        assert plane.points > 500 and plane.rms_mm < 2.0, (label, plane)


def test_orthophoto_resolution_is_the_hand_cameras(data: InPlaceData) -> None:
    for label, _, made in _builds(data):
        assert made.mm_per_px == pytest.approx(HAND_MM_PER_PX, abs=0.02), label
        meta = made.built.model.meta
        assert meta["in_place"]["mm_per_px"] == made.mm_per_px
        assert meta["in_place"]["empty_pair"] is label.endswith("-empty")
        np.testing.assert_allclose(meta["in_place"]["T_cam1_model"], made.T_cam1_model)
        h, w = made.orthophoto_bgr.shape[:2]
        assert made.orthophoto_bgr.dtype == np.uint8 and h > 300 and w > 400


def test_model_frame_lies_on_the_garment(data: InPlaceData) -> None:
    """z along the measured normal, origin on the plane at the silhouette's centroid."""
    for label, case, made in _builds(data):
        T = made.T_cam1_model
        R = T[:3, :3]
        np.testing.assert_allclose(R.T @ R, np.eye(3), atol=1e-9)
        assert np.linalg.det(R) == pytest.approx(1.0)
        np.testing.assert_allclose(R[:, 2], made.plane.normal_cam1, atol=1e-9)
        assert float(made.plane.normal_cam1 @ T[:3, 3]) == pytest.approx(
            made.plane.distance_mm, abs=1e-6)
        assert case.shot.T_cam1_model is not None
        truth = _true_silhouette_centroid(case.garment, case.shot.T_cam1_model)
        assert np.linalg.norm(T[:3, 3] - truth) < POSE_TOL_MM, (label, T[:3, 3], truth)


def test_orthophoto_maps_agree_with_the_plane() -> None:
    """Each orthophoto pixel's camera 1 pixel is the plane point the virtual camera sees there
    (an independent projection through camera 1's lens)."""
    rig = hand_stereo_rig()
    normal = np.array([0.08, -0.03, 1.0])
    normal /= np.linalg.norm(normal)
    plane = TablePlane(normal, 690.0, 0.0, 1000)
    ortho = orthophoto(rig.cam1, plane)
    f = float(np.sqrt(rig.cam1.K[0, 0] * rig.cam1.K[1, 1]))
    assert ortho.mm_per_px == pytest.approx(690.0 / f)
    K = ortho.camera.K
    gen = np.random.default_rng(0)
    h, w = ortho.maps[0].shape
    u, v = gen.integers(0, w, 50), gen.integers(0, h, 50)
    on_plane = np.column_stack([(u - K[0, 2]) * ortho.mm_per_px,
                                (v - K[1, 2]) * ortho.mm_per_px, np.full(50, 690.0)])
    X = on_plane @ ortho.R_cam1_virtual.T
    np.testing.assert_allclose(X @ normal, 690.0, atol=1e-6)
    uv = rig.cam1.project(X)
    np.testing.assert_allclose(np.column_stack([ortho.maps[0][v, u], ortho.maps[1][v, u]]), uv,
                               atol=1e-2)
    assert (uv >= 0).all() and (uv[:, 0] <= rig.cam1.width_px - 1).all()
    assert (uv[:, 1] <= rig.cam1.height_px - 1).all()


# --- the model located elsewhere -----------------------------------------------------------


@pytest.mark.parametrize("kind", ["empty", "colour"])
def test_model_is_located_where_the_garment_went(data: InPlaceData, kind: str) -> None:
    """The in-place model of No.5 in two other shots lies where its frame went with the
    garment: ``T_test @ inv(T_build) @ T_cam1_model``."""
    case = data.cases["No.5"]
    made = case.with_empty if kind == "empty" else case.without_empty
    T_build = case.shot.T_cam1_model
    assert T_build is not None
    carry = np.linalg.inv(T_build) @ made.T_cam1_model
    locate = pm.Locator(made.built.model, data.rig)
    for seed in (11, 12):
        test = simulate_scene(catalogue_garment("No.5"), data.rig, parse_conditions("paper"),
                              seed)
        assert test.T_cam1_model is not None
        result = locate(test.right_bgr, test.left_bgr, rng=0)
        truth = test.T_cam1_model @ carry
        assert result.found, (seed, result.score)
        error_mm = np.linalg.norm(result.T_cam1_model[:3, 3] - truth[:3, 3])
        assert error_mm < POSE_TOL_MM, (seed, error_mm)
        assert _angle_deg(result.T_cam1_model[:3, :3], truth[:3, :3]) < POSE_TOL_DEG, seed


# --- refusals ----------------------------------------------------------------------------------


def _cut(image: NDArray[np.uint8]) -> NDArray[np.uint8]:
    """The image rolled by half its width: the garment lies across the border."""
    return np.roll(image, image.shape[1] // 2, axis=1)


def test_views_of_another_size_are_refused(data: InPlaceData) -> None:
    shot = data.cases["No.5"].shot
    assert shot.empty_bgr is not None
    small = cv2.resize(shot.left_bgr, (320, 240))
    with pytest.raises(InputError, match=r"^left: .*320x240.*640x480"):
        build_in_place(data.rig, shot.right_bgr, small)
    with pytest.raises(InputError, match=r"^right: .*320x240"):
        build_in_place(data.rig, small, shot.left_bgr)
    with pytest.raises(InputError, match=r"^empty-left: .*320x240"):
        build_in_place(data.rig, shot.right_bgr, shot.left_bgr,
                       empty_right_bgr=shot.empty_bgr[0], empty_left_bgr=small)


def test_one_empty_view_alone_is_refused(data: InPlaceData) -> None:
    shot = data.cases["No.5"].shot
    assert shot.empty_bgr is not None
    with pytest.raises(InputError, match=r"^empty-left: give both views"):
        build_in_place(data.rig, shot.right_bgr, shot.left_bgr,
                       empty_right_bgr=shot.empty_bgr[0])
    with pytest.raises(InputError, match=r"^empty-right: give both views"):
        build_in_place(data.rig, shot.right_bgr, shot.left_bgr,
                       empty_left_bgr=shot.empty_bgr[1])


def test_no_garment_is_refused(data: InPlaceData) -> None:
    shot = data.cases["No.5"].shot
    with pytest.raises(NoGarmentError, match=r"is the garment in the empty pair too\?"):
        build_in_place(data.rig, shot.right_bgr, shot.left_bgr, empty_right_bgr=shot.right_bgr,
                       empty_left_bgr=shot.left_bgr)
    plain = np.full_like(shot.right_bgr, 128)
    with pytest.raises(NoGarmentError, match="the table's colour"):
        build_in_place(data.rig, plain, plain.copy())


@pytest.mark.parametrize("empty", [True, False])
def test_garment_cut_by_the_border_is_refused(data: InPlaceData, empty: bool) -> None:
    shot = data.cases["No.5"].shot
    assert shot.empty_bgr is not None
    er, el = (_cut(shot.empty_bgr[0]), _cut(shot.empty_bgr[1])) if empty else (None, None)
    with pytest.raises(InputError, match="cut by camera 1's image border"):
        build_in_place(data.rig, _cut(shot.right_bgr), _cut(shot.left_bgr),
                       empty_right_bgr=er, empty_left_bgr=el)


def test_failed_build_writes_nothing(data: InPlaceData, tmp_path: Path,
                                     capsys: pytest.CaptureFixture[str]) -> None:
    """Through ``photomodel build --stereo``: one line naming the file, exit 2, and the
    output folder stays empty."""
    shot = data.cases["No.5"].shot
    assert shot.empty_bgr is not None
    inputs = tmp_path / "in"
    inputs.mkdir()
    stereo = inputs / "stereo.yaml"
    save_stereo(stereo, data.rig)
    images = {"right": shot.right_bgr, "left": shot.left_bgr,
              "cut_right": _cut(shot.right_bgr), "cut_left": _cut(shot.left_bgr),
              "small": cv2.resize(shot.left_bgr, (320, 240))}
    for n, image in images.items():
        assert cv2.imwrite(str(inputs / f"{n}.png"), image)
    cases = {
        "small.png": ("right", "small", None, None),
        "empty_pair": ("right", "left", "right", "left"),
        "cut_right.png": ("cut_right", "cut_left", None, None),
    }
    out = tmp_path / "out"
    out.mkdir()
    for mention, (r, left, er, el) in cases.items():
        argv = ["build", "--stereo", str(stereo), "--right", str(inputs / f"{r}.png"),
                "--left", str(inputs / f"{left}.png"), "--out", str(out / "x.model")]
        if er is not None and el is not None:
            argv += ["--empty-right", str(inputs / f"{er}.png"),
                     "--empty-left", str(inputs / f"{el}.png")]
        code = main(argv)
        captured = capsys.readouterr()
        lines = [x for x in captured.err.splitlines() if x.strip()]
        assert code == 2, captured.err
        assert len(lines) == 1 and lines[0].startswith("photomodel: error: "), captured.err
        if mention == "empty_pair":
            assert "is the garment in the empty pair too?" in lines[0]
        else:
            assert mention in lines[0], lines[0]
        assert captured.out == ""
        assert sorted(p.name for p in out.iterdir()) == [], mention


def test_a_calibration_without_image_size_takes_the_views_size(data: InPlaceData) -> None:
    import dataclasses

    from photomodel.camera import PinholeCamera

    rig = data.rig
    no_size = dataclasses.replace(rig, cam1=PinholeCamera(rig.cam1.K, rig.cam1.dist),
                                  cam2=PinholeCamera(rig.cam2.K, rig.cam2.dist))
    case = data.cases["No.5"]
    made = _build(no_size, case.shot, False, "No.5")
    assert made.plane.distance_mm == pytest.approx(case.without_empty.plane.distance_mm,
                                                   abs=0.01)
    small = cv2.resize(case.shot.left_bgr, (320, 240))
    with pytest.raises(InputError, match=r"^left: size 320x240 differs"):
        build_in_place(no_size, case.shot.right_bgr, small)


def test_views_that_do_not_match_give_no_plane(data: InPlaceData) -> None:
    # camera 2's view of another place: stereo finds no table under the garment
    shot = data.cases["No.5"].shot
    other = np.roll(shot.left_bgr, shot.left_bgr.shape[1] // 2, axis=1)
    with pytest.raises((InputError, NoGarmentError), match=r"plane"):
        build_in_place(data.rig, shot.right_bgr, other)
