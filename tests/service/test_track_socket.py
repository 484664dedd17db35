"""The /track WebSocket: a stereo stream in, one pose per frame out, the newest frame wins."""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import httpx
import numpy as np
import pytest
from websockets.exceptions import ConnectionClosed, InvalidStatus
from websockets.sync.client import connect

from photomodel.errors import InputError
from photomodel.service._track_socket import decode_frame, encode_frame


def _ws(service: object, query: str = "model=No.3", **kwargs: object):  # type: ignore[no-untyped-def]
    url = service.url.replace("http://", "ws://")  # type: ignore[attr-defined]
    return connect(f"{url}/track?{query}", max_size=2**25, open_timeout=30, **kwargs)


def _pair(cell_data, garment: str = "No.3") -> tuple[bytes, bytes]:  # type: ignore[no-untyped-def]
    scene = cell_data.scene_of(garment)
    return (scene / "right.png").read_bytes(), (scene / "left.png").read_bytes()


def test_frames_are_detected_then_tracked_with_a_stamped_pose(service, cell_data) -> None:
    right, left = _pair(cell_data)
    with _ws(service) as ws:
        answers = []
        for k in range(4):
            ws.send(encode_frame(right, left, t_s=k / 30))
            answers.append(json.loads(ws.recv(timeout=60)))
    assert [a["mode"] for a in answers] == ["detect", "track", "track", "track"]
    assert all(a["found"] and a["pose_stamped"] is not None for a in answers)
    assert [a["received"] for a in answers] == [1, 2, 3, 4]
    assert answers[-1]["dropped"] == 0 and answers[-1]["t_s"] == pytest.approx(0.1)
    assert len(answers[-1]["T_cam1_model"]) == 4


def test_the_newest_frame_wins_and_drops_are_counted(service, cell_data) -> None:
    right, left = _pair(cell_data)
    sent = 12
    with _ws(service) as ws:
        for k in range(sent):
            ws.send(encode_frame(right, left, t_s=k / 60))
        answers: list[dict] = []
        while not answers or len(answers) + answers[-1]["dropped"] < sent:
            answers.append(json.loads(ws.recv(timeout=60)))
    last = answers[-1]
    assert last["received"] == sent and last["dropped"] > 0
    assert len(answers) + last["dropped"] == sent          # every frame answered or dropped
    metrics = httpx.get(f"{service.url}/metrics").text  # type: ignore[attr-defined]
    assert 'photomodel_track_frames_total{outcome="dropped"}' in metrics


def test_a_bad_frame_is_answered_with_an_error_and_the_stream_goes_on(service, cell_data
                                                                      ) -> None:
    right, left = _pair(cell_data)
    with _ws(service) as ws:
        ws.send(b"\x00\x00")
        bad = json.loads(ws.recv(timeout=60))
        assert "error" in bad and "frame" in bad["error"]
        ws.send(encode_frame(b"not a png", left))
        assert "right image" in json.loads(ws.recv(timeout=60))["error"]
        ws.send(encode_frame(right, left, t_s=0.0))
        good = json.loads(ws.recv(timeout=60))
        assert good["mode"] == "detect" and good["received"] == 3
        ws.send(json.dumps({"reset": True}))
        ws.send(encode_frame(right, left, t_s=1.0))
        assert json.loads(ws.recv(timeout=60))["mode"] == "detect"   # started over


def test_raw_pixels_are_taken_too(service, cell_data) -> None:
    scene = cell_data.scene_of("No.3")
    right = cv2.imread(str(scene / "right.png"))
    left = cv2.imread(str(scene / "left.png"))
    with _ws(service) as ws:
        ws.send(encode_frame(right.tobytes(), left.tobytes(), shape=right.shape))
        assert json.loads(ws.recv(timeout=60))["found"]


def test_an_unknown_model_is_refused_with_the_reason(service) -> None:
    with _ws(service, "model=nope") as ws:
        assert "no model named 'nope'" in json.loads(ws.recv(timeout=30))["error"]
        with pytest.raises(ConnectionClosed):
            ws.recv(timeout=30)
        assert ws.close_code == 1008


def test_frame_messages_are_checked() -> None:
    png = cv2.imencode(".png", np.zeros((4, 5, 3), np.uint8))[1].tobytes()
    right, left, t = decode_frame(encode_frame(png, png, t_s=0.5))
    assert right.shape == (4, 5, 3) and t == 0.5
    raw = np.arange(60, dtype=np.uint8).reshape(4, 5, 3)
    r, _, t = decode_frame(encode_frame(raw.tobytes(), raw.tobytes(), shape=raw.shape))
    assert np.array_equal(r, raw) and t is None
    message = encode_frame(png, png)
    for bad, match in ((message[:2], "4-byte"), (message[:-1], "do not match"),
                       (b"\x00\x00\x00\x02{}" + png, "right_bytes"),
                       (encode_frame(raw.tobytes(), raw.tobytes()[:-3], shape=raw.shape),
                        "take 60 bytes"),
                       (encode_frame(png, png, t_s=float("inf")), "t_s")):
        with pytest.raises(InputError, match=match):
            decode_frame(bad)


def test_a_token_guards_the_stream(cell_data, tmp_path: Path) -> None:
    from photomodel.service import CellService, ServiceConfig, ServiceThread

    token = "stream-token-1234567"
    cell = CellService(ServiceConfig(stereo=cell_data.stereo, models=cell_data.library,
                                     token=token))
    with ServiceThread(cell, warm=False) as running:
        url = running.url.replace("http://", "ws://") + "/track?model=No.3"
        with pytest.raises(InvalidStatus):
            connect(url, open_timeout=30).close()
        with connect(url, open_timeout=30,
                     additional_headers={"Authorization": f"Bearer {token}"}) as ws:
            ws.send(b"\x00")
            assert "error" in json.loads(ws.recv(timeout=60))
