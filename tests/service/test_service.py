"""The cell service over real HTTP: a uvicorn server on a free loopback port, an httpx client.

Poses equal the in-process API's for the same pair and seed; a registration is used by the
next request; every bad request is a 4xx with a JSON error and the service stays up.
"""

from __future__ import annotations

import json
import threading
from pathlib import Path

import cv2
import httpx
import numpy as np
import pytest
from service_helpers import json_error as _error

import photomodel as pm
from photomodel.service import CellService, ServiceConfig, ServiceThread

TIMEOUT_S = 120.0


def _pair(scene: Path) -> dict[str, tuple[str, bytes, str]]:
    return {side: (f"{side}.png", (scene / f"{side}.png").read_bytes(), "image/png")
            for side in ("right", "left")}


def _locate(url: str, model: str, scene: Path, seed: int | None = 1, **kw: object
            ) -> httpx.Response:
    data = {"model": model} | ({} if seed is None else {"seed": str(seed)})
    return httpx.post(f"{url}/locate", data=data, files=_pair(scene), timeout=TIMEOUT_S, **kw)




def test_health_and_models(service, cell_data) -> None:
    health = httpx.get(f"{service.url}/health").json()
    assert health["status"] == "ok" and health["models"] == 1
    assert health["version"] == pm.__version__
    assert health["prepared"] == 1 and health["prepared_max"] == 32   # a small library: all
    models = httpx.get(f"{service.url}/models").json()
    assert [m["name"] for m in models] == ["No.3"]
    assert {"size_mm", "area_mm2", "colours", "n_in", "n_out", "preview"} <= set(models[0])
    png = httpx.get(f"{service.url}/{models[0]['preview']}")
    assert png.status_code == 200 and png.content[:8] == b"\x89PNG\r\n\x1a\n"


def test_locate_equals_the_in_process_api(service, cell_data) -> None:
    scene = cell_data.scene_of("No.3")
    answer = _locate(service.url, "No.3", scene, seed=7).json()
    rig = pm.load_stereo(cell_data.stereo)
    locator = pm.Locator(pm.load_model(cell_data.library / "No.3.npz"), rig)
    mine = locator(pm.read_image(scene / "right.png"), pm.read_image(scene / "left.png"), rng=7)
    assert answer["found"] and mine.found
    np.testing.assert_allclose(answer["T_cam1_model"], mine.T_cam1_model, atol=1e-9)
    assert answer["score"] == pytest.approx(mine.score, abs=1e-12)
    truth = np.array(cell_data.truth[scene.name]["T_cam1_model"])
    assert np.linalg.norm(np.array(answer["position_mm"]) - truth[:3, 3]) < 5.0
    # the ROS-shaped copy: metres and an xyzw quaternion of the same pose
    ps = answer["pose_stamped"]
    assert ps["header"]["frame_id"] == "cam1" and ps["header"]["stamp"] > 1.7e9
    position = ps["pose"]["position"]
    assert [position[k] * 1000 for k in "xyz"] == pytest.approx(answer["position_mm"])
    q = ps["pose"]["orientation"]
    assert [q["w"], q["x"], q["y"], q["z"]] == pytest.approx(answer["quat_wxyz"])
    # kept with an overlay
    overlay = httpx.get(f"{service.url}/results/{answer['id']}/overlay.png")
    assert overlay.status_code == 200 and overlay.content[:4] == b"\x89PNG"
    assert httpx.get(f"{service.url}/results/{answer['id']}").json()["score"] == answer["score"]


def test_identify(service, cell_data) -> None:
    answer = httpx.post(f"{service.url}/identify", data={"seed": "2"},
                        files=_pair(cell_data.scene_of("No.3")), timeout=TIMEOUT_S).json()
    assert answer["model"] == "No.3" and answer["found"]
    assert answer["pose_stamped"]["header"]["frame_id"] == "cam1"
    assert {"runner_up", "min_score", "candidates", "id"} <= set(answer)
    recent = httpx.get(f"{service.url}/results").json()
    assert recent[0]["id"] == answer["id"] and recent[0]["kind"] == "identify"


def test_identify_every_garment(service, cell_data) -> None:
    answer = httpx.post(f"{service.url}/identify", data={"seed": "2", "all": "true"},
                        files=_pair(cell_data.scene_of("No.3")), timeout=TIMEOUT_S).json()
    assert answer["count"] == 1 and answer["pick_order"] == [0]
    (garment,) = answer["garments"]
    assert garment["model"] == answer["model"] == "No.3" and garment["rank"] == 0
    assert garment["covered_by"] == [] and garment["visible_fraction"] > 0.9
    assert answer["pose_stamped"]["header"]["frame_id"] == "cam1"
    overlay = httpx.get(f"{service.url}/results/{answer['id']}/overlay.png")
    assert overlay.status_code == 200 and overlay.content[:4] == b"\x89PNG"
    # a garment not in the library (No.5 is registered by a later test): none; a bad value of
    # all: one line naming the field
    empty = cell_data.scene_of("No.5")
    none = httpx.post(f"{service.url}/identify", data={"all": "1"}, files=_pair(empty),
                      timeout=TIMEOUT_S).json()
    assert none["count"] == 0 and none["model"] is None and none["pose_stamped"] is None
    _error(httpx.post(f"{service.url}/identify", data={"all": "maybe"},
                      files=_pair(empty), timeout=TIMEOUT_S), 400, "all")


def test_a_registration_is_used_by_the_next_request(service, cell_data) -> None:
    photo, background = cell_data.photos("No.5")
    scene = cell_data.scene_of("No.5")
    _error(_locate(service.url, "No.5", scene), 404, "No.5")
    files = {"photo": ("photo.bmp", photo.read_bytes(), "image/bmp"),
             "background": ("background.bmp", background.read_bytes(), "image/bmp")}
    created = httpx.post(f"{service.url}/models", data={"name": "No.5"}, files=files,
                         timeout=TIMEOUT_S)
    assert created.status_code == 201, created.text
    assert created.json()["name"] == "No.5"
    assert (service.cell.library.root / "No.5.npz").is_file()
    assert "No.5" in json.loads((service.cell.library.root / "index.json").read_text())["models"]
    answer = _locate(service.url, "No.5", scene).json()
    assert answer["found"], answer
    identified = httpx.post(f"{service.url}/identify", files=_pair(scene), data={"seed": "1"},
                            timeout=TIMEOUT_S).json()
    assert identified["model"] == "No.5"
    # the same name again: a conflict, unless replacing
    _error(httpx.post(f"{service.url}/models", data={"name": "No.5"}, files=files,
                      timeout=TIMEOUT_S), 409, "No.5", "replace")
    again = httpx.post(f"{service.url}/models", data={"name": "No.5", "replace": "true"},
                       files=files, timeout=TIMEOUT_S)
    assert again.status_code == 201, again.text
    # and removed: gone from memory and the library
    assert httpx.delete(f"{service.url}/models/No.5").status_code == 200
    _error(_locate(service.url, "No.5", scene), 404)
    _error(httpx.delete(f"{service.url}/models/No.5"), 404)
    assert not (service.cell.library.root / "No.5.npz").exists()
    assert [m["name"] for m in httpx.get(f"{service.url}/models").json()] == ["No.3"]


def test_bad_requests_are_4xx_with_a_json_error(service, cell_data, tmp_path: Path) -> None:
    url = service.url
    scene = cell_data.scene_of("No.3")
    pair = _pair(scene)
    text = ("right.png", b"not an image", "image/png")
    _error(httpx.post(f"{url}/locate", data={"model": "No.3"},
                      files={**pair, "right": text}), 400, "right", "not a readable image")
    _error(httpx.post(f"{url}/locate", data={"model": "No.3"}, files={"right": pair["right"]}),
           400, "left", "missing file")
    _error(httpx.post(f"{url}/locate", files=pair), 400, "model", "missing field")
    _error(httpx.post(f"{url}/locate", json={"model": "No.3"}), 400, "multipart")
    _error(httpx.post(f"{url}/locate", content=b"--x\r\ngarbage",
                      headers={"content-type": "multipart/form-data; boundary=x"}), 400)
    _error(httpx.post(f"{url}/locate", data={"model": "No.3", "seed": "-1"}, files=pair), 400,
           "seed")
    half = cv2.imencode(".png", cv2.imread(str(scene / "left.png"))[::2, ::2])[1].tobytes()
    _error(httpx.post(f"{url}/locate", data={"model": "No.3"},
                      files={"right": pair["right"], "left": ("l.png", half, "image/png")}),
           400, "left", "calibration")
    _error(httpx.get(f"{url}/results/0123456789abcdef/overlay.png"), 404, "result")
    _error(httpx.get(f"{url}/results/nope"), 404)
    _error(httpx.get(f"{url}/models/nope/preview.png"), 404, "nope")
    _error(httpx.get(f"{url}/no/such/page"), 404)
    _error(httpx.put(f"{url}/locate"), 405)
    photo, background = cell_data.photos("No.5")
    files = {"photo": ("p.bmp", photo.read_bytes(), "image/bmp"),
             "background": ("b.bmp", background.read_bytes(), "image/bmp")}
    for name in ("bad/name", "two\nlines", ".hidden", ""):
        _error(httpx.post(f"{url}/models", data={"name": name}, files=files), 400, "name")
    _error(httpx.post(f"{url}/models", data={"name": "x", "distance_mm": "inf"}, files=files),
           400, "distance_mm")
    small = cv2.imencode(".png", cv2.imread(str(background))[::2, ::2])[1].tobytes()
    _error(httpx.post(f"{url}/models", data={"name": "x"},
                      files={**files, "background": ("b.png", small, "image/png")}), 400,
           "background")
    # bigger than the bound: refused before it is read whole
    big = b"\0" * (service.cell.config.max_upload_bytes + 1)
    _error(httpx.post(f"{url}/locate", data={"model": "No.3"},
                      files={**pair, "right": ("r.png", big, "image/png")}), 413, "MiB")
    assert httpx.get(f"{url}/health").json()["status"] == "ok"   # still serving
    metrics = httpx.get(f"{url}/metrics").text
    assert 'photomodel_requests_total{endpoint="/locate",method="POST",status="400"}' in metrics
    assert "photomodel_request_seconds_bucket" in metrics


def test_health_answers_while_searches_run(service, cell_data) -> None:
    scene = cell_data.scene_of("No.3")
    done = []

    def search(seed: int) -> None:
        done.append(_locate(service.url, "No.3", scene, seed=seed).status_code)

    threads = [threading.Thread(target=search, args=(k,)) for k in range(4)]
    for t in threads:
        t.start()
    answers = [httpx.get(f"{service.url}/health", timeout=5.0).status_code for _ in range(5)]
    for t in threads:
        t.join()
    assert answers == [200] * 5 and done == [200] * 4


@pytest.fixture(scope="module")
def unwarmed(cell_data, tmp_path_factory):
    """A service whose warm-up never ran, with a token and a ring of two results."""
    token = "s3cret-token-of-cell-7"
    cell = CellService(ServiceConfig(stereo=cell_data.stereo, models=cell_data.library,
                                     token=token, results_kept=2))
    with ServiceThread(cell, warm=False) as running:
        yield running, token


def test_the_token_is_required(unwarmed) -> None:
    running, token = unwarmed
    for headers in ({}, {"Authorization": "Bearer wrong"}, {"Authorization": token},
                    {"Authorization": f"Basic {token}"}, {"Authorization": f"Bearer{token}"}):
        response = httpx.get(f"{running.url}/health", headers=headers)
        _error(response, 401, "token")
        assert response.headers["www-authenticate"] == "Bearer"
    for scheme in ("Bearer", "bearer", "BEARER"):         # RFC 7235: any case
        ok = httpx.get(f"{running.url}/health", headers={"Authorization": f"{scheme} {token}"})
        assert ok.status_code == 200 and ok.json()["status"] == "warming"


def test_a_browser_logs_in_once_with_the_token(unwarmed) -> None:
    running, token = unwarmed
    with httpx.Client(base_url=running.url) as browser:
        first = browser.get("/")
        assert first.status_code == 303 and first.headers["location"] == "login"
        assert "token" in browser.get("/login").text
        assert browser.post("/login", data={"token": "wrong"}).status_code == 401
        _error(browser.get("/health"), 401)
        done = browser.post("/login", data={"token": token})
        assert done.status_code == 303
        cookie = done.headers["set-cookie"].lower()
        assert "httponly" in cookie and "samesite=strict" in cookie
        assert browser.get("/").status_code == 200          # the cookie now opens the page
        assert browser.get("/health").json()["status"] == "warming"


def test_a_warming_service_answers_503(unwarmed, cell_data) -> None:
    running, token = unwarmed
    response = _locate(running.url, "No.3", cell_data.scene_of("No.3"),
                       headers={"Authorization": f"Bearer {token}"})
    _error(response, 503, "warming")
    assert response.headers["retry-after"] == "5"


def test_the_result_ring_is_bounded(unwarmed) -> None:
    running, _ = unwarmed
    ring = running.cell.results
    ids = [ring.add("locate", {"found": False, "score": 0.1}, lambda: b"png").id
           for _ in range(5)]
    assert len(ring) == 2 and [r["id"] for r in ring.recent()] == [ids[4], ids[3]]
    assert ring.get(ids[0]) is None and ring.overlay_png(ids[-1]) == b"png"


def test_serve_refuses_a_public_address_without_a_token(capsys, cell_data, tmp_path) -> None:
    from photomodel.cli import main

    argv = ["serve", "--stereo", str(cell_data.stereo), "--models", str(tmp_path / "lib")]
    assert main([*argv, "--host", "0.0.0.0"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("photomodel: error: --host: binding to 0.0.0.0") and "\n" not in err
    short = tmp_path / "token"
    short.write_text("abc\n")
    assert main([*argv, "--host", "0.0.0.0", "--token-file", str(short)]) == 2
    assert "at least 16" in capsys.readouterr().err
    assert main([*argv, "--port", "70000"]) == 2
    assert "--port: expected an integer from 1 to 65535" in capsys.readouterr().err
    assert not (tmp_path / "lib").exists()
