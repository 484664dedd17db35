"""``photomodel simulate``: a real run, a user's own garment, and one clear line per bad input.

docs/contracts.md ("Command line"): errors give one line on stderr (``photomodel: error:
...``) naming the file or argument, exit code 2, no traceback, and nothing half-written (no
dataset directory, no hidden build directory beside it, no contact sheet).
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import cv2
import numpy as np
import pytest

from photomodel.cli import main
from photomodel.sim import write_dataset

LAYOUT = {"stereo.yaml", "model_camera.yaml", "truth.json", "dataset.json",
          "models/No.3/photo.bmp", "models/No.3/background.bmp",
          "scenes/paper_No.3_0000/right.png", "scenes/paper_No.3_0000/left.png",
          "scenes/no-target_0000/right.png", "scenes/no-target_0000/left.png"}


def _files(root: Path) -> dict[str, bytes]:
    return {p.relative_to(root).as_posix(): p.read_bytes()
            for p in sorted(root.rglob("*")) if p.is_file()}


def _run(capsys: pytest.CaptureFixture[str], argv: list[object]) -> tuple[int, str, str]:
    code = main([str(a) for a in argv])
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def _assert_one_error_line(code: int, out: str, err: str, *mentions: str) -> str:
    assert code == 2, (out, err)
    assert "Traceback" not in err
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith("photomodel: error: "), lines[0]
    for text in mentions:
        assert text in lines[0], (text, lines[0])
    assert out == ""
    return lines[0]


def _assert_nothing_written(parent: Path, *expected: str) -> None:
    """Only ``expected`` names (inputs made by the test) are in ``parent``: no output at all."""
    assert sorted(p.name for p in parent.iterdir()) == sorted(expected)


@pytest.fixture
def user_garment(tmp_path: Path) -> tuple[Path, Path]:
    """A blue ellipse with a stripe, its mask: a user's garment photo (300 x 200 px)."""
    image = np.full((200, 300, 3), 235, np.uint8)
    mask = np.zeros((200, 300), np.uint8)
    cv2.ellipse(mask, (150, 100), (120, 80), 0, 0, 360, 255, -1)
    image[mask > 0] = (200, 70, 30)
    image[90:110][mask[90:110] > 0] = (40, 200, 250)
    inputs = tmp_path / "inputs"
    inputs.mkdir()
    paths = inputs / "mine.png", inputs / "mine_mask.png"
    assert cv2.imwrite(str(paths[0]), image) and cv2.imwrite(str(paths[1]), mask)
    return paths


# --- a real run ------------------------------------------------------------------------------


def test_simulate_in_a_subprocess_writes_the_dataset_and_a_contact_sheet(tmp_path: Path) -> None:
    out, sheet = tmp_path / "D", tmp_path / "D2" / "sheet.png"
    result = subprocess.run(
        [sys.executable, "-m", "photomodel", "simulate", "--out", str(out), "--garments", "No.3",
         "--conditions", "paper,no-target", "--scenes", "1", "--seed", "1",
         "--contact-sheet", str(sheet)],
        capture_output=True, text=True, timeout=300, cwd=tmp_path)
    assert result.returncode == 0, result.stderr
    assert "Traceback" not in result.stderr
    assert "1 model(s), 2 scene(s)" in result.stdout and str(sheet) in result.stdout
    files = _files(out)
    assert set(files) == LAYOUT
    truth = json.loads(files["truth.json"])
    assert truth["no-target_0000"]["model"] is None
    assert truth["paper_No.3_0000"]["model"] == "No.3"
    assert sheet.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    image = cv2.imread(str(sheet))
    assert image is not None and image.shape[0] > 150 and image.shape[1] > 400
    # The command is a thin wrapper: the library, in this process (another hash seed), writes
    # the very same bytes.
    again = write_dataset(tmp_path / "again", ["No.3"], ["paper", "no-target"], 1, 1)
    assert _files(again.out) == files


def test_user_garment_is_modelled_and_simulated(capsys, tmp_path: Path,
                                                user_garment: tuple[Path, Path]) -> None:
    image, mask = user_garment
    out = tmp_path / "ds"
    code, stdout, err = _run(capsys, ["simulate", "--out", out, "--garments=",
                                      "--add-garment", "mine", image, mask, "200",
                                      "--conditions", "paper", "--seed", "3"])
    assert code == 0, err
    assert "1 model(s), 1 scene(s)" in stdout
    assert set(_files(out)) == {"stereo.yaml", "model_camera.yaml", "truth.json", "dataset.json",
                                "models/mine/photo.bmp", "models/mine/background.bmp",
                                "scenes/paper_mine_0000/right.png",
                                "scenes/paper_mine_0000/left.png"}
    truth = json.loads((out / "truth.json").read_text())
    assert truth["paper_mine_0000"]["model"] == "mine"
    assert truth["paper_mine_0000"]["visible_fraction"] == pytest.approx([1.0, 1.0])
    manifest = json.loads((out / "dataset.json").read_text())
    assert manifest["garments"]["mine"]["shape"] == "user"
    assert manifest["garments"]["mine"]["size_mm"][0] == pytest.approx(200.0)
    # On the model photo the garment has the size the width says: the 241 px wide mask is
    # 200 mm wide, seen from 400 mm with f = 760 px.
    photo = cv2.imread(str(out / "models" / "mine" / "photo.bmp"))
    hue = cv2.cvtColor(photo, cv2.COLOR_BGR2HSV)[..., 0].astype(float)
    garment_px = int((np.abs(hue - 62) > 20).sum())
    mask_px = int((cv2.imread(str(mask), cv2.IMREAD_GRAYSCALE) > 0).sum())
    expected = mask_px * (200.0 / 241.0) ** 2 * (760.0 / 400.0) ** 2
    assert 0.93 * expected < garment_px < 1.02 * expected
    # ... and the scene shows it too: the user's blue and yellow are in the right image.
    scene = cv2.imread(str(out / "scenes" / "paper_mine_0000" / "right.png"))
    hsv = cv2.cvtColor(scene, cv2.COLOR_BGR2HSV).reshape(-1, 3)
    blue = (np.abs(hsv[:, 0].astype(int) - 111) < 8) & (hsv[:, 1] > 150)
    assert blue.sum() > 0.5 * expected * (800.0 / 685.0) ** 2 / (760.0 / 400.0) ** 2


def test_force_replaces_an_existing_dataset(capsys, tmp_path: Path) -> None:
    out = tmp_path / "ds"
    out.mkdir()
    (out / "old.txt").write_text("old")
    (out / "dataset.json").write_text('{"format": "photomodel-dataset"}')  # simulate wrote it
    argv = ["simulate", "--out", out, "--garments", "No.3", "--conditions", "no-target"]
    line = _assert_one_error_line(*_run(capsys, argv), "ds", "exists")
    assert "--force" in line
    assert set(_files(out)) == {"old.txt", "dataset.json"}
    _assert_nothing_written(tmp_path, "ds")
    code, stdout, err = _run(capsys, [*argv, "--force"])
    assert code == 0, err
    assert "old.txt" not in _files(out) and (out / "scenes" / "no-target_0000").is_dir()
    _assert_nothing_written(tmp_path, "ds")


# --- one clear line for every bad input ------------------------------------------------------


@pytest.mark.parametrize(("extra", "mentions"), [
    (["--garments", "No.3,No.99"], ["No.99"]),
    (["--conditions", "paper,fog"], ["fog", "paper"]),  # names the known ones
    (["--conditions", "paper,wide-lens"], ["lens"]),
    (["--scenes", "0"], ["scenes"]),
    (["--garments="], ["--garments"]),
    (["--contact-sheet", "{tmp}/sheet.jpg"], ["sheet.jpg", ".png"]),
])
def test_bad_arguments(capsys, tmp_path: Path, extra: list[str], mentions: list[str]) -> None:
    out = tmp_path / "out"
    argv = ["simulate", "--out", out, "--garments", "No.3", "--conditions", "paper"]
    argv += [a.replace("{tmp}", str(tmp_path)) for a in extra]
    _assert_one_error_line(*_run(capsys, argv), *mentions)
    _assert_nothing_written(tmp_path)


def test_add_garment_with_a_missing_mask(capsys, tmp_path: Path,
                                         user_garment: tuple[Path, Path]) -> None:
    image, _ = user_garment
    missing = tmp_path / "inputs" / "no_such_mask.png"
    argv = ["simulate", "--out", tmp_path / "out", "--add-garment", "mine", image, missing,
            "200", "--garments", "No.3"]
    _assert_one_error_line(*_run(capsys, argv), "no_such_mask.png", "not found")
    _assert_nothing_written(tmp_path, "inputs")


def test_add_garment_with_a_missing_image(capsys, tmp_path: Path,
                                          user_garment: tuple[Path, Path]) -> None:
    _, mask = user_garment
    argv = ["simulate", "--out", tmp_path / "out", "--add-garment", "mine",
            tmp_path / "no_such_photo.jpg", mask, "200"]
    _assert_one_error_line(*_run(capsys, argv), "no_such_photo.jpg")
    _assert_nothing_written(tmp_path, "inputs")


def test_add_garment_with_a_mask_of_another_size(capsys, tmp_path: Path,
                                                 user_garment: tuple[Path, Path]) -> None:
    image, mask = user_garment
    small = mask.with_name("small_mask.png")
    assert cv2.imwrite(str(small), cv2.imread(str(mask), cv2.IMREAD_GRAYSCALE)[:100, :150])
    argv = ["simulate", "--out", tmp_path / "out", "--add-garment", "mine", image, small, "200"]
    _assert_one_error_line(*_run(capsys, argv), "small_mask.png")
    _assert_nothing_written(tmp_path, "inputs")


@pytest.mark.parametrize("width", ["wide", "0", "-5", "nan", "inf"])
def test_add_garment_with_a_bad_width(capsys, tmp_path: Path, user_garment: tuple[Path, Path],
                                      width: str) -> None:
    image, mask = user_garment
    argv = ["simulate", "--out", tmp_path / "out", "--add-garment", "mine", image, mask, width]
    line = _assert_one_error_line(*_run(capsys, argv))
    assert "width" in line.lower(), line
    _assert_nothing_written(tmp_path, "inputs")


def test_add_garment_with_a_name_that_is_no_directory(capsys, tmp_path: Path,
                                                      user_garment: tuple[Path, Path]) -> None:
    image, mask = user_garment
    argv = ["simulate", "--out", tmp_path / "out", "--add-garment", "a/b", image, mask, "200"]
    _assert_one_error_line(*_run(capsys, argv), "a/b")
    _assert_nothing_written(tmp_path, "inputs")


# --- a simulated catalogue of any size --------------------------------------------------------


def test_catalogue_writes_model_photos_without_scenes(capsys, tmp_path: Path) -> None:
    out = tmp_path / "lib"
    code, stdout, err = _run(capsys, ["simulate", "--out", out, "--catalogue", "3"])
    assert code == 0, err
    assert "3 model(s), 0 scene(s)" in stdout
    names = ["cat-00000", "cat-00001", "cat-00002"]
    assert set(_files(out)) == {"stereo.yaml", "model_camera.yaml", "truth.json",
                                "dataset.json"} | {f"models/{n}/{f}" for n in names
                                                   for f in ("photo.bmp", "background.bmp")}
    assert json.loads((out / "truth.json").read_text()) == {}
    assert list(json.loads((out / "dataset.json").read_text())["library"]) == names
    # Beside garments of its own, a catalogue adds model photos only; no-target still has
    # its scenes.
    both = tmp_path / "both"
    code, stdout, err = _run(capsys, ["simulate", "--out", both, "--catalogue", "2",
                                      "--garments", "No.3,cat-00001", "--conditions",
                                      "paper,no-target"])
    assert code == 0, err
    truth = json.loads((both / "truth.json").read_text())
    assert set(truth) == {"paper_No.3_0000", "paper_cat-00001_0000", "no-target_0000"}
    assert sorted(p.name for p in (both / "models").iterdir()) == [
        "No.3", "cat-00000", "cat-00001"]
    # The same seed gives the same model photo, asked for in a library or as a garment.
    assert ((both / "models" / "cat-00000" / "photo.bmp").read_bytes()
            == (out / "models" / "cat-00000" / "photo.bmp").read_bytes())


@pytest.mark.parametrize(("value", "option"), [
    (["--catalogue", "0"], "--catalogue"),
    (["--catalogue", "100001"], "--catalogue"),
    (["--catalogue", "-4"], "--catalogue"),
    (["--garments", "catalogue:0"], "--garments"),
    (["--garments", "catalogue:abc"], "--garments"),
    (["--garments", "cat-100000"], "--garments"),
])
def test_bad_catalogue_values(capsys, tmp_path: Path, value: list[str], option: str) -> None:
    argv = ["simulate", "--out", tmp_path / "out", "--conditions", "no-target", *value]
    line = _assert_one_error_line(*_run(capsys, argv), option)
    assert "catalogue" in line or "cat-" in line
    _assert_nothing_written(tmp_path)


def test_a_catalogue_size_that_is_no_number(capsys, tmp_path: Path) -> None:
    with pytest.raises(SystemExit) as exit_:   # argparse's own check, one line too
        main(["simulate", "--out", str(tmp_path / "out"), "--catalogue", "many"])
    _assert_one_error_line(exit_.value.code, *capsys.readouterr(), "--catalogue", "'many'")
    _assert_nothing_written(tmp_path)
