"""Stream a stereo sequence to a photomodel cell service's /track WebSocket and print one pose
per frame (needs the `websockets` package, which the service installs).

usage: python track_client.py [--credit] URL MODEL FRAMES_DIR [FPS]   (token: $PHOTOMODEL_TOKEN)

An https:// URL streams over wss://, checked against the system's CAs or the CA file in
$PHOTOMODEL_CA.

FRAMES_DIR holds one folder per frame with right.png and left.png (``photomodel simulate
--sequences``, or ``POST /record``); frames are sent at FPS (default 30) with their times, as a
camera would, without waiting for the answers: when the service is slower, it drops frames
(the newest wins) and says how many.

--credit: answers on demand (``/track?model=NAME&credit=1``): the service sends an answer only
when asked, and the reader asks for the next one (``{"credit": 1}``) after each it has handled,
so a reader slower than the camera always gets the pose of the newest frame, never a backlog of
old answers (the frames in between are dropped and counted).
"""

from __future__ import annotations

import json
import os
import ssl
import struct
import sys
import threading
import time
from pathlib import Path

from websockets.exceptions import ConnectionClosed
from websockets.sync.client import connect


def frame_message(right: bytes, left: bytes, t_s: float) -> bytes:
    """One /track frame: 4-byte big-endian header length, the JSON header, both PNG files."""
    header = json.dumps({"right_bytes": len(right), "left_bytes": len(left), "t_s": t_s,
                         "encoding": "png"}).encode()
    return struct.pack(">I", len(header)) + header + right + left


def stream(url: str, model: str, frames: list[Path], fps: float,
           credit: bool = False) -> list[dict]:
    """Send every frame at ``fps`` and collect the answers (one per frame tracked; with
    ``credit``, one per answer asked for)."""
    headers = {}
    if token := os.environ.get("PHOTOMODEL_TOKEN"):
        headers["Authorization"] = f"Bearer {token}"
    ws_url = url.replace("http://", "ws://").replace("https://", "wss://").rstrip("/")
    answers: list[dict] = []
    # compression=None: PNG frames do not deflate, and deflating 0.9 MB a frame takes the
    # client about 20 ms, more than a 60 fps frame's time
    query = f"model={model}" + ("&credit=1" if credit else "")
    context = (ssl.create_default_context(cafile=os.environ.get("PHOTOMODEL_CA") or None)
               if ws_url.startswith("wss://") else None)
    with connect(f"{ws_url}/track?{query}", additional_headers=headers, ssl=context,
                 max_size=2**25, compression=None) as ws:
        def read() -> None:
            for text in ws:
                answer = json.loads(text)
                answers.append(answer)
                if "error" in answer:
                    print(f"error: {answer['error']}", file=sys.stderr)
                elif answer["mode"] == "lost":
                    print(f"frame {answer['frame']}: lost ({answer['dropped']} dropped)")
                else:
                    x, y, z = answer["position_mm"]
                    print(f"frame {answer['frame']}: {answer['mode']} x={x:.1f} y={y:.1f} "
                          f"z={z:.1f} mm theta={answer['theta_deg']:.2f} deg "
                          f"({answer['dropped']} dropped)")
                if credit:   # handled: ask for the next answer (send is safe from this thread)
                    try:
                        ws.send(json.dumps({"credit": 1}))
                    except ConnectionClosed:    # the stream is over
                        return

        reader = threading.Thread(target=read, daemon=True)
        reader.start()
        t0 = time.monotonic()
        for k, folder in enumerate(frames):
            time.sleep(max(0.0, t0 + k / fps - time.monotonic()))
            ws.send(frame_message((folder / "right.png").read_bytes(),
                                  (folder / "left.png").read_bytes(), k / fps))
        deadline = time.monotonic() + 30
        while time.monotonic() < deadline and (
                not answers or len(answers) + answers[-1].get("dropped", 0) < len(frames)):
            time.sleep(0.05)
    return answers


def main(argv: list[str]) -> int:
    credit = "--credit" in argv
    argv = [a for a in argv if a != "--credit"]
    if len(argv) not in (3, 4):
        print(__doc__.strip().splitlines()[2], file=sys.stderr)
        return 2
    url, model, folder = argv[0], argv[1], Path(argv[2])
    frames = sorted(p for p in folder.iterdir() if (p / "right.png").exists())
    if not frames:
        print(f"error: {folder}: no frames (folders with right.png and left.png)",
              file=sys.stderr)
        return 2
    try:
        answers = stream(url, model, frames, float(argv[3]) if len(argv) == 4 else 30.0,
                         credit)
    except OSError as exc:
        print(f"error: {url}: {exc}", file=sys.stderr)
        return 1
    return 1 if not answers or "error" in answers[0] else 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
