"""``photomodel build``'s other modes on real files: in place from the hand cameras' stereo
pair (``--stereo --right --left [--empty-right --empty-left]``) and a photo of unknown scale
(``--scale unknown``); one error line (exit 2, nothing written) for every wrong mix of
options; ``photomodel locate`` of a model of unknown scale reports the scale it measured.
"""

from __future__ import annotations

from dataclasses import dataclass, fields
from pathlib import Path

import cv2
import pytest

from photomodel.camera import save_camera, save_stereo
from photomodel.cli import main
from photomodel.model import load_model, scale_known
from photomodel.sim import (
    catalogue_garment,
    hand_stereo_rig,
    model_station_camera,
    parse_conditions,
    render_model_photos,
    simulate_scene,
)

EXIT_INPUT_ERROR = 2


@dataclass(frozen=True)
class Files:
    """Input files of every mode, written once per module (read-only for the tests)."""

    root: Path
    stereo: Path
    camera: Path
    right: Path
    left: Path
    empty_right: Path
    empty_left: Path
    photo: Path
    background: Path
    scene_right: Path
    scene_left: Path


@pytest.fixture(scope="module")
def files(tmp_path_factory: pytest.TempPathFactory) -> Files:
    root = tmp_path_factory.mktemp("build_modes")
    rig = hand_stereo_rig()
    save_stereo(root / "stereo.yaml", rig)
    camera = model_station_camera()
    save_camera(root / "camera.yaml", camera, distance_mm=400)
    shot = simulate_scene(catalogue_garment("No.5"), rig, parse_conditions("paper"), 1,
                          placement=(40.0, -30.0, 0.0), empty=True)
    assert shot.empty_bgr is not None
    photo, background = render_model_photos(catalogue_garment("No.2"), camera, rng=3)
    scene = simulate_scene(catalogue_garment("No.2"), rig, parse_conditions("paper"), 21)
    images = {"right": shot.right_bgr, "left": shot.left_bgr,
              "empty_right": shot.empty_bgr[0], "empty_left": shot.empty_bgr[1],
              "photo": photo, "background": background,
              "scene_right": scene.right_bgr, "scene_left": scene.left_bgr}
    for name, image in images.items():
        assert cv2.imwrite(str(root / f"{name}.png"), image)
    return Files(root, root / "stereo.yaml", root / "camera.yaml",
                 *(root / f"{n}.png" for n in images))


def _run(capsys: pytest.CaptureFixture[str], argv: list[object]) -> tuple[int, str, str]:
    code = main([str(a) for a in argv])
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def _one_line(text: str) -> str:
    lines = [line for line in text.splitlines() if line.strip()]
    assert len(lines) == 1, text
    return lines[0]


# --- in place -------------------------------------------------------------------------------


@pytest.mark.parametrize("empty", [True, False], ids=["empty-pair", "table-colour"])
def test_in_place_writes_the_model_and_its_preview(files: Files, tmp_path: Path, empty: bool,
                                                   capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "skirt.model"
    argv: list[object] = ["build", "--stereo", files.stereo, "--right", files.right,
                          "--left", files.left, "--out", out]
    if empty:
        argv += ["--empty-right", files.empty_right, "--empty-left", files.empty_left]
    code, text, err = _run(capsys, argv)
    assert code == 0, err
    assert "Traceback" not in err
    line = _one_line(text)
    assert line.startswith(f"{out}: model 'skirt'")
    assert "in place" in line and "mm/px" in line and "table plane at" in line
    assert out.is_file() and out.with_suffix(".preview.png").is_file()
    model = load_model(out)
    assert model.name == "skirt" and scale_known(model)
    assert model.meta["in_place"]["empty_pair"] is empty
    assert model.meta["in_place"]["mm_per_px"] == pytest.approx(0.86, abs=0.02)


def test_in_place_takes_the_name_option(files: Files, tmp_path: Path,
                                        capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "x.npz"
    code, text, err = _run(capsys, ["build", "--stereo", files.stereo, "--right", files.right,
                                    "--left", files.left, "--out", out, "--name", "No.5",
                                    "--no-preview"])
    assert code == 0, err
    assert "model 'No.5'" in _one_line(text)
    assert load_model(out).name == "No.5"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["x.npz"]


# --- unknown scale --------------------------------------------------------------------------


@pytest.mark.parametrize("background", [True, False], ids=["background", "surface-colour"])
def test_unknown_scale_writes_a_model_of_unknown_scale(
        files: Files, tmp_path: Path, background: bool,
        capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "trousers.model"
    argv: list[object] = ["build", "--scale", "unknown", "--photo", files.photo, "--out", out]
    if background:
        argv += ["--background", files.background]
    code, text, err = _run(capsys, argv)
    assert code == 0, err
    line = _one_line(text)
    assert "scale unknown" in line and "nominal mm" in line
    assert out.is_file() and out.with_suffix(".preview.png").is_file()
    model = load_model(out)
    assert not scale_known(model) and model.meta["scale"]["known"] is False


def test_locate_of_an_unknown_scale_model_prints_its_scale(
        files: Files, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    model = tmp_path / "trousers.model"
    code, _, err = _run(capsys, ["build", "--scale", "unknown", "--photo", files.photo,
                                 "--out", model, "--no-preview"])
    assert code == 0, err
    code, text, err = _run(capsys, ["locate", "--model", model, "--stereo", files.stereo,
                                    "--right", files.scene_right, "--left", files.scene_left])
    assert code == 0, err
    scale = [line for line in text.splitlines() if line.startswith("scale")]
    assert len(scale) == 1, text
    factor = float(scale[0].split()[1])
    # the station photo's 0.53 mm a pixel against the nominal 0.94: about 0.566
    assert factor == pytest.approx(0.566, rel=0.01)


# --- wrong mixes of options -----------------------------------------------------------------


def _mixes(f: Files) -> dict[str, tuple[str, list[object]]]:
    """Case id -> (the option the error names, the build options but --out)."""
    stereo = ["--stereo", f.stereo, "--right", f.right, "--left", f.left]
    return {
        "stereo-and-photo": ("--stereo", stereo + ["--photo", f.photo]),
        "stereo-and-camera": ("--stereo", stereo + ["--camera", f.camera]),
        "stereo-and-scale-unknown": ("--stereo", stereo + ["--scale", "unknown"]),
        "missing-left": ("--left", ["--stereo", f.stereo, "--right", f.right]),
        "missing-right": ("--right", ["--stereo", f.stereo, "--left", f.left]),
        "missing-stereo": ("--stereo", ["--right", f.right, "--left", f.left]),
        "empty-right-only": ("--empty-left", stereo + ["--empty-right", f.empty_right]),
        "empty-left-only": ("--empty-right", stereo + ["--empty-left", f.empty_left]),
        "unknown-with-camera": ("--camera", ["--scale", "unknown", "--photo", f.photo,
                                             "--camera", f.camera]),
        "unknown-with-distance": ("--distance-mm", ["--scale", "unknown", "--photo", f.photo,
                                                    "--distance-mm", "400"]),
        "no-mode": ("--photo", []),
        "station-without-camera": ("--camera", ["--photo", f.photo,
                                                "--background", f.background]),
    }


_CASES = list(_mixes(Files(*[Path("-")] * len(fields(Files)))))


@pytest.mark.parametrize("case", _CASES)
def test_wrong_mix_is_one_line_and_writes_nothing(files: Files, tmp_path: Path, case: str,
                                                  capsys: pytest.CaptureFixture[str]) -> None:
    option, argv = _mixes(files)[case]
    out = tmp_path / "out"
    out.mkdir()
    code, text, err = _run(capsys, ["build", *argv, "--out", out / "x.model"])
    assert code == EXIT_INPUT_ERROR, err
    assert "Traceback" not in err and text == ""
    line = _one_line(err)
    assert line.startswith(f"photomodel: error: {option}: "), line
    assert sorted(p.name for p in out.iterdir()) == []


def test_in_place_refusal_names_the_file(files: Files, tmp_path: Path,
                                         capsys: pytest.CaptureFixture[str]) -> None:
    """An empty pair that holds the garment too: the right view's file, exit 2, nothing
    written."""
    out = tmp_path / "out"
    out.mkdir()
    code, text, err = _run(capsys, ["build", "--stereo", files.stereo, "--right", files.right,
                                    "--left", files.left, "--empty-right", files.right,
                                    "--empty-left", files.left, "--out", out / "x.model"])
    assert code == EXIT_INPUT_ERROR and text == ""
    line = _one_line(err)
    assert line.startswith(f"photomodel: error: {files.right}: "), line
    assert "is the garment in the empty pair too?" in line
    assert sorted(p.name for p in out.iterdir()) == []
