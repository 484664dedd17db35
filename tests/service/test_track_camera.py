"""/track?source=camera: the service tracks its own camera's pairs and pushes one pose per
pair, the viewers share one grabbing loop, a stopped source is said once and the stream goes
on when it is back, and the live view serves camera 1's picture with the tracked outline."""

from __future__ import annotations

import json
import shutil
import time
from collections.abc import Iterator
from pathlib import Path

import cv2
import httpx
import numpy as np
import pytest
from websockets.exceptions import ConnectionClosed
from websockets.sync.client import connect

from photomodel.service import CellService, ServiceConfig, ServiceThread
from photomodel.service._track_socket import encode_frame

FPS = 10


def _ws(service: ServiceThread, query: str):  # type: ignore[no-untyped-def]
    url = service.url.replace("http://", "ws://")
    return connect(f"{url}/track?{query}", max_size=2**25, open_timeout=30)


def _answer(ws) -> dict:  # type: ignore[no-untyped-def]
    return json.loads(ws.recv(timeout=60))


@pytest.fixture(scope="module")
def sequence(cell_data, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Three pairs of the first No.3 scene at 10 fps (the garment still: detect, then track)."""
    root = tmp_path_factory.mktemp("camera") / "seq"
    for k in range(3):
        shutil.copytree(cell_data.scene_of("No.3"), root / f"{k:06d}")
    (root / "meta.json").write_text(json.dumps({"fps": FPS}))
    return root


@pytest.fixture(scope="module")
def camera_service(cell_data, sequence: Path, tmp_path_factory: pytest.TempPathFactory
                   ) -> Iterator[ServiceThread]:
    library = tmp_path_factory.mktemp("served") / "library"
    shutil.copytree(cell_data.library, library)
    cell = CellService(ServiceConfig(stereo=cell_data.stereo, models=library,
                                     source=f"replay:{sequence}"))
    with ServiceThread(cell) as running:
        running.wait_ready()
        yield running
    cell.close()


def test_poses_arrive_without_frames_sent_detected_then_tracked(camera_service) -> None:
    t_before = time.time()
    with _ws(camera_service, "model=No.3&source=camera") as ws:
        answers = [_answer(ws) for _ in range(4)]
    assert [a["mode"] for a in answers][:2] == ["detect", "track"]
    assert all(a["found"] and a["pose_stamped"] is not None for a in answers)
    indices = [a["frame_index"] for a in answers]
    assert indices == sorted(set(indices))                       # rising
    assert all(a["source"].startswith("replay:") for a in answers)
    assert t_before - 1.0 / FPS <= answers[0]["frame_t_s"] <= time.time()
    for a in answers:
        assert a["pose_stamped"]["header"]["stamp"] == pytest.approx(a["frame_t_s"])
        assert a["t_s"] == pytest.approx(a["frame_t_s"])
    last = answers[-1]
    assert last["received"] == len(answers) + last["dropped"]


def test_credit_and_text_messages_on_a_camera_stream(camera_service, cell_data) -> None:
    with _ws(camera_service, "model=No.3&source=camera&credit=1") as ws:
        first = _answer(ws)
        assert first["mode"] == "detect" and first["superseded"] == 0
        with pytest.raises(TimeoutError):        # no credit left: nothing is sent
            ws.recv(timeout=1.0)
        ws.send(json.dumps({"credit": 1}))
        later = _answer(ws)                      # only the newest answer was kept
        assert later["frame_index"] > first["frame_index"] and later["superseded"] >= 1
        scene = cell_data.scene_of("No.3")
        ws.send(encode_frame((scene / "right.png").read_bytes(),
                             (scene / "left.png").read_bytes()))
        error = _answer(ws)                      # answered at once, free of credit
        assert "camera stream" in error["error"] and "ignored" in error["error"]
        ws.send(json.dumps({"reset": True, "credit": 1}))
        modes = [_answer(ws)["mode"]]            # (the one kept may predate the reset)
        ws.send(json.dumps({"credit": 1}))
        modes.append(_answer(ws)["mode"])
        assert "detect" in modes                 # started over


def test_two_viewers_share_one_grabbing_loop(camera_service) -> None:
    feed = camera_service.cell.feed
    with _ws(camera_service, "model=No.3&source=camera") as a, \
            _ws(camera_service, "model=No.3&source=camera") as b:
        ours = [_answer(a), _answer(b)]
        for _ in range(2):
            ours += [_answer(a), _answer(b)]
        assert feed.running
    # the two streams were handed the same pairs: the same numbers
    assert {x["frame_index"] for x in ours[0::2]} & {x["frame_index"] for x in ours[1::2]}


def test_a_removed_source_is_said_once_and_the_stream_goes_on(camera_service,
                                                               sequence: Path) -> None:
    away = sequence.with_name("away")
    with _ws(camera_service, "model=No.3&source=camera") as ws:
        assert "mode" in _answer(ws)
        sequence.rename(away)
        try:
            answer = _answer(ws)
            while "error" not in answer:         # the pairs grabbed before the removal
                answer = _answer(ws)
            assert answer["source"].startswith("replay:") and "re-opening" in answer["error"]
        finally:
            away.rename(sequence)
        errors = [answer]
        after = _answer(ws)                       # re-opened by the service: poses again
        while "error" in after:
            errors.append(after)
            after = _answer(ws)
        assert len(errors) == 1, errors           # said once, not at every retry
        assert after["found"] and after["frame_index"] >= 0


def test_the_live_view_shows_camera_1_with_the_tracked_outline(camera_service,
                                                               cell_data) -> None:
    url = camera_service.url
    plain = httpx.get(f"{url}/camera/latest.jpg", timeout=30)
    assert plain.status_code == 200 and plain.headers["content-type"] == "image/jpeg"
    bare = cv2.imdecode(np.frombuffer(plain.content, np.uint8), cv2.IMREAD_COLOR)
    assert bare.shape[1] <= 640
    with _ws(camera_service, "model=No.3&source=camera") as ws:
        _answer(ws)
        _answer(ws)
        drawn = httpx.get(f"{url}/camera/latest.jpg", params={"model": "No.3"}, timeout=30)
    assert drawn.status_code == 200
    image = cv2.imdecode(np.frombuffer(drawn.content, np.uint8), cv2.IMREAD_COLOR)
    outline = (image[..., 0] < 80) & (image[..., 1] > 200) & (image[..., 2] > 200)  # yellow
    assert outline.sum() > 200 > ((bare[..., 0] < 80) & (bare[..., 1] > 200)
                                  & (bare[..., 2] > 200)).sum()
    assert httpx.get(f"{url}/camera/latest.jpg", params={"model": "nope"}).status_code == 404
    assert httpx.get(f"{url}/camera/latest.jpg", params={"overlay": "x"}).status_code == 400


def test_without_a_source_the_stream_is_refused(camera_service) -> None:
    cell = camera_service.cell
    link, cell.source = cell.source, None
    try:
        with _ws(camera_service, "model=No.3&source=camera") as ws:
            refused = _answer(ws)
            assert "no camera source" in refused["error"] and "--source" in refused["error"]
            with pytest.raises(ConnectionClosed) as closed:
                ws.recv(timeout=30)
            assert closed.value.rcvd.code == 1008
        assert httpx.get(f"{camera_service.url}/camera/latest.jpg").status_code == 409
    finally:
        cell.source = link
    with _ws(camera_service, "model=No.3&source=usb") as ws:
        assert "source=camera" in _answer(ws)["error"]


def test_the_feed_hands_a_late_stream_the_pairs_it_still_keeps() -> None:
    from photomodel.service._camera_feed import FeedState
    from photomodel.service._source import StereoGrab

    view = np.zeros((2, 2, 3), np.uint8)
    grabs = tuple(StereoGrab(view, view, float(k), float(k), k) for k in (7, 8, 9))
    state = FeedState(10, grabs[-1], 0, None, "replay:x", grabs)   # pairs 8, 9 and 10
    assert state.since(10) == ([], 0)
    kept, lost = state.since(8)
    assert [g.index for g in kept] == [8, 9] and lost == 0
    kept, lost = state.since(5)                                     # 6 and 7 are gone
    assert [g.index for g in kept] == [7, 8, 9] and lost == 2
