"""The command line on real files: one clear error line for every bad input, and the happy path.

The error rule (docs/contracts.md, "Command line", errors): a missing or unreadable file, a
calibration without the needed keys, images whose size does not match the calibration, a photo
with no garment in it give one line on stderr naming the file and the problem, a non-zero exit
code (2), no traceback, and nothing half-written.
"""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np
import pytest

from photomodel.camera import load_camera, save_camera, save_stereo
from photomodel.cli import main
from photomodel.geometry import in_plane_angle_rad
from photomodel.model import build_photo_model, save_model
from photomodel.sim import (
    MODEL_DISTANCE_MM,
    hand_stereo_rig,
    make_garment,
    model_station_camera,
    random_stereo_scene,
    render_model_photos,
)

LOCATE_KEYS = {"model", "found", "T_cam1_model", "position_mm", "quat_wxyz", "theta_deg",
               "fitness", "score", "seconds"}



@dataclass(frozen=True)
class CliData:
    """A valid set of input files, written once per module."""

    root: Path
    photo: Path
    background: Path
    camera: Path
    stereo: Path
    right: Path
    left: Path
    model: Path
    T_cam1_model: np.ndarray


@pytest.fixture(scope="module")
def data(tmp_path_factory: pytest.TempPathFactory) -> CliData:
    root = tmp_path_factory.mktemp("cli_data")
    garment = make_garment("tshirt", "plain", (150, 120), rng=1)
    camera = model_station_camera()
    photo, background = render_model_photos(garment, camera, rng=2)
    rig = hand_stereo_rig()
    scene = random_stereo_scene(garment, rig, rng=3)
    paths = {name: root / name for name in
             ("photo.bmp", "background.bmp", "model_camera.yaml", "stereo.yaml", "right.png",
              "left.png", "garment.npz")}
    save_camera(paths["model_camera.yaml"], camera, distance_mm=400)
    save_stereo(paths["stereo.yaml"], rig)
    for name, image in (("photo.bmp", photo), ("background.bmp", background),
                        ("right.png", scene.right_bgr), ("left.png", scene.left_bgr)):
        assert cv2.imwrite(str(paths[name]), image)
    built = build_photo_model(photo, background, camera, MODEL_DISTANCE_MM, name="garment")
    save_model(built.model, paths["garment.npz"])
    return CliData(root, paths["photo.bmp"], paths["background.bmp"],
                   paths["model_camera.yaml"], paths["stereo.yaml"], paths["right.png"],
                   paths["left.png"], paths["garment.npz"], scene.T_cam1_model)


def _run(capsys: pytest.CaptureFixture[str], argv: list[str]) -> tuple[int, str, str]:
    code = main([str(a) for a in argv])
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def _assert_clean_error(code: int, out: str, err: str, offending: Path, out_dir: Path) -> str:
    assert code == 2, err
    assert "Traceback" not in err
    lines = [line for line in err.splitlines() if line.strip()]
    assert len(lines) == 1, err
    assert len(err.strip().splitlines()) == 1, err
    line = lines[0]
    assert line.startswith("photomodel: error: "), line
    assert offending.name in line, line
    assert out == ""
    written = sorted(p.name for p in out_dir.rglob("*")) if out_dir.exists() else []
    assert written == [], f"half-written output: {written}"
    return line


def _random_bytes(path: Path, n: int = 4000, seed: int = 0) -> Path:
    path.write_bytes(np.random.default_rng(seed).integers(0, 256, n, dtype=np.uint8).tobytes())
    return path


# --- build ---------------------------------------------------------------------------------


def _build_argv(data: CliData, out_dir: Path, **files: Path) -> list[object]:
    photo = files.get("photo", data.photo)
    background = files.get("background", data.background)
    camera = files.get("camera", data.camera)
    return ["build", "--photo", photo, "--background", background, "--camera", camera,
            "--distance-mm", "400", "--out", out_dir / "model.npz"]


def _build_error(capsys: pytest.CaptureFixture[str], data: CliData, tmp_path: Path,
                 offending: Path, **files: Path) -> str:
    out_dir = tmp_path / "out"
    code, out, err = _run(capsys, _build_argv(data, out_dir, **files))
    return _assert_clean_error(code, out, err, offending, out_dir)


def test_build_missing_photo(capsys, data: CliData, tmp_path: Path) -> None:
    photo = tmp_path / "no_such_photo.bmp"
    line = _build_error(capsys, data, tmp_path, photo, photo=photo)
    assert "not found" in line


def test_build_corrupt_photo(capsys, data: CliData, tmp_path: Path) -> None:
    photo = _random_bytes(tmp_path / "corrupt_photo.bmp")
    _build_error(capsys, data, tmp_path, photo, photo=photo)


def test_build_truncated_photo(capsys, data: CliData, tmp_path: Path) -> None:
    photo = tmp_path / "truncated_photo.bmp"
    photo.write_bytes(data.photo.read_bytes()[:40])
    _build_error(capsys, data, tmp_path, photo, photo=photo)


def test_build_greyscale_photo(capsys, data: CliData, tmp_path: Path) -> None:
    photo = tmp_path / "grey_photo.bmp"
    grey = cv2.cvtColor(cv2.imread(str(data.photo)), cv2.COLOR_BGR2GRAY)
    assert cv2.imwrite(str(photo), grey)
    line = _build_error(capsys, data, tmp_path, photo, photo=photo)
    assert "grey" in line or "gray" in line or "colour" in line


def test_build_background_of_another_size(capsys, data: CliData, tmp_path: Path) -> None:
    background = tmp_path / "small_background.bmp"
    assert cv2.imwrite(str(background), cv2.resize(cv2.imread(str(data.background)), (320, 240)))
    _build_error(capsys, data, tmp_path, background, background=background)


def test_build_missing_camera_file(capsys, data: CliData, tmp_path: Path) -> None:
    camera = tmp_path / "no_such_camera.yaml"
    _build_error(capsys, data, tmp_path, camera, camera=camera)


def test_build_camera_file_without_camera_matrix(capsys, data: CliData, tmp_path: Path) -> None:
    camera = tmp_path / "no_matrix_camera.yaml"
    fs = cv2.FileStorage(str(camera), cv2.FILE_STORAGE_WRITE)
    fs.write("image_width", 640)
    fs.write("image_height", 480)
    fs.write("distortion_coefficients", np.zeros((1, 5)))
    fs.release()
    line = _build_error(capsys, data, tmp_path, camera, camera=camera)
    assert "camera_matrix" in line


@pytest.mark.parametrize("content", ["text", "binary"])
def test_build_camera_file_that_is_not_yaml(capsys, data: CliData, tmp_path: Path,
                                            content: str) -> None:
    camera = tmp_path / "not_yaml_camera.yaml"
    if content == "text":
        camera.write_text("Model station camera, calibrated on Monday by the night shift.\n")
    else:
        camera.write_bytes(data.photo.read_bytes()[:3000])
    _build_error(capsys, data, tmp_path, camera, camera=camera)


def test_build_photo_without_garment(capsys, data: CliData, tmp_path: Path) -> None:
    photo = tmp_path / "empty_plane_photo.bmp"
    shutil.copyfile(data.background, photo)
    line = _build_error(capsys, data, tmp_path, photo, photo=photo)
    assert "garment" in line


def test_build_photo_size_differs_from_camera(capsys, data: CliData, tmp_path: Path) -> None:
    photo, background = tmp_path / "big_photo.bmp", tmp_path / "big_background.bmp"
    for src, dst in ((data.photo, photo), (data.background, background)):
        assert cv2.imwrite(str(dst), cv2.resize(cv2.imread(str(src)), (800, 600)))
    assert load_camera(data.camera).image_size == (640, 480)
    line = _build_error(capsys, data, tmp_path, photo, photo=photo, background=background)
    assert "800x600" in line and "640x480" in line


def test_build_error_through_a_real_process(data: CliData, tmp_path: Path) -> None:
    """``python -m photomodel``: exit code non-zero, one line, no traceback."""
    photo = tmp_path / "vanished_photo.bmp"
    out_dir = tmp_path / "out"
    argv = [str(a) for a in _build_argv(data, out_dir, photo=photo)]
    proc = subprocess.run([sys.executable, "-m", "photomodel", *argv], capture_output=True,
                          text=True, timeout=300, check=False)
    assert proc.returncode != 0
    _assert_clean_error(proc.returncode, proc.stdout, proc.stderr, photo, out_dir)


def test_build_writes_model_and_one_line_summary(capsys, data: CliData, tmp_path: Path) -> None:
    out = tmp_path / "models" / "tshirt.npz"
    code, stdout, err = _run(capsys, ["build", "--photo", data.photo, "--background",
                                      data.background, "--camera", data.camera,
                                      "--distance-mm", "400", "--out", out, "--name", "tshirt"])
    assert code == 0, err
    assert len(stdout.strip().splitlines()) == 1
    assert "tshirt" in stdout
    assert out.is_file()
    names = sorted(p.name for p in out.parent.iterdir())
    assert not [n for n in names if n.startswith(".")], names  # no temporary left behind


def test_build_out_below_a_file(capsys, data: CliData, tmp_path: Path) -> None:
    blocker = tmp_path / "out"
    blocker.write_text("not a directory")
    code, out, err = _run(capsys, [*_build_argv(data, blocker)])
    assert code == 2, err
    assert "Traceback" not in err
    assert len(err.strip().splitlines()) == 1 and blocker.name in err


def test_build_out_is_a_directory(capsys, data: CliData, tmp_path: Path) -> None:
    out_dir = tmp_path / "out"
    (out_dir / "model.npz").mkdir(parents=True)
    code, out, err = _run(capsys, _build_argv(data, out_dir))
    assert code == 2, err
    assert len(err.strip().splitlines()) == 1 and "model.npz" in err
    assert sorted(p.name for p in out_dir.rglob("*")) == ["model.npz"]


# --- locate --------------------------------------------------------------------------------


def _locate_argv(data: CliData, **files: Path) -> list[object]:
    return ["locate", "--model", files.get("model", data.model),
            "--stereo", files.get("stereo", data.stereo),
            "--right", files.get("right", data.right), "--left", files.get("left", data.left),
            "--seed", "0"]


def _locate_error(capsys: pytest.CaptureFixture[str], data: CliData, tmp_path: Path,
                  offending: Path, **files: Path) -> str:
    out_dir = tmp_path / "out"
    argv = [*_locate_argv(data, **files), "--json", "--overlay", out_dir / "overlay.png"]
    code, out, err = _run(capsys, argv)
    return _assert_clean_error(code, out, err, offending, out_dir)


def test_locate_missing_model(capsys, data: CliData, tmp_path: Path) -> None:
    model = tmp_path / "no_such_model.npz"
    _locate_error(capsys, data, tmp_path, model, model=model)


def test_locate_npz_with_other_arrays(capsys, data: CliData, tmp_path: Path) -> None:
    model = tmp_path / "other_arrays.npz"
    np.savez(model, points=np.zeros((10, 3)), weights=np.ones(10))
    line = _locate_error(capsys, data, tmp_path, model, model=model)
    assert "photomodel" in line.split(model.name, 1)[1]


def test_locate_npz_of_another_format(capsys, data: CliData, tmp_path: Path) -> None:
    model = tmp_path / "foreign_meta.npz"
    np.savez(model, meta=np.array(json.dumps({"format": "something-else", "version": 1})),
             points_in_mm=np.zeros((3, 3)))
    _locate_error(capsys, data, tmp_path, model, model=model)


def test_locate_model_of_a_newer_version(capsys, data: CliData, tmp_path: Path) -> None:
    model = tmp_path / "future_model.npz"
    with np.load(data.model, allow_pickle=False) as z:
        arrays = {k: z[k] for k in z.files}
    meta = json.loads(str(arrays["meta"]))
    meta["version"] = 999
    arrays["meta"] = np.array(json.dumps(meta))
    np.savez(model, **arrays)
    line = _locate_error(capsys, data, tmp_path, model, model=model)
    assert "999" in line


@pytest.mark.parametrize("name", ["notes_model.txt", "text_model.npz"])
def test_locate_text_file_as_model(capsys, data: CliData, tmp_path: Path, name: str) -> None:
    model = tmp_path / name
    model.write_text("garment No. 3: red T-shirt, 150 x 120 mm\n")
    _locate_error(capsys, data, tmp_path, model, model=model)


def test_locate_truncated_model(capsys, data: CliData, tmp_path: Path) -> None:
    model = tmp_path / "truncated_model.npz"
    model.write_bytes(data.model.read_bytes()[:500])
    _locate_error(capsys, data, tmp_path, model, model=model)


@pytest.mark.parametrize("missing", ["T", "R", "K2"])
def test_locate_stereo_without_needed_key(capsys, data: CliData, tmp_path: Path,
                                          missing: str) -> None:
    rig = hand_stereo_rig()
    stereo = tmp_path / f"stereo_without_{missing}.yaml"
    entries = {"image_width": 640, "image_height": 480, "K1": rig.cam1.K, "D1": rig.cam1.dist,
               "K2": rig.cam2.K, "D2": rig.cam2.dist, "R": rig.R, "T": rig.T}
    del entries[missing]
    fs = cv2.FileStorage(str(stereo), cv2.FILE_STORAGE_WRITE)
    for key, value in entries.items():
        fs.write(key, value)
    fs.release()
    line = _locate_error(capsys, data, tmp_path, stereo, stereo=stereo)
    assert missing in line.split(stereo.name, 1)[1]


def test_locate_missing_stereo(capsys, data: CliData, tmp_path: Path) -> None:
    stereo = tmp_path / "no_such_stereo.yaml"
    _locate_error(capsys, data, tmp_path, stereo, stereo=stereo)


def test_locate_stereo_that_is_not_yaml(capsys, data: CliData, tmp_path: Path) -> None:
    stereo = _random_bytes(tmp_path / "garbage_stereo.yaml")
    _locate_error(capsys, data, tmp_path, stereo, stereo=stereo)


def test_locate_right_image_of_another_size(capsys, data: CliData, tmp_path: Path) -> None:
    right = tmp_path / "small_right.png"
    assert cv2.imwrite(str(right), cv2.resize(cv2.imread(str(data.right)), (320, 240)))
    line = _locate_error(capsys, data, tmp_path, right, right=right)
    assert "320x240" in line and "640x480" in line


def test_locate_left_image_of_another_size(capsys, data: CliData, tmp_path: Path) -> None:
    left = tmp_path / "cropped_left.png"
    assert cv2.imwrite(str(left), cv2.imread(str(data.left))[:400, :600])
    _locate_error(capsys, data, tmp_path, left, left=left)


def test_locate_missing_left_image(capsys, data: CliData, tmp_path: Path) -> None:
    left = tmp_path / "no_such_left.png"
    line = _locate_error(capsys, data, tmp_path, left, left=left)
    assert "not found" in line


def test_locate_corrupt_right_image(capsys, data: CliData, tmp_path: Path) -> None:
    right = _random_bytes(tmp_path / "corrupt_right.png", seed=1)
    _locate_error(capsys, data, tmp_path, right, right=right)


def test_locate_greyscale_right_image(capsys, data: CliData, tmp_path: Path) -> None:
    right = tmp_path / "grey_right.png"
    assert cv2.imwrite(str(right), cv2.imread(str(data.right), cv2.IMREAD_GRAYSCALE))
    _locate_error(capsys, data, tmp_path, right, right=right)


def test_locate_overlay_with_unknown_suffix(capsys, data: CliData, tmp_path: Path) -> None:
    out_dir = tmp_path / "out"
    overlay = out_dir / "overlay.xyz"
    code, out, err = _run(capsys, [*_locate_argv(data), "--json", "--overlay", overlay])
    _assert_clean_error(code, out, err, overlay, out_dir)


@pytest.mark.parametrize(("option", "value"), [("--tilt-deg", "120"), ("--theta-deg", "-5")])
def test_locate_search_space_out_of_range(capsys, data: CliData, tmp_path: Path, option: str,
                                          value: str) -> None:
    """The tilt is measured from the table of the stereo file's rig, so the ranges are checked
    once it is read: still one line, nothing written."""
    out_dir = tmp_path / "out"
    code, out, err = _run(capsys, [*_locate_argv(data), option, value, "--json",
                                   "--overlay", out_dir / "overlay.png"])
    assert code == 2 and out == "" and "Traceback" not in err
    assert len(err.strip().splitlines()) == 1
    assert err.startswith(f"photomodel: error: {option}: expected an angle from 0 to"), err
    assert not out_dir.exists()


# --- locate: the happy path ----------------------------------------------------------------


def test_build_then_locate_json(capsys, data: CliData, tmp_path: Path) -> None:
    model = tmp_path / "built" / "tshirt.npz"
    code, _, err = _run(capsys, ["build", "--photo", data.photo, "--background", data.background,
                                 "--camera", data.camera, "--distance-mm", "400", "--out", model,
                                 "--name", "tshirt"])
    assert code == 0, err
    code, out, err = _run(capsys, [*_locate_argv(data, model=model), "--json"])
    assert code == 0, err
    assert "Traceback" not in err
    assert len(out.strip().splitlines()) == 1, out
    result = json.loads(out)
    assert isinstance(result, dict)
    assert LOCATE_KEYS <= set(result), LOCATE_KEYS - set(result)

    assert result["model"] == "tshirt"
    assert isinstance(result["found"], bool)
    T = np.array(result["T_cam1_model"], dtype=np.float64)
    assert T.shape == (4, 4)
    np.testing.assert_allclose(T[3], [0.0, 0.0, 0.0, 1.0], atol=1e-12)
    np.testing.assert_allclose(T[:3, :3] @ T[:3, :3].T, np.eye(3), atol=1e-9)
    position = np.array(result["position_mm"], dtype=np.float64)
    assert position.shape == (3,)
    np.testing.assert_allclose(position, T[:3, 3], atol=1e-9)
    quat = np.array(result["quat_wxyz"], dtype=np.float64)
    assert quat.shape == (4,)
    assert np.linalg.norm(quat) == pytest.approx(1.0, abs=1e-9)
    w, x, y, z = quat  # the rotation of T in (w, x, y, z) order
    R_q = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                    [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                    [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])
    np.testing.assert_allclose(R_q, T[:3, :3], atol=1e-9)
    for key in ("theta_deg", "fitness", "score", "seconds"):
        assert isinstance(result[key], int | float) and not isinstance(result[key], bool), key
        assert np.isfinite(result[key]), key
    assert result["theta_deg"] == pytest.approx(np.rad2deg(in_plane_angle_rad(T)), abs=1e-6)
    assert 0.0 <= result["score"] <= 1.0
    assert result["seconds"] >= 0.0
    # Not an accuracy test, only a sanity check that the pose is the scene's garment.
    assert result["found"] is True
    assert np.linalg.norm(position - data.T_cam1_model[:3, 3]) < 30.0
    strain = np.array(result["strain"], dtype=np.float64)   # the fitted in-plane strain
    assert strain.shape == (3,) and np.all(np.abs(strain) < 0.1)


def test_locate_prints_the_pose_and_the_strain(capsys, data: CliData) -> None:
    code, out, err = _run(capsys, _locate_argv(data))
    assert code == 0, err
    lines = {line.split()[0]: line for line in out.strip().splitlines()}
    assert {"model", "position", "theta", "quat_wxyz", "strain", "search"} <= set(lines), out
    assert "found" in lines["model"] and lines["strain"].count("%") == 3


def test_locate_overlay_png(capsys, data: CliData, tmp_path: Path) -> None:
    overlay = tmp_path / "report" / "overlay.png"
    code, out, err = _run(capsys, [*_locate_argv(data), "--json", "--overlay", overlay])
    assert code == 0, err
    assert json.loads(out)["model"] == "garment"
    assert overlay.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    image = cv2.imread(str(overlay), cv2.IMREAD_UNCHANGED)
    assert image is not None and image.ndim == 3
    width = cv2.imread(str(data.right)).shape[1]
    assert 2 * width <= image.shape[1] <= 2 * width + 40
    assert image.shape[0] >= 480
    assert sorted(p.name for p in overlay.parent.iterdir()) == ["overlay.png"]


def test_locate_human_readable(capsys, data: CliData) -> None:
    code, out, err = _run(capsys, _locate_argv(data))
    assert code == 0, err
    assert "position" in out
    assert "garment" in out
    with pytest.raises(json.JSONDecodeError):
        json.loads(out)


# --- the file contract and the options of each method ----------------------------------------


@pytest.mark.parametrize("name", ["shirt.model", "shirt", "shirt.npz"])
def test_build_writes_exactly_the_given_path_and_locate_reads_it(
        capsys, data: CliData, tmp_path: Path, name: str) -> None:
    out = tmp_path / name
    code, stdout, err = _run(capsys, ["build", "--photo", data.photo, "--background",
                                      data.background, "--camera", data.camera, "--out", out])
    assert code == 0, err
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted([name, "shirt.preview.png"])
    assert "'shirt'" in stdout     # the name without .model / .npz
    code, stdout, err = _run(capsys, [*_locate_argv(data, model=out), "--json"])
    assert code == 0, err
    assert json.loads(stdout)["model"] == "shirt"


def test_build_out_naming_an_existing_directory_is_an_error(capsys, data: CliData,
                                                            tmp_path: Path) -> None:
    folder = tmp_path / "models"
    folder.mkdir()
    code, out, err = _run(capsys, ["build", "--photo", data.photo, "--background",
                                   data.background, "--camera", data.camera, "--out", folder])
    assert code == 2 and out == ""
    assert len(err.strip().splitlines()) == 1 and "is a directory" in err and "models" in err
    assert list(folder.iterdir()) == []


@pytest.mark.parametrize("option", [["--optimizer", "full"], ["--fitness", "balanced"],
                                    ["--generations", "5"], ["--refine"]])
def test_paper_options_with_the_default_method_are_refused(capsys, data: CliData,
                                                           option: list[str]) -> None:
    code, out, err = _run(capsys, [*_locate_argv(data), *option])
    assert code == 2 and out == ""
    assert err.strip() == f"photomodel: error: {option[0]}: applies to --method paper only"


@pytest.mark.parametrize("value", ["2", "-0.1", "nan"])
def test_a_min_score_outside_0_1_is_refused(capsys, data: CliData, value: str) -> None:
    code, out, err = _run(capsys, [*_locate_argv(data), "--min-score", value])
    assert code == 2 and "--min-score: expected a number from 0 to 1" in err


def test_the_paper_method_runs_with_its_options(capsys, data: CliData) -> None:
    code, out, err = _run(capsys, [*_locate_argv(data), "--method", "paper", "--generations",
                                   "3", "--json"])
    assert code == 0, err
    result = json.loads(out)
    assert result["generations"] <= 3 and 0.0 <= result["score"] <= 1.0


def _modules_after(argv: list[str]) -> set[str]:
    """The heavy modules a new process has loaded after ``photomodel ARGV`` returned."""
    code = ("import sys\nfrom photomodel.cli import main\n"
            "try:\n    main(sys.argv[1:])\nexcept SystemExit:\n    pass\n"
            "print('MODULES:', *(m for m in ('numba', 'scipy', 'matplotlib', 'cma', 'skimage', "
            "'numpy', 'cv2') if m in sys.modules))")
    done = subprocess.run([sys.executable, "-c", code, *argv], capture_output=True, text=True,
                          timeout=120)
    last = done.stdout.strip().splitlines()[-1]
    assert last.startswith("MODULES:"), done.stdout
    return set(last.split()[1:])


def test_help_and_error_paths_load_no_numba_scipy_or_matplotlib(data: CliData,
                                                                tmp_path: Path) -> None:
    assert _modules_after(["--help"]) == set()            # not even numpy or OpenCV
    assert _modules_after(["locate", "--help"]) == set()
    heavy = {"numba", "scipy", "matplotlib", "cma", "skimage"}
    missing = tmp_path / "missing.npz"
    assert not _modules_after([str(a) for a in _locate_argv(data, model=missing)]) & heavy
    assert _modules_after(["locate", "--model", str(data.model), "--bogus"]) == set()


@pytest.mark.parametrize("argv", [["frob"], ["locate", "--model", "m.npz"],
                                  ["locate", "--model", "m", "--stereo", "s", "--right", "r",
                                   "--left", "l", "--method", "fast"],
                                  ["simulate", "--out", "d", "--scenes", "many"]])
def test_an_option_error_is_one_line_naming_the_option(capsys, argv: list[str]) -> None:
    with pytest.raises(SystemExit) as stop:
        main(argv)
    err = capsys.readouterr().err
    assert stop.value.code == 2
    assert len(err.strip().splitlines()) == 1 and err.startswith("photomodel: error: "), err
    assert "Traceback" not in err and "usage:" not in err
