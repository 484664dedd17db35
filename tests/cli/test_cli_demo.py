"""``photomodel demo``: simulate, calibrate, build a library, locate, pick, identify, through the
real commands and with no file written by hand."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from photomodel.cli._main import main


def test_demo_runs_end_to_end_and_finds_the_true_pose(tmp_path: Path,
                                                      capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "demo"
    assert main(["demo", "--out", str(out), "--seed", "3", "--garments", "No.1,No.3"]) == 0
    text = capsys.readouterr().out
    for command in ("simulate", "calibrate stereo", "calibrate camera", "handeye", "build",
                    "locate", "pick", "identify"):
        assert f"$ photomodel {command}" in text
    for name in ("stereo.yaml", "station.yaml", "hand_eye.yaml", "stereo.coverage.png"):
        assert (out / "calibration" / name).is_file()
    # every later step reads the calibrations the demo made, not the simulator's files
    assert "--stereo " + str(out / "data" / "stereo.yaml") not in text
    assert "--camera " + str(out / "data" / "model_camera.yaml") not in text
    pick = next(line for line in text.splitlines() if line.startswith("pick:"))
    assert float(pick.split(" mm from the truth")[0].rsplit(", ", 1)[1]) < 2.0
    assert json.loads((out / "pick.json").read_text())["reachable"] is True
    for name in ("stereo.yaml", "model_camera.yaml", "truth.json",
                 "models/No.1/photo.bmp", "models/No.1/background.bmp"):
        assert (out / "data" / name).is_file()
    for name in ("No.1.npz", "No.3.npz", "No.1.preview.png"):
        assert (out / "models" / name).is_file()
    assert (out / "overlay.png").is_file()
    error_row = next(line for line in text.splitlines() if line.startswith("error"))
    dx, dy, dz, dtheta = (float(v) for v in error_row.split()[1:])
    assert np.hypot(dx, dy) < 2.0 and abs(dz) < 10.0 and abs(dtheta) < 1.0
    truth = json.loads((out / "data" / "truth.json").read_text())
    assert sorted(facts["model"] for facts in truth.values()) == ["No.1", "No.3"]
    identified = next(line for line in text.splitlines() if line.startswith("identify in"))
    assert identified.split(": ")[1].startswith("No.3 (truth No.3)")
