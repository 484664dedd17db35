"""The README's Python quick start runs as written, on the files ``make demo`` writes."""

from __future__ import annotations

import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from photomodel.cli import main

README = Path(__file__).parents[1] / "README.md"


def _quick_start() -> str:
    blocks = re.findall(r"```python\n(.*?)```", README.read_text(), flags=re.DOTALL)
    assert blocks, "README.md has no ```python block"
    return blocks[0]


def test_the_quick_start_is_five_lines_of_api() -> None:
    code = _quick_start()
    assert code.startswith("import photomodel as pm")
    assert len(code.strip().splitlines()) <= 8


@pytest.mark.filterwarnings("ignore::DeprecationWarning")
def test_the_quick_start_runs_as_written(tmp_path: Path) -> None:
    """The demo's layout (``build/demo/data``, ``calibration``, ``models``) for one garment, then
    the README's block in a new process in that folder."""
    data, models = tmp_path / "build/demo/data", tmp_path / "build/demo/models"
    assert main(["simulate", "--out", str(data), "--garments", "No.3", "--scenes", "1",
                 "--seed", "3"]) == 0
    assert main(["build", "--photo", str(data / "models/No.3/photo.bmp"),
                 "--background", str(data / "models/No.3/background.bmp"),
                 "--camera", str(data / "model_camera.yaml"),
                 "--out", str(models / "No.3.npz"), "--name", "No.3"]) == 0
    # the demo calibrates the rig into build/demo/calibration; the true file stands in here
    (tmp_path / "build/demo/calibration").mkdir(parents=True)
    shutil.copy(data / "stereo.yaml", tmp_path / "build/demo/calibration/stereo.yaml")
    done = subprocess.run([sys.executable, "-c", _quick_start()], cwd=tmp_path,
                          capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    assert done.stdout.split()[0] == "True", done.stdout
