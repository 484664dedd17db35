"""The service's faces without uploads, for ``bench_service.py`` (same run, same frames):
the trigger path, raw uploads, the OPC UA ``Locate`` and a camera stream.

Trigger service
---------------
``photomodel serve --source replay:DIR --opcua PORT`` where ``DIR`` holds the benchmark's
scenes of one garment (``--faces-model``, the first garment; ``DIR/<k>/right.png, left.png``,
``meta.json`` ``fps`` :data:`TRIGGER_FPS`), so that every grab shows that garment. On it, one
request at a time, the rows in turn in blocks of 25 (``--faces-requests`` each):

``trigger``  ``POST /trigger/locate?model=G&seed=S``: latency from sending to the decoded
             answer, and the answer's ``grab_seconds`` (the wait for the replay's next frame;
             the replay decodes each file once, as a camera hands over pixels). The figure
             against in-process is the latency less the grab (the issue's), and with it; the
             pose is checked against in-process on the answer's frame (``frame_index``
             modulo the frames) with the same seed.
``raw`` / ``png`` ``POST /locate`` of the benchmark's pairs (each searched for its own garment
             with its own seed), alternately as one ``application/octet-stream`` body of raw BGR
             pixels (fields in the query) and as the multipart PNG upload; poses checked.
``opcua``    an ``asyncua`` client keeps one session, as a PLC does, and calls
             ``PhotomodelVision.Locate(G)`` (no seed: the face seeds its own); round trip from
             the call to its outputs. After each call, untimed, ``GET /results/{ResultId}``
             gives the frame and the grab; the position is compared with in-process on that
             frame (another seed: millimetres, not bits).

HTTP requests go over one keep-alive ``http.client`` connection, as the examples send them.
Every answer is followed at once by the in-process call (``Locator`` in this process, warm)
on the same frame or pair, each side after a 20 ms pause (:data:`SETTLE_S`): on a shared
machine whose speed drifts by tens of per cent over minutes only samples taken side by side
compare, and OpenMP workers still spinning after one side's call would slow the other's. A
row's ratio is its p50 over the p50 of its in-process calls.

Stream service
--------------
``photomodel serve --source replay:SEQ`` where ``SEQ`` is the 60 fps conveyor sequence of
``bench_track_stream.py`` (rendered once into ``--faces-work``), its frames laid out back and
forth from the middle (links to the rendered files), as that benchmark plays them, so the
loop never makes the garment jump. One WebSocket ``/track?model=NAME&source=camera`` for
``--stream-warmup-s`` plus ``--stream-seconds`` (60 s): every answer's ``frame_index``,
``received``, ``dropped`` and age (receipt less ``frame_t_s``, the frame's exposure time).
Dropped frames over the counted seconds: the gaps in ``frame_index`` between answers (pairs the
source produced that the feed never grabbed) plus the stream's own ``dropped`` (pairs it
skipped); resident memory sampled every 0.5 s, growth from the end of the warm-up to the end.
"""

from __future__ import annotations

import asyncio
import json
import os
import shutil
import threading
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any
from urllib.parse import urlencode

import numpy as np

TRIGGER_FPS = 100.0
"""Frame rate of the trigger service's replay (a fast industrial camera)."""
TRIGGER_SEED = 7
TARGET_TRIGGER_RATIO = 1.15
"""Issue: trigger path p50 (less the grab) at most 1.15 x the in-process Locator."""
TARGET_RAW_RATIO = 1.3
"""Issue: raw uploads p50 at most 1.3 x the in-process Locator."""
TARGET_OPCUA_RATIO = 1.3
"""Issue: OPC UA Locate round trip p50 at most 1.3 x the in-process Locator."""
TARGET_STREAM_RSS_GROWTH = 0.05
STREAM_FPS = 60.0
STREAM_GARMENT = "No.6"
"""The stream's garment: a full locate finds No.6 on the belt (see bench_track.py)."""
RSS_PERIOD_S = 0.5


def _log(msg: str) -> None:
    import sys

    print(msg, file=sys.stderr, flush=True)


# ----------------------------------------------------------------------------- data

def trigger_replay(folder: Path, pairs: Sequence[Any], fps: float) -> None:
    """Lay ``pairs`` (bench_service ``Pair``) out as a replay folder, frame ``k`` = pair
    ``k``, at ``fps``; the folder is replaced."""
    if folder.exists():
        shutil.rmtree(folder)
    folder.mkdir(parents=True)
    for k, p in enumerate(pairs):
        frame = folder / f"{k:04d}"
        frame.mkdir()
        (frame / "right.png").write_bytes(p.right)
        (frame / "left.png").write_bytes(p.left)
    (folder / "meta.json").write_text(json.dumps({"fps": fps}))


def back_and_forth(n: int) -> list[int]:
    """Frame order of a loop over ``n`` frames that never jumps: from the middle to the end,
    back to the start, then up to just before the middle (``n // 2 .. n - 1, n - 2 .. 0,
    1 .. n // 2 - 1``); its last frame is next to its first."""
    if n < 2:
        return list(range(n))
    mid = n // 2
    return list(range(mid, n)) + list(range(n - 2, -1, -1)) + list(range(1, mid))


def stream_replay(folder: Path, sequence: Path, names: Sequence[str], fps: float) -> int:
    """A replay folder of the rendered ``sequence``'s frames ``names`` played back and forth
    (:func:`back_and_forth`; symbolic links to the rendered files) at ``fps``; replaced.
    The loop's length in frames."""
    if folder.exists():
        shutil.rmtree(folder)
    folder.mkdir(parents=True)
    order = back_and_forth(len(names))
    for k, j in enumerate(order):
        frame = folder / f"{k:05d}"
        frame.mkdir()
        for side in ("right.png", "left.png"):
            os.symlink((sequence / names[j] / side).resolve(), frame / side)
    (folder / "meta.json").write_text(json.dumps({"fps": fps}))
    return len(order)


# ----------------------------------------------------------------------------- in process

class TriggerBaseline:
    """The in-process side: ``Locator(G)`` on the trigger service's frames with
    :data:`TRIGGER_SEED`, and every benchmark pair's own Locator and seed (the upload rows'
    reference); each call timed and its pose checked against the first call's."""

    def __init__(self, locator: Any, pairs: Sequence[Any], base: Any) -> None:
        self.locator = locator
        self.pairs = list(pairs)
        self.base = base
        self.poses = [self.locator(p.right_bgr, p.left_bgr, rng=TRIGGER_SEED).T_cam1_model
                      for p in self.pairs]

    def frame(self, j: int) -> float:
        """Seconds of one in-process call on trigger frame ``j``."""
        p = self.pairs[j]
        time.sleep(SETTLE_S)
        t0 = time.perf_counter()
        r = self.locator(p.right_bgr, p.left_bgr, rng=TRIGGER_SEED)
        dt = time.perf_counter() - t0
        self._check(r.T_cam1_model, self.poses[j], f"frame {j}")
        return dt

    def pair(self, j: int) -> float:
        """Seconds of one in-process call on benchmark pair ``j`` (its garment and seed)."""
        p = self.base.pairs[j]
        time.sleep(SETTLE_S)
        t0 = time.perf_counter()
        r = self.base.locators[p.model](p.right_bgr, p.left_bgr, rng=p.seed)
        dt = time.perf_counter() - t0
        self._check(r.T_cam1_model, self.base.poses[j], f"pair {j}")
        return dt

    @staticmethod
    def _check(T: Any, reference: Any, what: str) -> None:
        from bench_service import pose_difference

        d = pose_difference(T, reference)
        if d is None or d > 1e-9:
            raise RuntimeError(f"in process: {what} gave another pose ({d})")


def _merge(into: dict[str, Any], part: dict[str, Any]) -> dict[str, Any]:
    """Extend ``into``'s lists with ``part``'s (recursively), add its counts."""
    for key, value in part.items():
        if isinstance(value, list):
            into.setdefault(key, []).extend(value)
        elif isinstance(value, dict):
            _merge(into.setdefault(key, {}), value)
        elif isinstance(value, int) and key == "requests":
            into[key] = into.get(key, 0) + value
        else:
            into[key] = value
    return into


# ----------------------------------------------------------------------------- passes
# Every service answer is followed at once by the in-process call on the same frame or pair
# (``paired_s``): on a shared machine whose speed drifts by tens of per cent over minutes,
# only samples taken side by side compare.

SETTLE_S = 0.02
"""Pause before each timed call, either side: OpenMP's workers spin for some milliseconds
after a parallel region (libgomp's default), and a spinning team of one process slows the
other's call on two cores."""


class _Http:
    """One keep-alive connection of the standard library's ``http.client`` (what the
    examples use, as a robot program would: a light client, so that the rows measure the
    service rather than the client's own parsing)."""

    def __init__(self, url: str) -> None:
        import http.client
        from urllib.parse import urlsplit

        self.conn = http.client.HTTPConnection(urlsplit(url).netloc, timeout=120)

    def post(self, route: str, body: bytes = b"", ctype: str | None = None
             ) -> tuple[int, Any]:
        headers = {"Content-Type": ctype} if ctype else {}
        self.conn.request("POST", route, body, headers)
        r = self.conn.getresponse()
        return r.status, json.loads(r.read())

    def close(self) -> None:
        self.conn.close()


def _post(client: _Http, route: str, errors: list[str], body: bytes = b"",
          ctype: str | None = None) -> tuple[float, Any]:
    """POST ``route``: (seconds, answer), or (nan, None) with the error noted."""
    import http.client

    time.sleep(SETTLE_S)
    t0 = time.perf_counter()
    try:
        status, answer = client.post(route, body, ctype)
    except (OSError, http.client.HTTPException, ValueError) as exc:
        errors.append(f"{type(exc).__name__}: {exc}")
        client.conn.close()                    # reconnects on the next request
        return float("nan"), None
    dt = time.perf_counter() - t0
    if status != 200:
        errors.append(f"{status}: {answer.get('error')}")
        return float("nan"), None
    return dt, answer


def trigger_pass(url: str, model: str, requests: int, base: TriggerBaseline) -> dict[str, Any]:
    """``requests`` triggers, one at a time, each followed by in-process on its frame:
    latency, grab, service seconds, poses."""
    from bench_service import pose_difference

    out: dict[str, Any] = {k: [] for k in ("latency_s", "grab_s", "service_s", "paired_s",
                                           "pose_diffs", "frames", "errors")}
    query = "/trigger/locate?" + urlencode({"model": model, "seed": TRIGGER_SEED})
    client = _Http(url)
    try:
        for _ in range(requests):
            dt, answer = _post(client, query, out["errors"])
            if answer is None:
                continue
            j = int(answer["frame_index"]) % len(base.pairs)
            out["latency_s"].append(dt)
            out["grab_s"].append(float(answer["grab_seconds"]))
            out["service_s"].append(float(answer["seconds"]))
            out["frames"].append(int(answer["frame_index"]))
            out["pose_diffs"].append(pose_difference(answer["T_cam1_model"], base.poses[j]))
            out["paired_s"].append(base.frame(j))
    finally:
        client.close()
    out["requests"] = requests
    return out


def upload_pass(url: str, pairs: Sequence[Any], base: TriggerBaseline, requests: int
                ) -> dict[str, Any]:
    """``requests`` rounds of one raw and one PNG ``/locate`` of pair ``k % len(pairs)``
    (in turn first), each followed by in-process on the pair."""
    from bench_service import pose_difference

    out: dict[str, Any] = {kind: {"latency_s": [], "paired_s": [], "pose_diffs": [],
                                  "errors": [], "requests": requests}
                           for kind in ("raw", "png")}
    raw = [(p.right_bgr.tobytes() + p.left_bgr.tobytes(),
            "/locate?" + urlencode({"model": p.model, "seed": p.seed,
                                    "width": p.right_bgr.shape[1],
                                    "height": p.right_bgr.shape[0], "pixel_format": "bgr8"}))
           for p in pairs]
    client = _Http(url)
    try:
        for k in range(requests):
            j = k % len(pairs)
            for kind in ("raw", "png") if k % 2 == 0 else ("png", "raw"):
                rec = out[kind]
                if kind == "raw":
                    dt, answer = _post(client, raw[j][1], rec["errors"], raw[j][0],
                                       "application/octet-stream")
                else:
                    dt, answer = _post(client, "/locate", rec["errors"], pairs[j].body,
                                       pairs[j].content_type)
                if answer is None:
                    continue
                rec["latency_s"].append(dt)
                rec["pose_diffs"].append(pose_difference(answer["T_cam1_model"],
                                                         base.base.poses[j]))
                rec["paired_s"].append(base.pair(j))
    finally:
        client.close()
    out["raw"]["body_bytes"] = len(raw[0][0])
    return out


async def _opcua_calls(endpoint: str, url: str, model: str, requests: int,
                       base: TriggerBaseline) -> dict[str, Any]:
    import httpx
    from asyncua import Client, ua

    from photomodel.service._opcua import NAMESPACE

    out: dict[str, Any] = {k: [] for k in ("latency_s", "grab_s", "paired_s",
                                           "position_diff_mm", "errors")}
    async with Client(endpoint, timeout=120.0) as client, \
            httpx.AsyncClient(base_url=url, timeout=30.0) as http:
        ns = await client.get_namespace_index(NAMESPACE)
        vision = client.get_node(ua.NodeId("PhotomodelVision", ns))
        method = ua.NodeId("PhotomodelVision.Locate", ns)
        for _ in range(requests):
            time.sleep(SETTLE_S)
            t0 = time.perf_counter()
            try:
                found, result_id = await vision.call_method(method, model)
            except ua.UaStatusCodeError as exc:
                out["errors"].append(str(exc))
                continue
            out["latency_s"].append(time.perf_counter() - t0)
            answer = (await http.get(f"/results/{result_id}")).json()   # untimed: which frame
            j = int(answer["frame_index"]) % len(base.pairs)
            out["grab_s"].append(float(answer["grab_seconds"]))
            T = answer.get("T_cam1_model")
            if T is not None and T[0][0] is not None:
                out["position_diff_mm"].append(float(np.abs(np.asarray(T)[:3, 3]
                                                            - base.poses[j][:3, 3]).max()))
            out["paired_s"].append(base.frame(j))
    out["requests"] = requests
    return out


def opcua_pass(endpoint: str, url: str, model: str, requests: int, base: TriggerBaseline
               ) -> dict[str, Any]:
    """``requests`` ``Locate(model)`` calls over one OPC UA session, each result read back
    over HTTP (untimed: its frame and grab) and followed by in-process on that frame."""
    import logging

    logging.getLogger("asyncua").setLevel(logging.ERROR)
    return asyncio.run(_opcua_calls(endpoint, url, model, requests, base))


def stream_pass(service: Any, model: str, warmup_s: float, seconds: float) -> dict[str, Any]:
    """One camera stream of ``warmup_s + seconds``; answers of the counted seconds."""
    from websockets.sync.client import connect

    uri = service.url.replace("http://", "ws://") + "/track?" + urlencode(
        {"model": model, "source": "camera"})
    answers: list[dict[str, Any]] = []
    rss: list[tuple[float, float]] = []
    stop = threading.Event()

    def sample() -> None:
        while not stop.is_set():
            rss.append((time.perf_counter(), service.memory_mib()["rss"]))
            stop.wait(RSS_PERIOD_S)

    sampler = threading.Thread(target=sample, daemon=True)
    cpu0 = service.cpu_s()
    with connect(uri, compression=None, max_size=None, open_timeout=30) as ws:
        t0 = time.perf_counter()
        sampler.start()
        while (now := time.perf_counter()) - t0 < warmup_s + seconds:
            message = json.loads(ws.recv(timeout=30))
            message["_t"] = now - t0
            message["_age_s"] = time.time() - float(message.get("frame_t_s") or "nan")
            answers.append(message)
    stop.set()
    sampler.join()
    wall = time.perf_counter() - t0
    cpu = service.cpu_s() - cpu0
    counted = [a for a in answers if a["_t"] >= warmup_s and "frame_index" in a]
    errors = [a["error"] for a in answers if "error" in a]
    index = [int(a["frame_index"]) for a in counted]
    gaps = int(sum(max(0, b - a - 1) for a, b in zip(index, index[1:], strict=False)))
    dropped = (int(counted[-1]["dropped"]) - int(counted[0]["dropped"])) if counted else 0
    rss_warm = [m for t, m in rss if t - t0 >= warmup_s]
    lost = sum(1 for a in counted if a.get("T_cam1_model") is None
               or a["T_cam1_model"][0][0] is None)
    return {"answers": len(counted), "seconds": seconds, "warmup_s": warmup_s,
            "expected_frames": int(seconds * STREAM_FPS),
            "frame_index_first_last": [index[0], index[-1]] if index else None,
            "frames_spanned": (index[-1] - index[0] + 1) if index else 0,
            "gaps": gaps, "stream_dropped": dropped, "dropped_total": gaps + dropped,
            "errors": errors, "lost_answers": lost,
            "age_s": [a["_age_s"] for a in counted],
            "tracker_s": [float(a["seconds"]) for a in counted if "seconds" in a],
            "rss_mib": [m for _, m in rss], "rss_warm_start_mib": rss_warm[0] if rss_warm
            else None, "rss_end_mib": rss_warm[-1] if rss_warm else None,
            "service_cpu_s_per_frame": cpu / max(1, len(answers)), "wall_s": wall}


# ----------------------------------------------------------------------------- the section

def run_faces(args: Any, data: Any, base: Any, env: dict[str, str]) -> dict[str, Any]:
    """The faces section of ``bench_service.py``: its JSON object (targets included)."""
    from bench_service import ServiceProcess, free_port, ratio, summarise_ms

    model = args.faces_model or data.pairs[0].model
    chosen = [p for p in data.pairs if p.model == model]
    if not chosen:
        raise SystemExit(f"--faces-model {model}: not one of the benchmark's garments")
    replay = args.work / "replay-trigger"
    trigger_replay(replay, chosen, TRIGGER_FPS)
    trig = TriggerBaseline(base.locators[model], chosen, base)
    opcua_port = free_port()
    service = ServiceProcess(data.stereo, data.library, 2, args.out.parent /
                             "service-faces.log", env,
                             extra=["--source", f"replay:{replay}", "--opcua",
                                    str(opcua_port)])
    n = args.faces_requests
    result: dict[str, Any] = {"model": model, "frames": len(chosen), "trigger_fps": TRIGGER_FPS,
                              "requests": n, "seed": TRIGGER_SEED}
    endpoint = f"opc.tcp://127.0.0.1:{opcua_port}/photomodel/"
    rows: dict[str, Any] = {}
    block = 25
    try:
        result["ready_s"] = service.start()
        _log(f"faces: trigger service ready in {result['ready_s']:.1f} s (replay of "
             f"{len(chosen)} scenes of {model} at {TRIGGER_FPS:g} fps, OPC UA on "
             f"{opcua_port})")
        trigger_pass(service.url, model, 2 * len(chosen), trig)      # warm: threads, kernels
        upload_pass(service.url, data.pairs, trig, len(data.pairs))
        opcua_pass(endpoint, service.url, model, 2, trig)
        result["memory_mib_before"] = service.memory_mib()
        for start in range(0, n, block):  # the rows in turn, so that drift falls on each
            k = min(block, n - start)
            _merge(rows, {"trigger": trigger_pass(service.url, model, k, trig)})
            _merge(rows, upload_pass(service.url, data.pairs, trig, k))
            _merge(rows, {"opcua": opcua_pass(endpoint, service.url, model, k, trig)})
            _log(f"  faces: {start + k}/{n} requests of each row")
        result["memory_mib_after"] = service.memory_mib()
    finally:
        result["exit_code"] = service.stop()
        result["log_tail"] = service.log_tail(1000)
    t = rows["trigger"]
    less_grab = [a - b for a, b in zip(t["latency_s"], t["grab_s"], strict=True)]
    paired = summarise_ms(t["paired_s"])
    result["trigger"] = {
        "latency_ms": summarise_ms(t["latency_s"]), "grab_ms": summarise_ms(t["grab_s"]),
        "latency_less_grab_ms": summarise_ms(less_grab), "in_process_ms": paired,
        "service_seconds_ms": summarise_ms(t["service_s"]), "errors": t["errors"],
        "pose_max_abs_diff": _worst(t["pose_diffs"]),
        "frames_seen": len(set(t["frames"])),
        "ratio_p50_less_grab": ratio(summarise_ms(less_grab)["p50"], paired["p50"]),
        "ratio_p50_with_grab": ratio(summarise_ms(t["latency_s"])["p50"], paired["p50"])}
    for kind in ("raw", "png"):
        r = rows[kind]
        lat, paired = summarise_ms(r["latency_s"]), summarise_ms(r["paired_s"])
        result[kind] = {"latency_ms": lat, "in_process_ms": paired, "errors": r["errors"],
                        "pose_max_abs_diff": _worst(r["pose_diffs"]),
                        "ratio_p50": ratio(lat["p50"], paired["p50"])}
    result["raw"]["body_bytes"] = rows["raw"]["body_bytes"]
    o = rows["opcua"]
    lat, paired = summarise_ms(o["latency_s"]), summarise_ms(o["paired_s"])
    less_grab = [a - b for a, b in zip(o["latency_s"], o["grab_s"], strict=True)]
    result["opcua"] = {
        "round_trip_ms": lat, "grab_ms": summarise_ms(o["grab_s"]),
        "round_trip_less_grab_ms": summarise_ms(less_grab), "in_process_ms": paired,
        "errors": o["errors"],
        "position_diff_mm_max": max(o["position_diff_mm"], default=None),
        "ratio_p50": ratio(lat["p50"], paired["p50"]),
        "ratio_p50_less_grab": ratio(summarise_ms(less_grab)["p50"], paired["p50"])}
    result["stream"] = _stream_section(args, env)
    result["targets"] = faces_targets(result)
    return result


def _stream_section(args: Any, env: dict[str, str]) -> dict[str, Any]:
    import bench_track_stream as bts
    from bench_service import ServiceProcess, growth, summarise_ms

    seq = bts.prepare_data(args.faces_work, STREAM_GARMENT, "conveyor", STREAM_FPS,
                           args.stream_sequence_s, 0)
    replay = args.faces_work / "replay-stream"
    loop = stream_replay(replay, seq.sequence, seq.frames.names, STREAM_FPS)
    service = ServiceProcess(seq.stereo, seq.library, 2, args.out.parent /
                             "service-stream.log", env, extra=["--source", f"replay:{replay}"])
    out: dict[str, Any] = {"fps": STREAM_FPS, "loop_frames": loop, "model": seq.model_name}
    try:
        out["ready_s"] = service.start()
        _log(f"faces: stream service ready in {out['ready_s']:.1f} s; tracking "
             f"{args.stream_warmup_s:g} + {args.stream_seconds:g} s at {STREAM_FPS:g} fps")
        run = stream_pass(service, seq.model_name, args.stream_warmup_s, args.stream_seconds)
    finally:
        out["exit_code"] = service.stop()
        out["log_tail"] = service.log_tail(1000)
    age, tracker = run.pop("age_s"), run.pop("tracker_s")
    out.update(run)
    out["age_ms"] = summarise_ms(age)
    out["tracker_ms"] = summarise_ms(tracker)
    out["rss_growth"] = growth(run["rss_warm_start_mib"], run["rss_end_mib"])
    return out


def _worst(diffs: Sequence[float | None]) -> float | None:
    if not diffs or any(d is None for d in diffs):
        return None
    return float(max(d for d in diffs if d is not None))


def faces_targets(result: dict[str, Any]) -> dict[str, Any]:
    """The issue's targets of the faces, each with its figure and verdict."""
    from bench_service import at_most

    s = result["stream"]
    return {
        "trigger_p50": {"criterion": f"trigger p50 less the grab / in-process <= "
                                     f"{TARGET_TRIGGER_RATIO}",
                        "value": result["trigger"]["ratio_p50_less_grab"],
                        "verdict": at_most(result["trigger"]["ratio_p50_less_grab"],
                                           TARGET_TRIGGER_RATIO)},
        "raw_p50": {"criterion": f"raw upload p50 / in-process <= {TARGET_RAW_RATIO}",
                    "value": result["raw"]["ratio_p50"],
                    "verdict": at_most(result["raw"]["ratio_p50"], TARGET_RAW_RATIO)},
        "opcua_p50": {"criterion": f"OPC UA Locate round trip p50 / in-process <= "
                                   f"{TARGET_OPCUA_RATIO}",
                      "value": result["opcua"]["ratio_p50"],
                      "verdict": at_most(result["opcua"]["ratio_p50"], TARGET_OPCUA_RATIO)},
        "stream_no_drop": {"criterion": f"{s['seconds']:g} s at {s['fps']:g} fps from a replay "
                                        "source: 0 dropped frames",
                           "value": s["dropped_total"],
                           "verdict": "pass" if s["dropped_total"] == 0 and s["answers"] > 0
                           else "fail"},
        "stream_memory": {"criterion": f"resident memory growth < "
                                       f"{TARGET_STREAM_RSS_GROWTH:.0%}",
                          "value": s["rss_growth"],
                          "verdict": at_most(s["rss_growth"], TARGET_STREAM_RSS_GROWTH)},
    }


def _fmt(value: float | None) -> str:
    return "n/a" if value is None else f"{value:.2f}"


def render_faces(result: dict[str, Any]) -> str:
    """The faces' table for stdout."""
    rows = ["faces (one client; each answer followed by in-process on the same frame or pair)",
            f"  {'path':<22}{'p50 ms':>9}{'p99 ms':>9}{'in proc':>9}{'ratio':>8}{'errors':>8}"]

    def row(name: str, lat: dict[str, Any], r: float | None, errors: int,
            ref: dict[str, Any] | None = None) -> None:
        p99 = lat.get("p99")
        inproc = float("nan") if ref is None else ref["p50"]
        rows.append(f"  {name:<22}{lat['p50'] or float('nan'):>9.1f}"
                    f"{p99 if p99 is not None else float('nan'):>9.1f}{inproc:>9.1f}"
                    f"{_fmt(r):>8}{errors:>8}")

    t = result["trigger"]
    row("trigger", t["latency_ms"], t["ratio_p50_with_grab"], len(t["errors"]),
        t["in_process_ms"])
    row("  less the grab", t["latency_less_grab_ms"], t["ratio_p50_less_grab"], 0,
        t["in_process_ms"])
    row("  grab", t["grab_ms"], None, 0)
    for kind in ("raw", "png"):
        row(f"{kind} upload", result[kind]["latency_ms"], result[kind]["ratio_p50"],
            len(result[kind]["errors"]), result[kind]["in_process_ms"])
    o = result["opcua"]
    row("OPC UA Locate", o["round_trip_ms"], o["ratio_p50"], len(o["errors"]),
        o["in_process_ms"])
    row("  less the grab", o["round_trip_less_grab_ms"], o["ratio_p50_less_grab"], 0,
        o["in_process_ms"])
    s = result["stream"]
    rows.append(f"  camera stream: {s['answers']} answers in {s['seconds']:g} s at "
                f"{s['fps']:g} fps, dropped {s['dropped_total']} (gaps {s['gaps']}, stream "
                f"{s['stream_dropped']}), age p50 {s['age_ms']['p50'] or float('nan'):.1f} ms, "
                f"memory growth {_fmt(s['rss_growth'])}")
    for name, tgt in result["targets"].items():
        rows.append(f"  target {name}: {tgt['verdict']} ({_fmt(tgt['value'])}; "
                    f"{tgt['criterion']})")
    return "\n".join(rows)
