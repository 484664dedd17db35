"""A simulated cell for the service's tests: a dataset (two garments, their model photos, a
few scenes), a library of one of them, and a running service on a free loopback port."""

from __future__ import annotations

import json
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import pytest

from photomodel.cli import main


@dataclass(frozen=True)
class CellData:
    """Paths of the simulated cell: ``dataset`` (simulate's layout), ``library`` (holds
    ``No.3`` only; ``No.5`` is registered by the tests), the scenes by id and the truth."""

    dataset: Path
    library: Path
    scenes: dict[str, Path]
    truth: dict[str, dict]

    @property
    def stereo(self) -> Path:
        return self.dataset / "stereo.yaml"

    @property
    def camera(self) -> Path:
        return self.dataset / "model_camera.yaml"

    def photos(self, garment: str) -> tuple[Path, Path]:
        """The model photo and the background of ``garment``."""
        folder = self.dataset / "models" / garment
        return folder / "photo.bmp", folder / "background.bmp"

    def scene_of(self, garment: str) -> Path:
        """The first scene that shows ``garment``."""
        return next(p for sid, p in sorted(self.scenes.items())
                    if self.truth[sid]["model"] == garment)


@pytest.fixture(scope="session")
def cell_data(tmp_path_factory: pytest.TempPathFactory) -> CellData:
    root = tmp_path_factory.mktemp("cell")
    dataset = root / "data"
    assert main(["simulate", "--out", str(dataset), "--garments", "No.3,No.5", "--scenes",
                 "2", "--seed", "5"]) == 0
    model = root / "No.3.npz"
    photo, background = (dataset / "models" / "No.3" / f for f in ("photo.bmp",
                                                                     "background.bmp"))
    assert main(["build", "--photo", str(photo), "--background", str(background), "--camera",
                 str(dataset / "model_camera.yaml"), "--out", str(model), "--name", "No.3",
                 "--no-preview"]) == 0
    library = root / "library"
    assert main(["models", "add", "--models", str(library), str(model)]) == 0
    truth = json.loads((dataset / "truth.json").read_text())
    scenes = {p.name: p for p in (dataset / "scenes").iterdir()}
    return CellData(dataset, library, scenes, truth)


@pytest.fixture(scope="module")
def service(cell_data: CellData, tmp_path_factory: pytest.TempPathFactory
            ) -> Iterator[object]:
    """A warmed service (``ServiceThread``: ``.url``, ``.cell``) on a copy of the library,
    with the model station's camera (so registration works)."""
    import shutil

    from photomodel.service import CellService, ServiceConfig, ServiceThread

    library = tmp_path_factory.mktemp("served") / "library"
    shutil.copytree(cell_data.library, library)
    cell = CellService(ServiceConfig(stereo=cell_data.stereo, models=library,
                                     camera=cell_data.camera))
    with ServiceThread(cell) as running:
        running.wait_ready()
        yield running
