"""``photomodel calibrate stereo|camera`` on rendered views with exact truth, and its errors.

Accuracy targets (issue 42): focal lengths within 0.2 %, principal points within 1 px,
baseline within 0.2 mm, stereo rotation within 0.05 deg.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import cv2
import numpy as np
import pytest
from calib_helpers import CHARUCO_PATTERN, STATION_DISTANCE_MM, StationData, StereoData
from scipy.spatial.transform import Rotation

from photomodel.calibrate import distortion_difference_px
from photomodel.camera import PinholeCamera, load_camera, load_distance_mm, load_stereo
from photomodel.cli import main


def _run(capsys: pytest.CaptureFixture[str], argv: list[str]) -> tuple[int, str, str]:
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def _check_camera(est: PinholeCamera, true: PinholeCamera, focal_rel: float = 0.002,
                  pp_px: float = 1.0) -> None:
    assert est.image_size == true.image_size
    np.testing.assert_allclose(np.diag(est.K)[:2], np.diag(true.K)[:2], rtol=focal_rel)
    np.testing.assert_allclose(est.K[:2, 2], true.K[:2, 2], atol=pp_px)


def test_stereo_calibration_recovers_the_rig(capsys, stereo_data: StereoData,
                                             tmp_path: Path) -> None:
    out = tmp_path / "cal" / "rig.yaml"
    code, stdout, err = _run(capsys, ["calibrate", "stereo", "--pairs", stereo_data.pairs,
                                      "--pattern", "chessboard:9x6:25", "--out", out, "--json"])
    assert code == 0, err
    result = json.loads(stdout)
    rig, true = load_stereo(out), stereo_data.rig
    _check_camera(rig.cam1, true.cam1)
    _check_camera(rig.cam2, true.cam2)
    assert abs(np.linalg.norm(rig.T) - np.linalg.norm(true.T)) < 0.2
    assert np.linalg.norm(rig.T - true.T) < 0.5
    assert np.degrees(Rotation.from_matrix(rig.R @ true.R.T).magnitude()) < 0.05
    # k3 fixed (the default): right over the whole image, the rim no view reaches included
    assert rig.cam1.dist.size == 5 and rig.cam1.dist[4] == 0.0
    assert distortion_difference_px(rig.cam1, true.cam1, 0.0) < 0.1
    assert distortion_difference_px(rig.cam2, true.cam2, 0.0) < 0.1
    # what it prints: RMS per camera and of the stereo fit, per view, nothing skipped
    assert result["rms_px"] < 0.1 and result["right"]["rms_px"] < 0.1
    assert len(result["pairs"]) == 15 and result["skipped"] == []
    assert 0.6 < result["right"]["coverage"] <= 1.0 and 0.6 < result["left"]["coverage"] <= 1.0
    assert result["baseline_mm"] == pytest.approx(np.linalg.norm(rig.T))
    np.testing.assert_allclose(result["K1"], rig.cam1.K)
    for picture in (result["coverage_png"], result["errors_png"]):
        image = cv2.imread(picture)
        assert image is not None and image.shape[0] > 200
    assert Path(result["coverage_png"]).name == "rig.coverage.png"


def test_stereo_calibration_with_a_charuco_board(capsys, charuco_data: StereoData,
                                                 tmp_path: Path) -> None:
    out = tmp_path / "rig.json"
    code, stdout, err = _run(capsys, ["calibrate", "stereo", "--pairs", charuco_data.pairs,
                                      "--pattern", CHARUCO_PATTERN, "--out", out, "--json"])
    assert code == 0, err
    result = json.loads(stdout)
    assert len(result["pairs"]) == 15 and result["rms_px"] < 0.1
    rig, true = load_stereo(out), charuco_data.rig
    _check_camera(rig.cam1, true.cam1)
    _check_camera(rig.cam2, true.cam2)
    assert abs(np.linalg.norm(rig.T) - np.linalg.norm(true.T)) < 0.2
    assert np.degrees(Rotation.from_matrix(rig.R @ true.R.T).magnitude()) < 0.05
    assert distortion_difference_px(rig.cam2, true.cam2, 0.0) < 0.1


def test_stereo_lists_and_skips_a_pair_without_the_board(capsys, stereo_data: StereoData,
                                                         tmp_path: Path) -> None:
    pairs = tmp_path / "pairs"
    for name in ("000", "001", "002", "003"):
        shutil.copytree(stereo_data.pairs / name, pairs / name)
    blank = np.full((480, 640, 3), 180, np.uint8)
    cv2.imwrite(str(pairs / "002" / "left.png"), blank)
    code, stdout, err = _run(capsys, ["calibrate", "stereo", "--pairs", pairs, "--pattern",
                                      "chessboard:9x6:25", "--out", tmp_path / "rig.yaml",
                                      "--fix-intrinsics"])
    assert code == 0, err
    assert "skipped 002: no 9x6 chessboard found in left" in stdout
    assert "stereo: 3 pairs" in stdout and "(intrinsics fixed)" in stdout
    assert "right (camera 1): 4 views" in stdout and "left (camera 2): 3 views" in stdout


def test_camera_calibration_and_plane_distance(capsys, station_data: StationData,
                                               tmp_path: Path) -> None:
    out = tmp_path / "station.yaml"
    code, stdout, err = _run(capsys, ["calibrate", "camera", "--images", station_data.images,
                                      "--plane", station_data.plane, "--pattern",
                                      "chessboard:9x6:25", "--out", out, "--json",
                                      "--distortion", "5"])
    assert code == 0, err
    result = json.loads(stdout)
    camera = load_camera(out)
    _check_camera(camera, station_data.camera)
    # k3 free: right where the views reach (it extrapolates the rim; see the stereo test)
    assert camera.dist.size == 5 and camera.dist[4] != 0.0
    assert distortion_difference_px(camera, station_data.camera, 0.1) < 0.1
    distance = load_distance_mm(out)
    assert distance == pytest.approx(STATION_DISTANCE_MM, abs=0.5)
    assert result["distance_mm"] == pytest.approx(distance)
    assert result["tilt_deg"] == pytest.approx(4.0, abs=0.1)
    assert len(result["views"]) == 12 and result["rms_px"] < 0.1
    assert (tmp_path / "station.coverage.png").is_file()
    assert (tmp_path / "station.errors.png").is_file()


# --- bad input: one line each, exit 2, nothing written ---------------------------------


def _bad(capsys, argv: list, out: Path) -> str:  # type: ignore[no-untyped-def]
    code, stdout, err = _run(capsys, argv)
    assert code == 2 and stdout == ""
    assert len(err.strip().splitlines()) == 1 and err.startswith("photomodel: error: ")
    assert not out.exists() and not list(out.parent.glob(f"{out.stem}.*.png"))
    return err.strip()


def _stereo_argv(pairs: Path, out: Path, pattern: str = "chessboard:9x6:25") -> list:
    return ["calibrate", "stereo", "--pairs", pairs, "--pattern", pattern, "--out", out]


def _copy_pairs(stereo_data: StereoData, folder: Path, names: list[str]) -> Path:
    for name in names:
        shutil.copytree(stereo_data.pairs / name, folder / name)
    return folder


def test_too_few_views(capsys, stereo_data: StereoData, tmp_path: Path) -> None:
    pairs = _copy_pairs(stereo_data, tmp_path / "pairs", ["000", "001"])
    out = tmp_path / "out" / "rig.yaml"
    err = _bad(capsys, _stereo_argv(pairs, out), out)
    assert "needs at least 3 right views in which the 9x6 chessboard is found; found in 2 " \
           "of 2" in err


def test_a_pair_without_the_board_leaves_too_few(capsys, stereo_data: StereoData,
                                                  tmp_path: Path) -> None:
    pairs = _copy_pairs(stereo_data, tmp_path / "pairs", ["000", "001", "002"])
    cv2.imwrite(str(pairs / "001" / "left.png"), np.full((480, 640, 3), 90, np.uint8))
    out = tmp_path / "rig.yaml"
    err = _bad(capsys, _stereo_argv(pairs, out), out)
    assert "found in 2 of 3: 001: no 9x6 chessboard found" in err


def test_a_wrong_pattern_size(capsys, stereo_data: StereoData, tmp_path: Path) -> None:
    pairs = _copy_pairs(stereo_data, tmp_path / "pairs", ["000", "001", "002"])
    out = tmp_path / "rig.yaml"
    err = _bad(capsys, _stereo_argv(pairs, out, "chessboard:10x7:25"), out)
    assert "no view shows a 10x7 chessboard (000 shows a 9x6 chessboard): check --pattern " \
           "(COLSxROWS counts inner corners, not squares)" in err


def test_a_board_never_found(capsys, station_data: StationData, tmp_path: Path) -> None:
    images = tmp_path / "views"
    images.mkdir()
    for k in range(4):
        cv2.imwrite(str(images / f"v{k}.png"), np.full((480, 640, 3), 60 * k, np.uint8))
    out = tmp_path / "cam.yaml"
    err = _bad(capsys, ["calibrate", "camera", "--images", images, "--plane", station_data.plane,
                        "--pattern", "chessboard:9x6:25", "--out", out], out)
    assert f"{images}: no view shows a 9x6 chessboard: check --pattern" in err


def test_views_of_different_sizes(capsys, stereo_data: StereoData, tmp_path: Path) -> None:
    pairs = _copy_pairs(stereo_data, tmp_path / "pairs", ["000", "001", "002"])
    left = pairs / "001" / "left.png"
    cv2.imwrite(str(left), cv2.resize(cv2.imread(str(left)), (800, 600)))
    out = tmp_path / "rig.yaml"
    err = _bad(capsys, _stereo_argv(pairs, out), out)
    assert f"{left}: is 800x600 px but" in err and "all views must" in err


def test_a_pair_folder_without_its_left_image(capsys, stereo_data: StereoData,
                                              tmp_path: Path) -> None:
    pairs = _copy_pairs(stereo_data, tmp_path / "pairs", ["000", "001", "002"])
    (pairs / "002" / "left.png").unlink()
    out = tmp_path / "rig.yaml"
    err = _bad(capsys, _stereo_argv(pairs, out), out)
    assert f"{pairs / '002'}: lacks left.png" in err


@pytest.mark.parametrize(("argv_tail", "message"), [
    (["--pattern", "chessboard:9x6"], "--pattern: expected chessboard:COLSxROWS:SQUARE_MM"),
    (["--pattern", "chessboard:9x6:25", "--out-suffix"], "unrecognized arguments"),
])
def test_malformed_options(capsys, tmp_path: Path, argv_tail: list[str], message: str) -> None:
    out = tmp_path / "rig.yaml"
    argv = ["calibrate", "stereo", "--pairs", tmp_path, "--out", out, *argv_tail]
    code, _, err = _run(capsys, argv) if "--out-suffix" not in argv_tail else (None, "", "")
    if code is None:
        with pytest.raises(SystemExit) as info:
            main([str(a) for a in argv])
        err = capsys.readouterr().err
        assert info.value.code == 2
    else:
        assert code == 2
    assert message in err and len(err.strip().splitlines()) == 1


def test_missing_folders_and_a_bad_output_name(capsys, tmp_path: Path) -> None:
    out = tmp_path / "rig.yaml"
    err = _bad(capsys, _stereo_argv(tmp_path / "nowhere", out), out)
    assert f"{tmp_path / 'nowhere'}: stereo pairs folder not found" in err
    bad_out = tmp_path / "rig.txt"
    err = _bad(capsys, _stereo_argv(tmp_path, bad_out), bad_out)
    assert "--out: unknown calibration format '.txt'; use .yaml, .xml or .json" in err
    err = _bad(capsys, _stereo_argv(tmp_path, out), out)
    assert "holds no pair folders" in err


def test_a_plane_view_without_the_board(capsys, station_data: StationData,
                                        tmp_path: Path) -> None:
    plane = tmp_path / "plane.png"
    cv2.imwrite(str(plane), np.full((480, 640, 3), 120, np.uint8))
    out = tmp_path / "station.yaml"
    err = _bad(capsys, ["calibrate", "camera", "--images", station_data.images, "--plane", plane,
                        "--pattern", "chessboard:9x6:25", "--out", out], out)
    assert f"{plane}: no 9x6 chessboard found: the plane view must show the whole board" in err


def test_help_loads_neither_numpy_nor_opencv() -> None:
    import subprocess
    import sys

    code = ("import sys\nfrom photomodel.cli import main\ntry:\n    main(sys.argv[1:])\n"
            "except SystemExit:\n    pass\n"
            "print('MODULES:', *(m for m in ('numpy', 'cv2', 'matplotlib') if m in sys.modules))")
    done = subprocess.run([sys.executable, "-c", code, "calibrate", "stereo", "--help"],
                          capture_output=True, text=True, timeout=60)
    assert done.stdout.strip().splitlines()[-1] == "MODULES:"
