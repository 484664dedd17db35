"""``photomodel identify`` and ``photomodel models`` on real files: the JSON contract, warnings
for files that are not photo-models, and one clear error line for every bad input."""

from __future__ import annotations

import json
import shutil
import sys
from pathlib import Path

import cv2
import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "identify"))

from identify_helpers import IdentifyData, make_identify_data  # noqa: E402

from photomodel.cli import main  # noqa: E402

LOCATE_KEYS = {"model", "found", "T_cam1_model", "position_mm", "quat_wxyz", "theta_deg",
               "fitness", "score", "seconds"}


@pytest.fixture(scope="module")
def data(tmp_path_factory: pytest.TempPathFactory) -> IdentifyData:
    return make_identify_data(tmp_path_factory.mktemp("cli_identify"))


def _run(capsys: pytest.CaptureFixture[str], argv: list[object]) -> tuple[int, str, str]:
    code = main([str(a) for a in argv])
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def _clean_error(code: int, out: str, err: str, offending: str) -> str:
    assert code == 2, err
    assert "Traceback" not in err and out == ""
    lines = [line for line in err.splitlines() if line.strip()]
    assert len(lines) == 1, err
    assert lines[0].startswith("photomodel: error: ") and offending in lines[0], lines[0]
    return lines[0]


def _argv(data: IdentifyData, library: Path, **files: Path) -> list[object]:
    return ["identify", "--models", library, "--stereo", files.get("stereo", data.stereo),
            "--right", files.get("right", data.right), "--left", files.get("left", data.left),
            "--json", "--max-candidates", "1"]  # one search keeps the test short


def test_identify_json_with_a_corrupt_file_skipped(capsys, data: IdentifyData,
                                                   tmp_path: Path) -> None:
    library = tmp_path / "lib"
    shutil.copytree(data.library, library)
    (library / "broken.npz").write_bytes(b"PK\x03\x04 not really a zip")
    code, out, err = _run(capsys, _argv(data, library))
    assert code == 0, err
    warnings = [line for line in err.splitlines() if line.strip()]
    assert len(warnings) == 1 and "warning" in warnings[0] and "broken.npz" in warnings[0]
    doc = json.loads(out)
    assert LOCATE_KEYS <= set(doc) and doc["model"] == "No.5" and doc["found"] is True
    assert set(doc["runner_up"]) == {"model", "score"} and doc["runner_up"]["model"] is None
    assert [c["model"] for c in doc["candidates"] if c["score"] is not None] == ["No.5"]
    assert np.linalg.norm(np.asarray(doc["position_mm"]) - data.T_cam1_model[:3, 3]) < 10.0
    assert 0.0 <= doc["score"] <= 1.0


def test_identify_text_on_an_empty_table(capsys, data: IdentifyData) -> None:
    code, out, err = _run(capsys, ["identify", "--models", data.library, "--stereo",
                                   data.stereo, "--right", data.empty_right_path, "--left",
                                   data.empty_left_path, "--max-candidates", "1"])
    assert code == 0, err
    assert "none of the 3 models is on the table" in out


def test_missing_library(capsys, data: IdentifyData, tmp_path: Path) -> None:
    missing = tmp_path / "no_library"
    code, out, err = _run(capsys, _argv(data, missing))
    assert "not found" in _clean_error(code, out, err, "no_library")


def test_empty_library(capsys, data: IdentifyData, tmp_path: Path) -> None:
    empty = tmp_path / "empty_library"
    empty.mkdir()
    (empty / "junk.npz").write_bytes(b"junk")
    code, out, err = _run(capsys, _argv(data, empty))
    assert code == 2 and out == "" and "Traceback" not in err
    lines = err.strip().splitlines()
    assert "junk.npz" in lines[0] and "warning" in lines[0]  # the skipped file, named
    assert len(lines) == 2 and "empty_library" in lines[1] and "no usable" in lines[1]


def test_image_size_mismatch(capsys, data: IdentifyData, tmp_path: Path) -> None:
    small = tmp_path / "small_right.png"
    assert cv2.imwrite(str(small), cv2.imread(str(data.right))[:240, :320])
    code, out, err = _run(capsys, _argv(data, data.library, right=small))
    _clean_error(code, out, err, "small_right.png")


def test_missing_image_and_bad_calibration(capsys, data: IdentifyData, tmp_path: Path) -> None:
    code, out, err = _run(capsys, _argv(data, data.library, left=tmp_path / "gone_left.png"))
    _clean_error(code, out, err, "gone_left.png")
    bad = tmp_path / "bad_stereo.yaml"
    bad.write_text("%YAML:1.0\n---\nfoo: 1\n")
    code, out, err = _run(capsys, _argv(data, data.library, stereo=bad))
    _clean_error(code, out, err, "bad_stereo.yaml")


def test_models_commands(capsys, data: IdentifyData, tmp_path: Path) -> None:
    library = tmp_path / "lib"
    code, out, err = _run(capsys, ["models", "add", "--models", library,
                                   data.library / "No.3.npz", data.library / "No.9.npz"])
    assert code == 0, err
    assert out.count("added") == 2
    code, out, err = _run(capsys, ["models", "list", "--models", library, "--json"])
    doc = json.loads(out)
    assert [m["name"] for m in doc["models"]] == ["No.3", "No.9"] and doc["skipped"] == []
    assert {"size_mm", "colours", "added_utc", "created_utc"} <= set(doc["models"][0])
    (library / "foreign.npz").write_bytes(b"\x00" * 10)
    code, out, err = _run(capsys, ["models", "list", "--models", library])
    assert code == 0 and "No.3" in out and "2 model(s)" in out
    assert "foreign.npz" in err and "skipped" in err
    code, out, err = _run(capsys, ["models", "show", "--models", library, "No.9"])
    assert code == 0 and "colours" in out and "No.9" in out
    code, out, err = _run(capsys, ["models", "remove", "--models", library, "No.3"])
    assert code == 0 and not (library / "No.3.npz").exists()
    code, out, err = _run(capsys, ["models", "show", "--models", library, "No.3"])
    _clean_error(code, out, err, "lib")


def test_models_add_bad_file_writes_nothing(capsys, tmp_path: Path) -> None:
    bad = tmp_path / "bad_model.npz"
    bad.write_bytes(b"not a model")
    library = tmp_path / "lib"
    code, out, err = _run(capsys, ["models", "add", "--models", library, bad])
    _clean_error(code, out, err, "bad_model.npz")
    assert list(library.iterdir()) == []


@pytest.mark.parametrize(("extra", "expected"), [
    (["--garments", "No.99"], "--garments/--library: unknown garment 'No.99'"),
    (["--garments", "No.3", "--library", "No.5"], "--library: has no model of 'No.3'"),
    (["--garments", "No.3", "--negatives", "paper"], "--negatives: 'paper' has a target"),
    (["--garments", "No.3", "--conditions", "empty"], "--conditions: 'empty' has no target"),
])
def test_experiment_identify_bad_options(capsys, tmp_path: Path, extra: list[str],
                                         expected: str) -> None:
    code, out, err = _run(capsys, ["experiment", "--identify", "--out", tmp_path / "run",
                                   *extra])
    assert code == 2 and expected in err and "Traceback" not in err
    assert not (tmp_path / "run").exists()


def test_experiment_identify_records_which_code_ran_it(capsys, tmp_path: Path) -> None:
    argv = ["experiment", "--identify", "--out", tmp_path / "run", "--garments", "No.5",
            "--library", "No.5", "--conditions", "paper", "--trials", "1", "--negatives",
            "empty", "--negative-trials", "1", "--workers", "1"]
    code, out, err = _run(capsys, argv)
    assert code == 0, err
    runs = json.loads((tmp_path / "run" / "identify_runs.json").read_text())["runs"]
    assert len(runs) == 1 and runs[0]["trials"] == 2 and runs[0]["commit"]
    code, out, err = _run(capsys, argv)   # finished: resumed with nothing to run
    assert code == 0, err
    runs = json.loads((tmp_path / "run" / "identify_runs.json").read_text())["runs"]
    assert len(runs) == 1
