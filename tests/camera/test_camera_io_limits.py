"""The calibration loaders on files that are malformed or implausible (issue 40): each ends
in one InputError naming the file and the key, or reads with one InputWarning."""

from __future__ import annotations

import gzip
import warnings
from pathlib import Path

import numpy as np
import pytest

from photomodel.camera import _io as camera_io
from photomodel.camera import load_camera, load_distance_mm, load_stereo, save_stereo
from photomodel.cli import main
from photomodel.errors import InputError, InputWarning
from photomodel.sim import hand_stereo_rig

STEREO = """\
%YAML:1.0
---
image_width: 640
image_height: 480
K1: [801.2, 0, 322.1, 0, 800.6, 238.4, 0, 0, 1]
D1: [-0.15, 0.06, 0.0011, -0.0008, 0]
K2: [798.4, 0, 317.6, 0, 798.9, 241.3, 0, 0, 1]
D2: [-0.145, 0.058, -0.0009, 0.0012, 0]
R: [1, 0, 0, 0, 1, 0, 0, 0, 1]
T: [119.5, 0, 10.4]
"""

CAMERA = """\
%YAML:1.0
---
camera_matrix: [760, 0, 321.8, 0, 760, 237.8, 0, 0, 1]
distortion_coefficients: [-0.12, 0.08, 0.0005, -0.0004, 0]
distance_mm: 400
"""


def _file(tmp_path: Path, text: str, name: str = "calib.yaml") -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


def _stereo(tmp_path: Path, **lines: str) -> Path:
    """The plain stereo file with some keys' lines replaced (an empty value drops the key)."""
    out = []
    for line in STEREO.splitlines():
        key = line.split(":", 1)[0]
        if key in lines:
            if lines[key]:
                out.append(f"{key}: {lines[key]}")
        else:
            out.append(line)
    out += [f"{k}: {v}" for k, v in lines.items() if v and k not in STEREO]
    return _file(tmp_path, "\n".join(out) + "\n", "stereo.yaml")


def _refused(load, path: Path) -> str:
    with pytest.raises(InputError) as info:
        load(path)
    message = str(info.value)
    assert info.value.source == str(path) and message.startswith(str(path))
    assert "\n" not in message and len(message) < len(str(path)) + 160
    return message.split(": ", 1)[1]


def _warned(load, path: Path) -> tuple[object, str]:
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = load(path)
    assert [w.category for w in caught] == [InputWarning]
    message = str(caught[0].message)
    assert message.startswith(str(path)) and "\n" not in message
    return result, message


def _quiet(load, path: Path) -> object:
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        return load(path)


def test_the_plain_files_read_without_a_word(tmp_path: Path) -> None:
    rig = _quiet(load_stereo, _stereo(tmp_path))
    assert rig.cam1.image_size == (640, 480)
    np.testing.assert_array_equal(rig.T, [119.5, 0, 10.4])
    camera_path = _file(tmp_path, CAMERA)
    assert _quiet(load_camera, camera_path).K[0, 0] == 760
    assert _quiet(load_distance_mm, camera_path) == 400


# --- the file as a whole -------------------------------------------------------------------


@pytest.mark.parametrize("text", ["[1, 2, 3]", '[{"K1": [1, 2, 3]}]'])
@pytest.mark.parametrize("load", [load_stereo, load_camera, load_distance_mm])
def test_a_json_array_at_top_level(tmp_path: Path, text: str, load) -> None:
    assert "top level" in _refused(load, _file(tmp_path, text, "calib.json"))


def test_a_binary_file(tmp_path: Path) -> None:
    path = tmp_path / "calib.yaml"
    path.write_bytes(bytes(range(256)) * 4)
    assert "not a text file" in _refused(load_stereo, path)


def test_a_gzipped_file_is_not_unpacked(tmp_path: Path) -> None:
    path = tmp_path / "calib.yaml.gz"
    path.write_bytes(gzip.compress(STEREO.encode() + b"#" * 100_000))
    assert "not a text file" in _refused(load_stereo, path)


def test_a_file_larger_than_the_bound(tmp_path: Path, monkeypatch) -> None:
    monkeypatch.setattr(camera_io, "MAX_CALIBRATION_FILE_BYTES", 200)
    assert "larger than" in _refused(load_stereo, _stereo(tmp_path))


def test_a_parse_error_is_short_and_names_the_line(tmp_path: Path) -> None:
    text = "K1: " + "[" * 5000 + "]" * 5000 + "\n"
    problem = _refused(load_stereo, _file(tmp_path, text))
    assert "line 1" in problem and "[[[[[[" not in problem


# --- values of the wrong type --------------------------------------------------------------


@pytest.mark.parametrize("value", ['"abc"', "abc", "{a: 1}", "{rows: 3, cols: 3}",
                                   "[1, abc, 3, 4, 5, 6, 7, 8, 9]", "[1, [2, 3]]",
                                   "[[[1]], [[2]], [[3]]]"])
def test_K1_that_is_not_numbers(tmp_path: Path, value: str) -> None:
    assert "K1" in _refused(load_stereo, _stereo(tmp_path, K1=value))


def test_K1_string_in_json(tmp_path: Path) -> None:
    text = '{"K1": "abc", "K2": [1, 0, 0, 0, 1, 0, 0, 0, 1], "R": [0, 0, 0], "T": [1, 2, 3]}'
    assert "K1" in _refused(load_stereo, _file(tmp_path, text, "stereo.json"))


@pytest.mark.parametrize("value", ["abc", "[1, 2]", "{a: 1}", "-640", "640.5", "1e12"])
def test_image_width_that_is_not_a_pixel_count(tmp_path: Path, value: str) -> None:
    assert "image_width" in _refused(load_stereo, _stereo(tmp_path, image_width=value))


def test_width_without_height(tmp_path: Path) -> None:
    assert "image_height" in _refused(load_stereo, _stereo(tmp_path, image_height=""))


def test_a_matrix_map_without_data_or_with_wrong_rows(tmp_path: Path) -> None:
    assert "D1" in _refused(load_stereo, _stereo(tmp_path, D1="{a: 1}"))
    text = "{rows: 2, cols: 2, data: [1, 0, 0, 0, 1, 0, 0, 0, 1]}"
    assert "K1" in _refused(load_stereo, _stereo(tmp_path, K1=text))


@pytest.mark.parametrize("value", ["abc", "[400]", ".inf", "-.inf", ".nan", "0", "-400",
                                   "1e6"])
def test_distance_mm_that_is_not_a_distance(tmp_path: Path, value: str) -> None:
    path = _file(tmp_path, CAMERA.replace("distance_mm: 400", f"distance_mm: {value}"))
    assert "distance_mm" in _refused(load_distance_mm, path)


# --- nested lists --------------------------------------------------------------------------


def test_nested_lists_read_as_their_values(tmp_path: Path) -> None:
    path = _stereo(tmp_path, T="[[119.5], [0], [10.4]]",
                   K1="[[801.2, 0, 322.1], [0, 800.6, 238.4], [0, 0, 1]]")
    rig = _quiet(load_stereo, path)
    np.testing.assert_array_equal(rig.T, [119.5, 0, 10.4])
    assert rig.cam1.K[0, 0] == 801.2 and rig.cam1.K[1, 2] == 238.4


def test_a_ragged_nested_list(tmp_path: Path) -> None:
    assert "ragged" in _refused(load_stereo, _stereo(tmp_path, T="[[119.5, 0], [10.4]]"))


# --- implausible values --------------------------------------------------------------------


@pytest.mark.parametrize("focal", ["1e12", "1e6", "0.5", "20000"])
def test_focal_length_out_of_range(tmp_path: Path, focal: str) -> None:
    path = _stereo(tmp_path, K1=f"[{focal}, 0, 322.1, 0, {focal}, 238.4, 0, 0, 1]")
    assert "focal" in _refused(load_stereo, path)


def test_focal_length_beyond_the_image_bound_without_a_size(tmp_path: Path) -> None:
    path = _stereo(tmp_path, K1="[20000, 0, 322.1, 0, 20000, 238.4, 0, 0, 1]",
                   image_width="", image_height="")
    assert _quiet(load_stereo, path).cam1.K[0, 0] == 20000  # a plausible telephoto


@pytest.mark.parametrize("value", ["[-0.15, 0.06, 0.0011, -0.0008, .inf]",
                                   "[-0.15, 1e5, 0.0011, -0.0008, 0]", "[1, 2, 3]"])
def test_distortion_out_of_range(tmp_path: Path, value: str) -> None:
    assert "D1" in _refused(load_stereo, _stereo(tmp_path, D1=value))


def test_principal_point_outside_the_image_warns(tmp_path: Path) -> None:
    path = _stereo(tmp_path, K1="[801.2, 0, 900, 0, 800.6, 238.4, 0, 0, 1]")
    _, message = _warned(load_stereo, path)
    assert "principal point" in message and "K1" in message


@pytest.mark.parametrize("value", ["[1, 0, 0, 0, 1, 0, 0, 0, -1]", "[2, 0, 0, 0, 2, 0, 0, 0, 2]",
                                   "[1, 0, 0, 0, .nan, 0, 0, 0, 1]", "[.inf, 0, 0]"])
def test_R_that_is_not_a_rotation(tmp_path: Path, value: str) -> None:
    assert "R" in _refused(load_stereo, _stereo(tmp_path, R=value))


def test_R_with_six_digits_is_a_rotation(tmp_path: Path) -> None:
    R = np.round(hand_stereo_rig().R, 6)
    path = _stereo(tmp_path, R="[" + ", ".join(f"{v:.6f}" for v in R.ravel()) + "]")
    np.testing.assert_allclose(_quiet(load_stereo, path).R, R)


@pytest.mark.parametrize("value", ["[1e6, 0, 0]", "[.nan, 0, 0]", "[1, 2]"])
def test_T_refused(tmp_path: Path, value: str) -> None:
    assert "T" in _refused(load_stereo, _stereo(tmp_path, T=value))


def test_T_in_metres_warns(tmp_path: Path) -> None:
    rig, message = _warned(load_stereo, _stereo(tmp_path, T="[0.1195, 0, 0.0104]"))
    assert "metres" in message and "T" in message
    np.testing.assert_array_equal(rig.T, [0.1195, 0, 0.0104])  # read as given


def test_T_zero_warns(tmp_path: Path) -> None:
    _, message = _warned(load_stereo, _stereo(tmp_path, T="[0, 0, 0]"))
    assert "zero" in message


def test_distance_in_metres_warns(tmp_path: Path) -> None:
    path = _file(tmp_path, CAMERA.replace("distance_mm: 400", "distance_mm: 0.4"))
    distance, message = _warned(load_distance_mm, path)
    assert distance == 0.4 and "metres" in message


def test_negative_image_width_in_the_projects_own_file(tmp_path: Path) -> None:
    path = tmp_path / "stereo.yaml"
    save_stereo(path, hand_stereo_rig())
    path.write_text(path.read_text().replace("image_width: 640", "image_width: -640"))
    assert "image_width" in _refused(load_stereo, path)


# --- ROS -----------------------------------------------------------------------------------

CAMERA_INFO = """\
header:
  seq: 12
  stamp:
    secs: 1700000000
    nsecs: 0
  frame_id: hand_right
height: 960
width: 1280
distortion_model: "plumb_bob"
D: [-0.2311, 0.0675, 0.00041, -0.00032, 0.0]
K: [1101.25, 0.0, 645.5, 0.0, 1099.75, 481.0, 0.0, 0.0, 1.0]
R: [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]
P: [1050.5, 0.0, 640.0, 0.0, 0.0, 1050.5, 480.0, 0.0, 0.0, 0.0, 1.0, 0.0]
binning_x: 0
binning_y: 0
---
"""


def test_camera_info_message_reads_its_width_and_height(tmp_path: Path) -> None:
    camera = _quiet(load_camera, _file(tmp_path, CAMERA_INFO, "right.yaml"))
    assert camera.image_size == (1280, 960)
    assert camera.K[0, 0] == 1101.25 and camera.dist[0] == -0.2311


def test_ros2_lower_case_keys(tmp_path: Path) -> None:
    text = ("height: 480\nwidth: 640\nd: [-0.2, 0.06, 0.0, 0.0, 0.0]\n"
            "k: [800.0, 0.0, 320.0, 0.0, 800.0, 240.0, 0.0, 0.0, 1.0]\n")
    camera = _quiet(load_camera, _file(tmp_path, text))
    assert camera.image_size == (640, 480) and camera.dist[0] == -0.2


# --- the command line ----------------------------------------------------------------------


def test_the_cli_prints_a_warning_and_an_error_one_line_each(tmp_path: Path, capsys) -> None:
    camera = _file(tmp_path, CAMERA.replace("distance_mm: 400", "distance_mm: 0.4"))
    code = main(["build", "--photo", str(tmp_path / "photo.bmp"), "--background",
                 str(tmp_path / "background.bmp"), "--camera", str(camera), "--out",
                 str(tmp_path / "m.model")])
    err = capsys.readouterr().err.splitlines()
    assert code == 2
    assert len(err) == 2, err
    assert err[0].startswith(f"photomodel: warning: {camera}: distance_mm = 0.4")
    assert err[1].startswith("photomodel: error: ") and "photo.bmp" in err[1]


def test_a_focal_length_too_long_for_the_images_is_refused_before_the_search() -> None:
    """Without a calibrated size, the focal length is checked against the images themselves
    (a search's grids grow with f^2)."""
    from photomodel.camera import PinholeCamera

    K = np.array([[14000.0, 0, 320], [0, 14000.0, 240], [0, 0, 1]])
    camera = PinholeCamera(K=K, dist=np.zeros(5))            # no image size: accepted
    with pytest.raises(InputError, match=r"right\.png: the calibration's focal length 14000 px "
                                         r"is more than 20 x this 640x480"):
        camera.check_image(np.zeros((480, 640, 3), np.uint8), "right.png")
    camera.check_image(np.zeros((960, 1280, 3), np.uint8), "right.png")  # 14000 <= 20 x 1280


def test_input_warnings_print_as_one_line(capsys: pytest.CaptureFixture[str]) -> None:
    from photomodel.errors import one_line_input_warnings

    shown: list[object] = []
    show = one_line_input_warnings(lambda *a: shown.append(a))
    show(InputWarning("stereo.yaml", "T looks like metres"), InputWarning, "x.py", 1)
    show(UserWarning("other"), UserWarning, "x.py", 1)
    assert capsys.readouterr().err == "photomodel: warning: stereo.yaml: T looks like metres\n"
    assert len(shown) == 1                                    # other warnings go on as before
