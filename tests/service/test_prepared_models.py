"""The service over a library larger than ``--prepared-models``: warm-up reads the index, not
the model files; each model is prepared when a request needs it and the least recently used is
dropped; registrations and removals reach ``/models`` and ``/identify``; the bound is
validated."""

from __future__ import annotations

import os
import re
import shutil
from collections.abc import Iterator
from pathlib import Path

import httpx
import numpy as np
import pytest

import photomodel as pm
from photomodel.cli import main
from photomodel.library import ModelLibrary
from photomodel.service import CellService, ServiceConfig, ServiceThread

TIMEOUT_S = 120.0
TWIN = "No.3-twin"      # No.3's model under a second name


def _pair(scene: Path) -> dict[str, tuple[str, bytes, str]]:
    return {side: (f"{side}.png", (scene / f"{side}.png").read_bytes(), "image/png")
            for side in ("right", "left")}


def _locate(url: str, model: str, scene: Path, seed: int = 1) -> httpx.Response:
    return httpx.post(f"{url}/locate", data={"model": model, "seed": str(seed)},
                      files=_pair(scene), timeout=TIMEOUT_S)


def _identify(url: str, scene: Path) -> dict:
    answer = httpx.post(f"{url}/identify", data={"seed": "1"}, files=_pair(scene),
                        timeout=TIMEOUT_S)
    assert answer.status_code == 200, answer.text
    return answer.json()


def _metric(text: str, name: str) -> float:
    found = re.search(rf"^{name} (\S+)$", text, re.MULTILINE)
    assert found is not None, f"{name} not in /metrics"
    return float(found.group(1))


@pytest.fixture(scope="module")
def three_models(cell_data, tmp_path_factory) -> Path:
    """A library of No.3, No.3-twin and No.5 (No.3 first by name)."""
    root = tmp_path_factory.mktemp("three")
    photo, background = cell_data.photos("No.5")
    model = root / "No.5.npz"
    assert main(["build", "--photo", str(photo), "--background", str(background), "--camera",
                 str(cell_data.camera), "--out", str(model), "--name", "No.5",
                 "--no-preview"]) == 0
    library = root / "library"
    shutil.copytree(cell_data.library, library)
    ModelLibrary(library).add(model)
    ModelLibrary(library).add(library / "No.3.npz", name=TWIN)
    return library


@pytest.fixture(scope="module")
def one_prepared(three_models, cell_data, tmp_path_factory) -> Iterator[ServiceThread]:
    """A warmed service on a copy of the three models that keeps one prepared."""
    library = tmp_path_factory.mktemp("one") / "library"
    shutil.copytree(three_models, library)
    cell = CellService(ServiceConfig(stereo=cell_data.stereo, models=library,
                                     camera=cell_data.camera, prepared_models=1))
    with ServiceThread(cell) as running:
        running.wait_ready()
        yield running


def test_warm_up_prepares_at_most_the_bound(one_prepared) -> None:
    health = httpx.get(f"{one_prepared.url}/health").json()
    assert health["status"] == "ok" and health["models"] == 3
    assert health["prepared"] == 1 and health["prepared_max"] == 1
    stats = one_prepared.cell.prepared_stats()
    assert stats.misses == 1 and stats.evicted == 0       # No.3, the first by name
    names = [m["name"] for m in httpx.get(f"{one_prepared.url}/models").json()]
    assert names == ["No.3", TWIN, "No.5"]


def test_each_model_located_in_turn_with_one_prepared(one_prepared, cell_data) -> None:
    url, cell = one_prepared.url, one_prepared.cell
    rig = pm.load_stereo(cell_data.stereo)
    before = cell.prepared_stats()
    order = ["No.5", TWIN, "No.3", "No.5"]
    for name in order:
        scene = cell_data.scene_of("No.3" if name == TWIN else name)
        answer = _locate(url, name, scene, seed=4)
        assert answer.status_code == 200, answer.text
        answer = answer.json()
        assert answer["found"], (name, answer)
        assert httpx.get(f"{url}/health").json()["prepared"] <= 1
        if name == "No.5":   # prepared on demand: the pose of the in-process Locator
            library = ModelLibrary(cell.library.root)
            model = library.load_entry(library.entry("No.5"))
            mine = pm.Locator(model, rig, min_score=cell.min_score)(
                pm.read_image(scene / "right.png"), pm.read_image(scene / "left.png"), rng=4)
            np.testing.assert_allclose(answer["T_cam1_model"], mine.T_cam1_model, atol=1e-9)
    after = cell.prepared_stats()
    assert after.prepared == 1
    assert after.misses - before.misses == len(order)      # every request a new model
    assert after.evicted - before.evicted == len(order)
    metrics = httpx.get(f"{url}/metrics").text
    assert _metric(metrics, "photomodel_prepared_models") == 1
    assert _metric(metrics, "photomodel_model_preparations_total") == after.misses
    assert _metric(metrics, "photomodel_prepared_evictions_total") == after.evicted
    assert _metric(metrics, "photomodel_models") == 3


def test_previews_of_models_not_prepared(one_prepared) -> None:
    for m in httpx.get(f"{one_prepared.url}/models").json():
        png = httpx.get(f"{one_prepared.url}/{m['preview']}")
        assert png.status_code == 200 and png.content[:8] == b"\x89PNG\r\n\x1a\n", m["name"]
    assert one_prepared.cell.prepared_stats().prepared == 1


def test_identify_registration_and_removal_with_one_prepared(one_prepared, cell_data) -> None:
    url, cell = one_prepared.url, one_prepared.cell
    assert _identify(url, cell_data.scene_of("No.5"))["model"] == "No.5"
    assert _identify(url, cell_data.scene_of("No.3"))["model"] in ("No.3", TWIN)
    # removed: gone from /models and from what identify can answer
    assert httpx.delete(f"{url}/models/{TWIN}").status_code == 200
    assert [m["name"] for m in httpx.get(f"{url}/models").json()] == ["No.3", "No.5"]
    assert _identify(url, cell_data.scene_of("No.3"))["model"] == "No.3"
    assert _locate(url, TWIN, cell_data.scene_of("No.3")).status_code == 404
    # registered: listed, prepared (the only one held) and used by the next requests
    photo, background = cell_data.photos("No.5")
    files = {"photo": ("photo.bmp", photo.read_bytes(), "image/bmp"),
             "background": ("background.bmp", background.read_bytes(), "image/bmp")}
    created = httpx.post(f"{url}/models", data={"name": "No.5-again"}, files=files,
                         timeout=TIMEOUT_S)
    assert created.status_code == 201, created.text
    assert [m["name"] for m in httpx.get(f"{url}/models").json()] == ["No.3", "No.5",
                                                                       "No.5-again"]
    health = httpx.get(f"{url}/health").json()
    assert health["models"] == 3 and health["prepared"] == 1
    held = cell.prepared_stats()
    answer = _locate(url, "No.5-again", cell_data.scene_of("No.5")).json()
    assert answer["found"], answer
    assert cell.prepared_stats().misses == held.misses     # registered prepared
    assert _identify(url, cell_data.scene_of("No.5"))["model"] in ("No.5", "No.5-again")


def test_warm_up_reads_no_model_file(three_models, cell_data, tmp_path) -> None:
    """The models after the first are overwritten with zeros of the same size and time: the
    index vouches for them, so the service starts and lists them; a request for one of them
    reads its file and is refused (the service keeps running)."""
    library = tmp_path / "library"
    shutil.copytree(three_models, library)
    for name in (TWIN, "No.5"):
        path = library / f"{name}.npz"
        st = path.stat()
        path.write_bytes(b"\0" * st.st_size)
        os.utime(path, ns=(st.st_atime_ns, st.st_mtime_ns))
    cell = CellService(ServiceConfig(stereo=cell_data.stereo, models=library,
                                     prepared_models=1))
    with ServiceThread(cell) as running:
        running.wait_ready()
        health = httpx.get(f"{running.url}/health").json()
        assert health["status"] == "ok" and health["models"] == 3 and health["prepared"] == 1
        assert len(httpx.get(f"{running.url}/models").json()) == 3
        assert _locate(running.url, "No.3", cell_data.scene_of("No.3")).json()["found"]
        refused = _locate(running.url, "No.5", cell_data.scene_of("No.5"))
        assert refused.status_code == 400 and "No.5.npz" in refused.json()["error"]
        assert httpx.get(f"{running.url}/health").json()["status"] == "ok"


@pytest.mark.parametrize("value", [0, -1, 100_001])
def test_the_bound_is_validated(value: int, capsys, cell_data, tmp_path) -> None:
    with pytest.raises(ValueError, match="prepared_models"):
        ServiceConfig(stereo=cell_data.stereo, models=tmp_path, prepared_models=value)
    argv = ["serve", "--stereo", str(cell_data.stereo), "--models", str(tmp_path / "lib"),
            "--prepared-models", str(value)]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert err == ("photomodel: error: --prepared-models: expected an integer from 1 to "
                   f"100000, got {value}")
    assert not (tmp_path / "lib").exists()


def test_an_identify_that_meets_a_removal_runs_again(three_models, cell_data, tmp_path,
                                                     monkeypatch) -> None:
    """A model screened in but removed before it was loaded (``Identifier`` raises for it):
    the identify runs once more on the library as it is now; the same error without a change
    of the library is not hidden."""
    from photomodel.identify import Identifier

    library = tmp_path / "library"
    shutil.copytree(three_models, library)
    cell = CellService(ServiceConfig(stereo=cell_data.stereo, models=library,
                                     prepared_models=1))
    cell.warm(progress=lambda line: None)
    assert cell.status == "ok", cell.detail
    scene = cell_data.scene_of("No.5")
    right, left = ((scene / f"{side}.png").read_bytes() for side in ("right", "left"))
    real = Identifier.__call__
    calls: list[int] = []

    def removed_meanwhile(self, *args, **kwargs):
        calls.append(len(self))
        if len(calls) == 1:
            cell.remove(TWIN)          # what another request did while this one screened
            raise KeyError(TWIN)
        return real(self, *args, **kwargs)

    monkeypatch.setattr(Identifier, "__call__", removed_meanwhile)
    answer = cell.identify(right, left, seed=1)
    assert answer["model"] == "No.5" and calls == [3, 2]

    def broken(self, *args, **kwargs):
        raise KeyError("a bug")

    monkeypatch.setattr(Identifier, "__call__", broken)
    with pytest.raises(KeyError, match="a bug"):
        cell.identify(right, left, seed=1)
