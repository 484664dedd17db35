"""The service with a camera source: POST /trigger/locate and /trigger/identify answer as
/locate and /identify do on the pair the source gives now, /record writes pairs that replay
reads back, and a source that stops degrades /health until it is back."""

from __future__ import annotations

import contextlib
import json
import shutil
import time
from collections.abc import Iterator
from pathlib import Path

import cv2
import httpx
import numpy as np
import pytest
from service_helpers import json_error as _error

import photomodel as pm
from photomodel.cli import main
from photomodel.service import CellService, ServiceConfig, ServiceThread
from photomodel.service._source import open_source

TIMEOUT_S = 120.0




def _video(path: Path, frames: int, fps: float = 30.0) -> Path:
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), fps, (640, 480))
    for k in range(frames):
        writer.write(np.full((480, 640, 3), (40 + 10 * k, 90, 160), np.uint8))
    writer.release()
    return path


def _wait_for(condition, timeout_s: float = 10.0) -> bool:  # type: ignore[no-untyped-def]
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if condition():
            return True
        time.sleep(0.1)
    return False


@pytest.fixture(scope="module")
def replay_dir(cell_data, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A one-pair sequence (the first No.3 scene) at 30 fps: every grab is that pair."""
    root = tmp_path_factory.mktemp("replay") / "seq"
    shutil.copytree(cell_data.scene_of("No.3"), root / "000000")
    (root / "meta.json").write_text(json.dumps({"fps": 30}))
    return root


@pytest.fixture(scope="module")
def camera_service(cell_data, replay_dir: Path, tmp_path_factory: pytest.TempPathFactory
                   ) -> Iterator[ServiceThread]:
    """A warmed service whose camera source replays ``replay_dir``."""
    library = tmp_path_factory.mktemp("served") / "library"
    shutil.copytree(cell_data.library, library)
    cell = CellService(ServiceConfig(stereo=cell_data.stereo, models=library,
                                     source=f"replay:{replay_dir}",
                                     record_dir=library.parent / "recs"))
    with ServiceThread(cell) as running:
        running.wait_ready()
        yield running
    cell.close()


@contextlib.contextmanager
def _source(cell: CellService, spec_or_opener, replay_dir: Path) -> Iterator[None]:  # type: ignore[no-untyped-def]
    """Another source for a while, then the replay again."""
    cell.attach_source(spec_or_opener)
    try:
        yield
    finally:
        cell.attach_source(f"replay:{replay_dir}")


def test_trigger_locate_answers_as_locate_on_the_pair_of_now(camera_service, cell_data
                                                              ) -> None:
    url = camera_service.url
    t_before = time.time()
    answer = httpx.post(f"{url}/trigger/locate", params={"model": "No.3", "seed": "7"},
                        timeout=TIMEOUT_S)
    assert answer.status_code == 200, answer.text
    answer = answer.json()
    scene = cell_data.scene_of("No.3")
    rig = pm.load_stereo(cell_data.stereo)
    mine = pm.Locator(pm.load_model(cell_data.library / "No.3.npz"), rig)(
        pm.read_image(scene / "right.png"), pm.read_image(scene / "left.png"), rng=7)
    assert answer["found"] and mine.found
    np.testing.assert_allclose(answer["T_cam1_model"], mine.T_cam1_model, atol=1e-9)
    # the frame: its time (within a frame of the request), its number, the source
    assert t_before - 1 / 30 - 0.01 <= answer["frame_t_s"] <= time.time()
    assert answer["pose_stamped"]["header"]["stamp"] == pytest.approx(answer["frame_t_s"])
    assert answer["source"] == f"replay:{camera_service.cell.source.health()['folder']}"
    assert answer["frame_skew_ms"] == 0.0 and answer["grab_seconds"] >= 0.0
    assert isinstance(answer["frame_index"], int)
    # kept with its pair: the overlay and the answer again
    overlay = httpx.get(f"{url}/results/{answer['id']}/overlay.png")
    assert overlay.status_code == 200 and overlay.content[:4] == b"\x89PNG"
    again = httpx.get(f"{url}/results/{answer['id']}").json()
    assert again["frame_t_s"] == answer["frame_t_s"]
    # a later trigger: a later frame
    later = httpx.post(f"{url}/trigger/locate", data={"model": "No.3"}, timeout=TIMEOUT_S)
    assert later.json()["frame_index"] > answer["frame_index"]
    metrics = httpx.get(f"{url}/metrics").text
    assert 'endpoint="/trigger/locate",method="POST",status="200"' in metrics


def test_trigger_identify_names_the_garment_in_view(camera_service) -> None:
    answer = httpx.post(f"{camera_service.url}/trigger/identify",
                        files={"seed": (None, "1")}, timeout=TIMEOUT_S)   # multipart fields
    assert answer.status_code == 200, answer.text
    body = answer.json()
    assert body["model"] == "No.3" and body["found"]
    assert {"frame_t_s", "frame_index", "source", "id", "pose_stamped"} <= set(body)
    assert httpx.get(f"{camera_service.url}/results/{body['id']}/overlay.png").status_code == 200


def test_bad_trigger_requests_are_4xx_with_a_json_error(camera_service) -> None:
    url = camera_service.url
    _error(httpx.post(f"{url}/trigger/locate"), 400, "model", "missing field")
    _error(httpx.post(f"{url}/trigger/locate", params={"model": "nope"}), 404, "nope")
    _error(httpx.post(f"{url}/trigger/locate", params={"model": "No.3", "seed": "-4"}), 400,
           "seed")
    _error(httpx.post(f"{url}/trigger/locate", params={"model": "No.3"},
                      data={"model": "No.5"}), 400, "model", "twice")
    _error(httpx.post(f"{url}/trigger/locate", json={"model": "No.3"}), 400, "form")
    _error(httpx.post(f"{url}/trigger/locate", params={"model": "No.3"},
                      content=b"x" * (65 << 10),
                      headers={"content-type": "application/x-www-form-urlencoded"}), 413)
    _error(httpx.get(f"{url}/trigger/locate"), 405)
    _error(httpx.post(f"{url}/trigger/identify", params={"seed": "x"}), 400, "seed")
    for frames in ("0", "10001", "many", ""):
        _error(httpx.post(f"{url}/record", params={"frames": frames}), 400, "frames")
    assert httpx.get(f"{url}/health").json()["status"] == "ok"


def test_without_a_source_triggers_are_409(camera_service) -> None:
    cell = camera_service.cell
    link, cell.source = cell.source, None
    try:
        _error(httpx.post(f"{camera_service.url}/trigger/locate", params={"model": "No.3"}),
               409, "no camera source", "--source")
        _error(httpx.post(f"{camera_service.url}/trigger/identify"), 409, "--source")
        _error(httpx.post(f"{camera_service.url}/record", params={"frames": "1"}), 409,
               "--source")
        assert httpx.get(f"{camera_service.url}/health").json()["source"] is None
    finally:
        cell.source = link


def test_a_recording_replays_and_calibrates(camera_service, cell_data) -> None:
    from photomodel.calibrate._views import list_pairs

    answer = httpx.post(f"{camera_service.url}/record", params={"frames": "3"},
                        timeout=TIMEOUT_S)
    assert answer.status_code == 201, answer.text
    body = answer.json()
    folder = Path(body["path"])
    assert body["frames"] == 3 and folder.parent == camera_service.cell.recorder.root
    assert [p.name for p in sorted(folder.iterdir())] == [
        "000000", "000001", "000002", "meta.json", "stereo.yaml"]
    assert not [p for p in folder.parent.iterdir() if p.name.startswith(".")]   # no temp
    meta = json.loads((folder / "meta.json").read_text())
    assert meta["fps"] == pytest.approx(body["fps"]) and 0 < meta["fps"] <= 31
    assert [f["t_s"] for f in meta["frames"].values()][0] == 0.0
    scene = cell_data.scene_of("No.3")
    assert (cv2.imread(str(folder / "000001" / "left.png")) ==
            cv2.imread(str(scene / "left.png"))).all()                # lossless
    # replay reads it back, calibrate takes its layout
    replayed = open_source(f"replay:{folder}", pm.load_stereo(folder / "stereo.yaml"))
    assert replayed.fps == pytest.approx(meta["fps"])
    assert (replayed.grab(1.0).right_bgr == cv2.imread(str(scene / "right.png"))).all()
    assert [name for name, *_ in list_pairs(folder)] == ["000000", "000001", "000002"]


def test_sim_source_finds_the_garment_where_the_simulator_put_it(camera_service,
                                                                  replay_dir) -> None:
    cell = camera_service.cell
    with _source(cell, "sim:No.3", replay_dir):
        answer = httpx.post(f"{camera_service.url}/trigger/locate",
                            params={"model": "No.3", "seed": "3"}, timeout=TIMEOUT_S).json()
        truth = cell.source.current.source.last_T_cam1_model
    assert answer["found"] and answer["source"] == "sim:No.3", answer
    assert np.linalg.norm(np.array(answer["position_mm"]) - truth[:3, 3]) < 5.0


def test_a_removed_replay_folder_degrades_health_until_it_is_back(camera_service,
                                                                   replay_dir) -> None:
    url = camera_service.url
    away = replay_dir.with_name("away")
    replay_dir.rename(away)
    try:
        error = _error(httpx.post(f"{url}/trigger/locate", params={"model": "No.3"},
                                  timeout=TIMEOUT_S), 503, "cannot be read", "re-opening")
        health = httpx.get(f"{url}/health").json()
        assert health["status"] == "degraded" and "stopped" in health["detail"]
        assert health["source"]["state"] == "down" and health["source"]["stops"] >= 1
        assert {"models", "version", "searches", "prepared"} <= set(health)
        response = httpx.post(f"{url}/trigger/identify", timeout=TIMEOUT_S)
        _error(response, 503, "stopped")
        assert response.headers["retry-after"] == "5"
        _error(httpx.post(f"{url}/record", params={"frames": "1"}), 503, "stopped")
        assert error
    finally:
        away.rename(replay_dir)
    assert _wait_for(lambda: httpx.get(f"{url}/health").json()["status"] == "ok")
    assert httpx.get(f"{url}/health").json()["source"]["reopened"] >= 1
    answer = httpx.post(f"{url}/trigger/locate", params={"model": "No.3"}, timeout=TIMEOUT_S)
    assert answer.status_code == 200 and answer.json()["found"]


def test_a_video_that_ends_degrades_health_then_plays_again(camera_service, replay_dir,
                                                            tmp_path: Path) -> None:
    url = camera_service.url
    right, left = _video(tmp_path / "r.avi", 2), _video(tmp_path / "l.avi", 2)
    with _source(camera_service.cell, f"opencv:{right},{left}", replay_dir):
        for k in range(2):       # plain frames: nothing found, but answered
            answer = httpx.post(f"{url}/trigger/identify", timeout=TIMEOUT_S)
            assert answer.status_code == 200 and answer.json()["frame_index"] == k
        _error(httpx.post(f"{url}/trigger/identify", timeout=TIMEOUT_S), 503,
               "end of the video")
        assert httpx.get(f"{url}/health").json()["status"] == "degraded"
        assert _wait_for(lambda: httpx.get(f"{url}/health").json()["status"] == "ok")
        answer = httpx.post(f"{url}/trigger/identify", timeout=TIMEOUT_S)   # from its start
        assert answer.status_code == 200 and answer.json()["frame_index"] == 0


def test_unsynchronised_cameras_are_refused_and_the_source_goes_on(camera_service,
                                                                    replay_dir,
                                                                    tmp_path: Path) -> None:
    url = camera_service.url
    right, left = _video(tmp_path / "r.avi", 3, fps=30.0), _video(tmp_path / "l.avi", 3,
                                                                  fps=20.0)
    with _source(camera_service.cell, f"opencv:{right},{left}", replay_dir):
        assert httpx.post(f"{url}/trigger/identify", timeout=TIMEOUT_S).status_code == 200
        _error(httpx.post(f"{url}/trigger/identify", timeout=TIMEOUT_S), 503,
               "unsynchronised cameras", "16.7 ms apart", "--max-skew-ms 5")
        health = httpx.get(f"{url}/health").json()
        assert health["status"] == "ok" and health["source"]["refused"] == 1


@pytest.mark.parametrize(("source", "mention"), [
    ("usb:0", "--source: unknown kind 'usb'"),
    ("opencv:97,98", "--source: opencv: camera 1 (right) '97': cannot open this device"),
    ("replay:nowhere", "no such folder"),
])
def test_serve_refuses_a_source_it_cannot_open_in_one_line(capsys, cell_data, tmp_path: Path,
                                                           source: str, mention: str) -> None:
    code = main(["serve", "--stereo", str(cell_data.stereo), "--models",
                 str(tmp_path / "lib"), "--source", source])
    err = capsys.readouterr().err
    assert code == 2 and mention in err, err
    assert err.count("\n") == 1 and err.startswith("photomodel: error: ")
    assert "Traceback" not in err


def test_a_trigger_through_two_genicam_cameras(camera_service, replay_dir) -> None:
    """The genicam package's simulated producer (viky.cti); its free-running cameras are up
    to a frame (50 ms) apart, so the bound is raised for them."""
    pytest.importorskip("harvesters")
    genicam = pytest.importorskip("genicam")
    cti = Path(genicam.__file__).with_name("viky.cti")
    if not cti.is_file():
        pytest.skip("this genicam package ships no viky.cti")
    cell = camera_service.cell
    spec = f"genicam:VikyTL_DEV_red,VikyTL_DEV_green,cti={cti}"
    with _source(cell, lambda: open_source(spec, cell.rig, max_skew_ms=60.0), replay_dir):
        answer = httpx.post(f"{camera_service.url}/trigger/identify", timeout=TIMEOUT_S)
        assert answer.status_code == 200, answer.text
        assert answer.json()["source"] == spec and answer.json()["model"] is None
        assert cell.health()["source"]["kind"] == "genicam"
