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


def test_the_newest_frame_wins_and_drops_are_counted(service, cell_data, monkeypatch) -> None:
    import time

    from photomodel.track import Tracker

    track = Tracker.__call__

    def slow(self, *args, **kwargs):  # type: ignore[no-untyped-def]
        time.sleep(0.05)              # slower than the client sends, however loaded the CPU
        return track(self, *args, **kwargs)

    monkeypatch.setattr(Tracker, "__call__", slow)
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



def _answer(ws) -> dict:  # type: ignore[no-untyped-def]
    return json.loads(ws.recv(timeout=60))


def _lying(message: bytes, right_bytes: int = 0, left_bytes: int | None = None,
           header_bytes: int = 0) -> bytes:
    """``message`` whose header claims ``right_bytes`` more for camera 1 and ``left_bytes``
    (default: as many) fewer for camera 2, and whose length prefix ``header_bytes`` more."""
    n = int.from_bytes(message[:4], "big")
    header = json.loads(message[4:4 + n])
    header["right_bytes"] += right_bytes
    header["left_bytes"] -= right_bytes if left_bytes is None else left_bytes
    head = json.dumps(header).encode()
    return (len(head) + header_bytes).to_bytes(4, "big") + head + message[4 + n:]


def test_bad_input_mid_stream_is_answered_and_tracking_goes_on(service, cell_data) -> None:
    """Another size, a corrupt PNG, a header that lies about its lengths and a text message
    that is not JSON: each one answer with the error, the tracker left as it was."""
    right, left = _pair(cell_data)
    image = cv2.imread(str(cell_data.scene_of("No.3") / "right.png"))
    half = cv2.imencode(".png", cv2.resize(image, (320, 240)))[1].tobytes()
    corrupt = right[:64] + bytes(range(256)) * 8               # PNG signature, then garbage
    small = cv2.resize(image, (320, 240))
    with _ws(service) as ws:
        ws.send(encode_frame(right, left, t_s=0.0))
        assert _answer(ws)["mode"] == "detect"
        bad_frames = [
            (encode_frame(half, half, t_s=0.1), "right image: image is 320x240 px"),
            (encode_frame(corrupt, left, t_s=0.2), "right image"),
            (_lying(encode_frame(right, left, t_s=0.3), right_bytes=10), "left image"),
            (_lying(encode_frame(right, left, t_s=0.3), right_bytes=100, left_bytes=0),
             "do not match"),
            (_lying(encode_frame(right, left, t_s=0.3), header_bytes=5000), "header length"),
            (encode_frame(small.tobytes(), small.tobytes(), t_s=0.3, shape=small.shape),
             "right image: image is 320x240 px")]
        for k, (message, match) in enumerate(bad_frames):
            ws.send(message)
            got = _answer(ws)
            assert match in got["error"], got
            assert got["received"] == 2 + k and set(got) == {"error", "received", "dropped"}
        ws.send("not json")
        got = _answer(ws)
        assert got["error"].startswith("text message: expected") and "not json" in got["error"]
        ws.send(json.dumps({"stop": True}))
        assert "text message" in _answer(ws)["error"]
        ws.send(encode_frame(right, left, t_s=0.4))
        good = _answer(ws)
        assert good["mode"] == "track" and good["found"]       # not restarted by the errors
        assert good["received"] == 2 + len(bad_frames) and good["dropped"] == 0
    metrics = httpx.get(f"{service.url}/metrics").text  # type: ignore[attr-defined]
    assert 'photomodel_track_frames_total{outcome="bad"}' in metrics


def test_a_time_that_goes_back_restarts_the_tracking_with_a_note(service, cell_data) -> None:
    """As the Tracker documents it: not an error, the frame is detected afresh."""
    right, left = _pair(cell_data)
    with _ws(service) as ws:
        modes = []
        for t_s in (1.0, 1.1, 0.5):
            ws.send(encode_frame(right, left, t_s=t_s))
            modes.append(_answer(ws))
    assert [a["mode"] for a in modes] == ["detect", "track", "detect"]
    assert "does not advance" in modes[2]["note"] and "error" not in modes[2]
    assert modes[2]["t_s"] == pytest.approx(0.5)


def test_a_reset_is_not_cancelled_by_a_later_text_message(service, cell_data) -> None:
    right, left = _pair(cell_data)
    with _ws(service) as ws:
        ws.send(encode_frame(right, left, t_s=0.0))
        assert _answer(ws)["mode"] == "detect"
        ws.send(json.dumps({"reset": True}))
        ws.send(json.dumps({"reset": False}))
        ws.send(encode_frame(right, left, t_s=0.1))
        assert _answer(ws)["mode"] == "detect"

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
        answer = None
        try:
            with connect(url, open_timeout=30,
                         additional_headers={"Authorization": f"Bearer {token}"}) as ws:
                # let in (no 403), then refused by the cell, which is never warmed here, with
                # its reason and close code 1008; a frame sent meanwhile could meet the
                # closed socket and reset the connection, so none is sent
                answer = json.loads(ws.recv(timeout=60))
        except ConnectionClosed:      # the 1008 close, when it comes before the client's own
            pass
        assert answer is not None and "warming" in answer["error"]


def test_answers_on_demand_never_pile_up_behind_a_slow_reader(service, cell_data) -> None:
    """With ``credit=1`` the server answers only when asked: frames sent meanwhile are
    tracked (the newest wins), only the latest answer is kept, so the next answer is about
    the newest frame."""
    right, left = _pair(cell_data)
    sent = 10
    with _ws(service, "model=No.3&credit=1") as ws:
        ws.send(encode_frame(right, left, t_s=0.0))
        first = _answer(ws)
        assert first["mode"] == "detect" and first["received"] == 1
        for k in range(1, sent):
            ws.send(encode_frame(right, left, t_s=k / 60))
        with pytest.raises(TimeoutError):
            ws.recv(timeout=3)                      # nothing asked for, nothing sent
        ws.send(json.dumps({"credit": 1}))
        second = _answer(ws)
        assert second["received"] == sent and second["mode"] == "track"
        # every frame is accounted for: answered, dropped unseen, or tracked and superseded
        assert 2 + second["dropped"] + second["superseded"] == sent
        assert second["t_s"] == pytest.approx((sent - 1) / 60)   # the newest frame's
        ws.send(json.dumps({"credit": 0}))
        assert "credit: expected a count from 1" in _answer(ws)["error"]


def test_a_bad_credit_is_refused_with_the_reason(service) -> None:
    with _ws(service, "model=No.3&credit=many") as ws:
        doc = json.loads(ws.recv(timeout=30))
        assert "credit: expected a count from 0" in doc["error"]
        with pytest.raises(ConnectionClosed):
            ws.recv(timeout=30)
