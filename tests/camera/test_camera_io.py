"""Calibration files: OpenCV FileStorage (YAML, XML, JSON), ROS camera_info, and their errors."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from photomodel.camera import (
    PinholeCamera,
    StereoRig,
    load_camera,
    load_distance_mm,
    load_stereo,
    save_camera,
    save_stereo,
)
from photomodel.errors import InputError

FORMATS = ("yaml", "xml", "json")

K1 = np.array([[801.2, 0.0, 322.1], [0.0, 800.6, 238.4], [0.0, 0.0, 1.0]])
K2 = np.array([[798.4, 0.0, 317.6], [0.0, 798.9, 241.3], [0.0, 0.0, 1.0]])
D1 = np.array([-0.15, 0.06, 0.0011, -0.0008, 0.0123])
D2 = np.array([-0.145, 0.058, -0.0009, 0.0012, 0.001, 0.02, -0.003, 0.0004])
RVEC = np.array([0.013, -0.174, 0.004])
R = cv2.Rodrigues(RVEC)[0]
T = np.array([119.54, -0.31, 10.47])



def _camera() -> PinholeCamera:
    return PinholeCamera(K1, D1, 640, 480)


def _rig() -> StereoRig:
    return StereoRig(_camera(), PinholeCamera(K2, D2, 640, 480), R, T)


def _write(path: Path, **entries: object) -> Path:
    """Write entries with cv2.FileStorage directly (format from the suffix)."""
    fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_WRITE)
    for key, value in entries.items():
        fs.write(key, value)
    fs.release()
    return path


def _stereo_entries(**overrides: object) -> dict[str, object]:
    entries: dict[str, object] = {"image_width": 640, "image_height": 480, "K1": K1,
                                  "D1": D1.reshape(1, -1), "K2": K2, "D2": D2.reshape(1, -1),
                                  "R": R, "T": T.reshape(3, 1)}
    entries.update(overrides)
    return {k: v for k, v in entries.items() if v is not None}


def _assert_input_error(excinfo: pytest.ExceptionInfo[InputError], path: Path) -> str:
    message = str(excinfo.value)
    assert message.startswith(str(path)), message
    assert excinfo.value.source == str(path)
    assert "\n" not in message
    return message


# --- round trips ---------------------------------------------------------------------------


@pytest.mark.parametrize("fmt", FORMATS)
def test_camera_round_trip(tmp_path: Path, fmt: str) -> None:
    path = tmp_path / f"cam.{fmt}"
    camera = _camera()
    save_camera(path, camera, distance_mm=412.5)
    loaded = load_camera(path)
    np.testing.assert_array_equal(loaded.K, camera.K)
    np.testing.assert_array_equal(loaded.dist, camera.dist)
    assert loaded.image_size == (640, 480)
    assert load_distance_mm(path) == 412.5
    assert sorted(p.name for p in tmp_path.iterdir()) == [path.name]  # no temporary left


@pytest.mark.parametrize("fmt", FORMATS)
def test_camera_round_trip_without_size_or_distortion(tmp_path: Path, fmt: str) -> None:
    path = tmp_path / f"cam.{fmt}"
    save_camera(path, PinholeCamera(K2, np.zeros(4)))
    loaded = load_camera(path)
    np.testing.assert_array_equal(loaded.K, K2)
    assert loaded.image_size == (0, 0)
    assert not loaded.has_distortion
    assert load_distance_mm(path) is None


@pytest.mark.parametrize("fmt", FORMATS)
def test_stereo_round_trip(tmp_path: Path, fmt: str) -> None:
    path = tmp_path / f"stereo.{fmt}"
    rig = _rig()
    save_stereo(path, rig)
    loaded = load_stereo(path)
    for got, want in zip(loaded.cameras, rig.cameras, strict=True):
        np.testing.assert_array_equal(got.K, want.K)
        np.testing.assert_array_equal(got.dist, want.dist)
        assert got.image_size == (640, 480)
    np.testing.assert_allclose(loaded.R, rig.R, rtol=0, atol=1e-15)
    np.testing.assert_allclose(loaded.T, rig.T, rtol=0, atol=1e-12)


@pytest.mark.parametrize("fmt", FORMATS)
def test_stereo_with_m1_m2_keys_written_by_opencv(tmp_path: Path, fmt: str) -> None:
    entries = _stereo_entries(K1=None, K2=None, M1=K1, M2=K2)
    loaded = load_stereo(_write(tmp_path / f"stereo.{fmt}", **entries))
    np.testing.assert_array_equal(loaded.cam1.K, K1)
    np.testing.assert_array_equal(loaded.cam2.K, K2)
    np.testing.assert_array_equal(loaded.cam1.dist, D1)
    np.testing.assert_array_equal(loaded.cam2.dist, D2)
    np.testing.assert_allclose(loaded.R, R, atol=1e-15)
    np.testing.assert_allclose(loaded.T, T, atol=1e-12)


@pytest.mark.parametrize("fmt", FORMATS)
@pytest.mark.parametrize("shape", [(3, 1), (1, 3)])
def test_stereo_rotation_as_rodrigues_vector(tmp_path: Path, fmt: str,
                                             shape: tuple[int, int]) -> None:
    path = _write(tmp_path / f"stereo.{fmt}", **_stereo_entries(R=RVEC.reshape(shape)))
    loaded = load_stereo(path)
    np.testing.assert_allclose(loaded.R, R, rtol=0, atol=1e-12)
    assert not np.allclose(loaded.R, np.eye(3), atol=1e-3)


@pytest.mark.parametrize("fmt", FORMATS)
def test_single_camera_with_short_keys(tmp_path: Path, fmt: str) -> None:
    path = _write(tmp_path / f"cam.{fmt}", K=K2, D=D2.reshape(-1, 1))
    loaded = load_camera(path)
    np.testing.assert_array_equal(loaded.K, K2)
    np.testing.assert_array_equal(loaded.dist, D2)


def test_stereo_without_distortion_keys_has_none(tmp_path: Path) -> None:
    path = _write(tmp_path / "stereo.yaml", **_stereo_entries(D1=None, D2=None))
    loaded = load_stereo(path)
    assert not loaded.cam1.has_distortion and not loaded.cam2.has_distortion


def test_camera_matrix_as_plain_list(tmp_path: Path) -> None:
    path = tmp_path / "cam.yaml"
    path.write_text("%YAML:1.0\n---\ncamera_matrix: [700.0, 0, 320.5, 0, 705, 240.5, 0, 0, 1]\n"
                    "distortion_coefficients: [-0.1, 0.01, 0, 0, 0]\n")
    loaded = load_camera(path)
    np.testing.assert_array_equal(loaded.K, [[700.0, 0, 320.5], [0, 705, 240.5], [0, 0, 1]])
    np.testing.assert_array_equal(loaded.dist, [-0.1, 0.01, 0, 0, 0])


ROS_CAMERA_INFO = """\
image_width: 1280
image_height: 960
camera_name: hand_right
camera_matrix:
  rows: 3
  cols: 3
  data: [1101.25, 0, 645.5, 0, 1099.75, 481, 0, 0, 1]
distortion_model: plumb_bob
distortion_coefficients:
  rows: 1
  cols: 5
  data: [-0.2311, 0.0675, 0.00041, -0.00032, 0]
rectification_matrix:
  rows: 3
  cols: 3
  data: [1, 0, 0, 0, 1, 0, 0, 0, 1]
projection_matrix:
  rows: 3
  cols: 4
  data: [1050.5, 0, 640, 0, 0, 1050.5, 480, 0, 0, 0, 1, 0]
"""


def test_ros_camera_info(tmp_path: Path) -> None:
    path = tmp_path / "right.yaml"
    path.write_text(ROS_CAMERA_INFO)
    camera = load_camera(path)
    np.testing.assert_array_equal(camera.K, [[1101.25, 0, 645.5], [0, 1099.75, 481], [0, 0, 1]])
    np.testing.assert_array_equal(camera.dist, [-0.2311, 0.0675, 0.00041, -0.00032, 0])
    assert camera.image_size == (1280, 960)
    assert load_distance_mm(path) is None


def test_ros_camera_info_rational_polynomial(tmp_path: Path) -> None:
    text = ROS_CAMERA_INFO.replace("plumb_bob", "rational_polynomial").replace(
        "  cols: 5\n  data: [-0.2311, 0.0675, 0.00041, -0.00032, 0]",
        "  cols: 8\n  data: [-0.2311, 0.0675, 0.00041, -0.00032, 0, 0.01, -0.002, 0.0003]")
    path = tmp_path / "right.yaml"
    path.write_text(text)
    camera = load_camera(path)
    np.testing.assert_array_equal(camera.dist,
                                  [-0.2311, 0.0675, 0.00041, -0.00032, 0, 0.01, -0.002, 0.0003])


# --- distance_mm ---------------------------------------------------------------------------


@pytest.mark.parametrize("fmt", FORMATS)
def test_load_distance_mm_from_opencv_file(tmp_path: Path, fmt: str) -> None:
    path = _write(tmp_path / f"cam.{fmt}", camera_matrix=K1, distance_mm=400.0)
    assert load_distance_mm(path) == 400.0


def test_load_distance_mm_absent_is_none(tmp_path: Path) -> None:
    assert load_distance_mm(_write(tmp_path / "cam.yaml", camera_matrix=K1)) is None


@pytest.mark.parametrize("value", [0.0, -400.0])
def test_load_distance_mm_not_positive(tmp_path: Path, value: float) -> None:
    path = _write(tmp_path / "cam.yaml", camera_matrix=K1, distance_mm=value)
    with pytest.raises(InputError) as info:
        load_distance_mm(path)
    assert "distance_mm" in _assert_input_error(info, path)


def test_load_distance_mm_missing_file(tmp_path: Path) -> None:
    path = tmp_path / "nowhere.yaml"
    with pytest.raises(InputError) as info:
        load_distance_mm(path)
    _assert_input_error(info, path)


# --- errors --------------------------------------------------------------------------------


@pytest.mark.parametrize("loader", [load_camera, load_stereo], ids=["camera", "stereo"])
def test_missing_file(tmp_path: Path, loader) -> None:
    path = tmp_path / "missing" / "calib.yaml"
    with pytest.raises(InputError) as info:
        loader(path)
    assert "not found" in _assert_input_error(info, path)


def test_directory_instead_of_file(tmp_path: Path) -> None:
    with pytest.raises(InputError) as info:
        load_camera(tmp_path)
    _assert_input_error(info, tmp_path)


@pytest.mark.parametrize("fmt", FORMATS)
@pytest.mark.parametrize("loader", [load_camera, load_stereo], ids=["camera", "stereo"])
def test_garbage_bytes(tmp_path: Path, fmt: str, loader) -> None:
    path = tmp_path / f"calib.{fmt}"
    path.write_bytes(np.random.default_rng(0).integers(0, 256, 700, dtype=np.uint8).tobytes())
    with pytest.raises(InputError) as info:
        loader(path)
    _assert_input_error(info, path)


@pytest.mark.parametrize("fmt", FORMATS)
def test_empty_file(tmp_path: Path, fmt: str) -> None:
    path = tmp_path / f"calib.{fmt}"
    path.write_bytes(b"")
    with pytest.raises(InputError) as info:
        load_stereo(path)
    _assert_input_error(info, path)


def test_text_that_is_not_yaml(tmp_path: Path) -> None:
    path = tmp_path / "calib.yaml"
    path.write_text("This is a note about the calibration, not the calibration itself.\n")
    with pytest.raises(InputError) as info:
        load_camera(path)
    _assert_input_error(info, path)


@pytest.mark.parametrize("fmt", FORMATS)
def test_stereo_missing_K2_names_K2(tmp_path: Path, fmt: str) -> None:
    path = _write(tmp_path / f"stereo.{fmt}", **_stereo_entries(K2=None))
    with pytest.raises(InputError) as info:
        load_stereo(path)
    assert "K2" in _assert_input_error(info, path)


@pytest.mark.parametrize("key", ["K1", "R", "T"])
def test_stereo_missing_key_is_named(tmp_path: Path, key: str) -> None:
    path = _write(tmp_path / "stereo.yaml", **_stereo_entries(**{key: None}))
    with pytest.raises(InputError) as info:
        load_stereo(path)
    assert key in _assert_input_error(info, path)


def test_camera_without_camera_matrix(tmp_path: Path) -> None:
    path = _write(tmp_path / "cam.yaml", distortion_coefficients=D1.reshape(1, -1))
    with pytest.raises(InputError) as info:
        load_camera(path)
    assert "camera_matrix" in _assert_input_error(info, path)


@pytest.mark.parametrize("K", [np.eye(2), np.ones((3, 4)), np.ones((1, 8))],
                         ids=["2x2", "3x4", "8 values"])
def test_wrong_size_K(tmp_path: Path, K: np.ndarray) -> None:
    path = _write(tmp_path / "stereo.yaml", **_stereo_entries(K1=K))
    with pytest.raises(InputError) as info:
        load_stereo(path)
    assert "K1" in _assert_input_error(info, path)


def test_wrong_size_camera_matrix(tmp_path: Path) -> None:
    path = _write(tmp_path / "cam.xml", camera_matrix=np.eye(4))
    with pytest.raises(InputError) as info:
        load_camera(path)
    assert "camera_matrix" in _assert_input_error(info, path)


def test_invalid_K_values(tmp_path: Path) -> None:
    K = K1.copy()
    K[0, 0] = -K[0, 0]
    path = _write(tmp_path / "cam.yaml", camera_matrix=K)
    with pytest.raises(InputError) as info:
        load_camera(path)
    _assert_input_error(info, path)


def test_non_finite_K(tmp_path: Path) -> None:
    K = K1.copy()
    K[0, 2] = np.nan
    path = _write(tmp_path / "cam.yaml", camera_matrix=K)
    with pytest.raises(InputError) as info:
        load_camera(path)
    _assert_input_error(info, path)


def test_wrong_number_of_distortion_coefficients(tmp_path: Path) -> None:
    path = _write(tmp_path / "cam.yaml", camera_matrix=K1, distortion_coefficients=np.ones((1, 3)))
    with pytest.raises(InputError) as info:
        load_camera(path)
    assert "dist" in _assert_input_error(info, path)


@pytest.mark.parametrize(
    "R_bad",
    [np.diag([1.0, 1.0, -1.0]), 1.5 * np.eye(3), R + 0.05, np.ones((2, 2))],
    ids=["reflection", "scaled", "perturbed", "four values"],
)
def test_non_rotation_R(tmp_path: Path, R_bad: np.ndarray) -> None:
    path = _write(tmp_path / "stereo.yaml", **_stereo_entries(R=R_bad))
    with pytest.raises(InputError) as info:
        load_stereo(path)
    assert "R" in _assert_input_error(info, path).split(":", 1)[1]


def test_wrong_size_T(tmp_path: Path) -> None:
    path = _write(tmp_path / "stereo.yaml", **_stereo_entries(T=np.ones((2, 1))))
    with pytest.raises(InputError) as info:
        load_stereo(path)
    assert "T" in _assert_input_error(info, path).split(":", 1)[1]
