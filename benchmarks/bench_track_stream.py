"""Benchmark: the cell service's ``/track`` WebSocket fed by a loopback client at camera rate,
against the in-process :class:`photomodel.Tracker` on the same frames in the same run.

The issue asks: "a loopback client sending 60 frames per second for 30 s: p50 per-frame
latency at most 2x the in-process tracker's, resident memory growth under 5 %, and with a
client that reads slowly, dropped frames counted and no backlog."

Data
----
``photomodel simulate --sequences conveyor --fps 60 --seconds 2 --garments No.6 --seed 0``
(``--kind``, ``--fps``, ``--sequence-seconds``, ``--garment``, ``--seed``), rendered once into
``--work`` (default ``build/bench-track-stream/``, kept and reused while its stamp says the same
settings), its ``models/No.6.npz`` added to a library there (``photomodel models add``). Every
frame's PNG files are read and decoded (OpenCV, BGR) into the client's memory before anything
is timed. The garment is No.6 because a full locate does not find the default No.1 on the
belt (see ``bench_track.py``).

Schedule
--------
Frame ``k`` of a run (``k = 0 .. N - 1``, ``N = (--warmup-s + --seconds) x fps``) shows the
sequence's frames back and forth from its middle (``n // 2, ..., n - 1, n - 2, ..., 0, 1,
...``: the belt runs one way, then back; the garment never jumps, so the tracker needs no
reset and detects only once, on frame 0, where the garment is wholly in view), stamped ``t_s =
k / fps`` (the camera's clock, rising throughout) and sent at ``t0 + k / fps`` by the client's
clock, as a camera would send it, whether or not answers came back. Frames of the first
``--warmup-s`` seconds are sent but not counted; the figures are those of the ``--seconds``
after them.

In-process baseline
-------------------
In the benchmark process, in two rounds, before the streams (the service then idle) and after
them (the service stopped), so that a change in the machine's load falls on both sides alike:
a new ``Tracker(model, rig)`` on the decoded arrays of the whole schedule, in order, with the
same ``t_s`` (``rng = seed + k``; the service seeds its own detections), after an untimed pass
over the sequence. Per-frame time of the call (p50, p95, p99) over the counted frames of both
rounds (each round's too); and the decoding of a frame message
(:func:`photomodel.service._track_socket.decode_frame`, as the service does) per encoding,
timed on the sequence's frames.

The service and the streams
---------------------------
``python -m photomodel serve --stereo S --models LIB --port P --log-level warning`` in a child
process on a free loopback port (``bench_service.ServiceProcess``; no token on loopback), ready
when ``/health`` says ``ok``. numba runs on one thread on both sides: run as a script,
``NUMBA_NUM_THREADS=1`` is set before numba is imported unless the environment sets it, and the
service inherits it (what was set is in ``settings.threads``). One WebSocket per run
(``websockets`` sync client, ``compression=None``: permessage-deflate of 1.8 MB raw frames would
cost the client and the service more than the tracking; a sender thread and a reader thread):

``raw``       frames as raw BGR pixels (``encoding: raw``, 2 x 640 x 480 x 3 bytes), the reader
              reading as fast as answers come;
``png``       (``--encoding png|both``) the same frames as the simulator's PNG files;
``slow_reader`` raw frames, but the reader sleeps ``--slow-read-s`` (0.2 s) after each answer
              while frames are being sent, then reads as fast as it can;
``slow_reader_credit`` the same slow reader asking for its answers (answers on demand:
              ``/track?model=NAME&credit=1``, then ``{"credit": 1}`` from the reader thread
              after each answer, once its sleep is over, i.e. when it is ready to read the
              next): the service tracks the newest frame when asked and lets the others wait
              and be dropped, instead of answering every frame into the socket buffers. Its
              tracker then sees only the frames it answers, about ``--slow-read-s`` apart
              (``modes`` counts how often it detected instead of tracking).

Per run: frames sent, answers, errors, the last answer's ``dropped`` and ``received``,
``credit`` (``initial`` and ``granted``; null without), the
``/metrics`` counters ``photomodel_track_frames_total{outcome}`` before and after (their
difference); latency of each answered counted frame = from just before its ``send`` to the
reader's receipt of its answer (an answer is matched to its frame by its ``t_s``), p50 / p95 /
p99, and per second of the run (``latency_p50_ms_by_second``: a growing queue shows as a
rising line); the service's own ``seconds`` per frame; the lag of each answer in frames:
``server_lag`` = the answer's ``received`` less its frame's number (frames that reached the
service while that frame was tracked), ``client_lag`` = frames sent when the answer was read
less its frame's number (it adds what waited in the socket buffers); ``drain_s`` = from the
end of the last ``send`` to the answer of the last frame (the newest frame always gets an
answer), and how many answers were read meanwhile; the service's resident memory
(``/proc/PID/status`` ``VmRSS``) when the warm-up ends and after the last answer, sampled every
0.5 s in between too; CPU seconds of the service and the client, and the cores other processes
kept busy meanwhile (``other_cores``; above 0.2 the run is flagged ``contaminated``).

Targets (``targets``: each figure, its limit and ``pass`` / ``fail``): raw p50 latency over
the in-process median at most 2; resident memory growth over the raw run and over each slow
reader's run under 5 %; for each slow reader (``slow_reader_*``, ``slow_reader_credit_*``),
every frame accounted (answers + dropped + bad + superseded = sent, the answers' ``dropped`` = the
``/metrics`` difference) and no backlog in the service (the last answer's ``received`` = frames
sent, the median ``server_lag`` at most 1 frame, ``drain_s`` at most 0.25 s); and no backlog of
answers (``slow_reader_no_backlog_of_answers``: at most 16 answers read after the last send,
with the age of the answers read, ``answer_age`` = ``latency_ms``, p50 and max), evaluated on
``slow_reader_credit``: a reader that does not ask for its answers gets one per frame tracked,
and what it has not read waits in the socket buffers, however the service drops frames; that
run's figures are shown beside it (``without_credit``, no verdict), as the reason credit
exists. The machine's load averages at the start and the end are in ``load_average``, and
``--note`` keeps a note in the JSON. ``send_ms`` is how long the
client's ``send`` of a frame took (a 1.8 MB raw frame does not fit the socket's buffer: the
send returns once the service has read most of it).

Run (about 4 minutes after the first, which renders 120 frames in about 30 s):
``.venv/bin/python benchmarks/bench_track_stream.py`` -> ``benchmarks/results/track_stream.json``.
Smoke: ``--quick`` (2 s runs after 1 s of warm-up, a 0.5 s sequence, raw only).
"""

from __future__ import annotations

import os

if __name__ == "__main__":     # run as the benchmark; imported (its tests) it changes nothing
    os.environ.setdefault("NUMBA_NUM_THREADS", "1")   # before numba is imported

import argparse  # noqa: E402
import json  # noqa: E402
import re  # noqa: E402
import shutil  # noqa: E402
import sys  # noqa: E402
import threading  # noqa: E402
import time  # noqa: E402
from collections.abc import Sequence  # noqa: E402
from dataclasses import dataclass, field  # noqa: E402
from pathlib import Path  # noqa: E402
from typing import Any  # noqa: E402

import numpy as np  # noqa: E402
from _meta import metadata  # noqa: E402
from bench_service import (  # noqa: E402
    OTHER_CORES_LIMIT,
    ServiceProcess,
    busy_cpu_s,
    contaminated,
    finite,
    growth,
    other_cores,
    ratio,
)
from bench_track import tracker_source  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
DEFAULT_OUT = REPO / "benchmarks" / "results" / "track_stream.json"
DEFAULT_WORK = REPO / "build" / "bench-track-stream"
STAMP = "bench_track_stream.stamp"
"""File that marks ``--work`` as this benchmark's (so that it may be replaced)."""

TARGET_P50_RATIO = 2.0
"""Issue: p50 per-frame latency through the stream at most 2 x the in-process tracker's."""
TARGET_RSS_GROWTH = 0.05
"""Issue: the service's resident memory grows under 5 % over a run."""
TARGET_DRAIN_S = 0.25
"""No backlog in the service: after the last frame is sent its answer comes within this (a
frame or two of tracking and the socket's transit, not the run's length)."""
TARGET_QUEUED_ANSWERS = 16
"""No backlog of answers: a slow reader finds at most this many answers waiting for it when
the sending ends (the websockets client's own queue, ``max_queue``), not one per frame
tracked since it last kept up."""
SEARCHES = 2
"""``photomodel serve --searches`` (its default; ``/track`` does not use the search slots)."""
RSS_PERIOD_S = 0.5
ANSWER_TIMEOUT_S = 60.0
QUICK = {"seconds": 2.0, "warmup_s": 1.0, "sequence_seconds": 0.5, "encoding": "raw"}


# ----------------------------------------------------------------------------- figures

def quantiles_ms(seconds: Sequence[float]) -> dict[str, Any]:
    """``n``, p50, p90, p95, p99, mean and max of ``seconds``, in ms (None when empty)."""
    x = np.asarray(seconds, dtype=np.float64) * 1000.0
    if x.size == 0:
        return {"n": 0, "p50": None, "p90": None, "p95": None, "p99": None, "mean": None,
                "max": None}
    p50, p90, p95, p99 = (float(v) for v in np.percentile(x, [50, 90, 95, 99]))
    return {"n": int(x.size), "p50": p50, "p90": p90, "p95": p95, "p99": p99,
            "mean": float(x.mean()), "max": float(x.max())}


def verdict(value: float | None, limit: float, below: bool = False) -> str:
    """``"pass"`` when ``value <= limit`` (``value < limit`` when ``below``), ``"fail"``
    otherwise, ``"n/a"`` without a value."""
    if value is None:
        return "n/a"
    return "pass" if (value < limit if below else value <= limit + 1e-12) else "fail"


@dataclass(frozen=True)
class Slot:
    """One frame of a run: its number ``k``, the sequence frame ``index`` it shows and its
    time ``t_s``."""

    k: int
    index: int
    t_s: float


def schedule(n_frames: int, n_sequence: int, fps: float) -> list[Slot]:
    """The frames of a run: the sequence of ``n_sequence`` frames played back and forth from
    its middle frame over ``n_frames`` (no jump from one frame to the next), ``t_s = k /
    fps`` rising throughout."""
    if n_frames < 1 or n_sequence < 1 or not fps > 0:
        raise ValueError(f"expected n_frames >= 1, n_sequence >= 1, fps > 0; got {n_frames}, "
                         f"{n_sequence}, {fps}")
    period = max(1, 2 * (n_sequence - 1))
    slots = []
    for k in range(n_frames):
        m = (k + n_sequence // 2) % period
        slots.append(Slot(k, m if m < n_sequence else period - m, k / fps))
    return slots


def frame_of(t_s: float, fps: float) -> int:
    """The frame number ``k`` of an answer's ``t_s`` (``k / fps``)."""
    return int(round(t_s * fps))


_TRACK_COUNTER = re.compile(r'^photomodel_track_frames_total\{outcome="(\w+)"\}\s+(\S+)$')


def track_counters(metrics_text: str) -> dict[str, float]:
    """``photomodel_track_frames_total`` by outcome from a ``/metrics`` page (missing
    outcomes are 0)."""
    out = {"tracked": 0.0, "dropped": 0.0, "bad": 0.0}
    for line in metrics_text.splitlines():
        m = _TRACK_COUNTER.match(line.strip())
        if m:
            out[m[1]] = float(m[2])
    return out


def by_second(t_send: Sequence[float], latency_s: Sequence[float], t0: float,
              seconds: int) -> list[float | None]:
    """p50 latency (ms) of the frames sent in each second after ``t0`` (None for a second
    without answers)."""
    bins: list[list[float]] = [[] for _ in range(seconds)]
    for t, lat in zip(t_send, latency_s, strict=True):
        i = int(t - t0)
        if 0 <= i < seconds:
            bins[i].append(lat)
    return [float(np.median(b)) * 1000.0 if b else None for b in bins]


# ----------------------------------------------------------------------------- data

@dataclass
class Frames:
    """The sequence in the client's memory: decoded images and their files' bytes."""

    names: list[str]
    right_bgr: list[np.ndarray] = field(repr=False)
    left_bgr: list[np.ndarray] = field(repr=False)
    right_png: list[bytes] = field(repr=False)
    left_png: list[bytes] = field(repr=False)

    @property
    def shape(self) -> tuple[int, int, int]:
        h, w, c = self.right_bgr[0].shape
        return int(h), int(w), int(c)

    def message(self, index: int, t_s: float, encoding: str) -> bytes:
        """The ``/track`` frame message of sequence frame ``index`` at ``t_s``."""
        from photomodel.service._track_socket import encode_frame

        if encoding == "png":
            return encode_frame(self.right_png[index], self.left_png[index], t_s=t_s)
        return encode_frame(self.right_bgr[index].tobytes(), self.left_bgr[index].tobytes(),
                            t_s=t_s, shape=self.shape)


@dataclass(frozen=True)
class Data:
    stereo: Path
    library: Path
    model_file: Path
    model_name: str
    sequence: Path
    frames: Frames
    simulate_argv: list[str]
    rendered_s: float | None


def _log(msg: str) -> None:
    print(msg, file=sys.stderr, flush=True)


def _cli(args: list[str]) -> None:
    from photomodel.cli import main as cli_main

    rc = cli_main(args)
    if rc != 0:
        raise RuntimeError(f"photomodel {' '.join(args)}: exit code {rc}")


def prepare_data(work: Path, garment: str, kind: str, fps: float, seconds: float,
                 seed: int) -> Data:
    """Render the sequence and its library into ``work`` (reused while its stamp holds the
    same settings) and read every frame into memory."""
    import cv2

    stamp = {"garment": garment, "kind": kind, "fps": fps, "seconds": seconds, "seed": seed,
             "version": 1}
    seq_dir = work / "sequence"
    library = work / "library"
    simulate = ["simulate", "--sequences", kind, "--fps", f"{fps:g}", "--seconds",
                f"{seconds:g}", "--garments", garment, "--seed", str(seed), "--out",
                str(seq_dir)]
    rendered_s = None
    try:
        cached = json.loads((work / STAMP).read_text()) == stamp
    except (OSError, ValueError):
        cached = False
    if not cached:
        if work.exists():
            if not (work / STAMP).is_file() and any(work.iterdir()):
                raise SystemExit(f"--work {work}: exists and is not this benchmark's "
                                 f"directory (no {STAMP}); give an empty or new directory")
            shutil.rmtree(work)
        work.mkdir(parents=True)
        t0 = time.perf_counter()
        _cli(simulate)
        rendered_s = time.perf_counter() - t0
        _cli(["models", "add", "--models", str(library), str(seq_dir / "models" /
                                                               f"{garment}.npz")])
        (work / STAMP).write_text(json.dumps(stamp))
    index = json.loads((library / "index.json").read_text())
    (model_name,) = index["models"]
    folder = seq_dir / f"{kind}-{fps:g}fps"
    names = sorted(p.name for p in folder.iterdir() if (p / "right.png").is_file())
    frames = Frames(names, [], [], [], [])
    for name in names:
        for side, files, images in (("right", frames.right_png, frames.right_bgr),
                                    ("left", frames.left_png, frames.left_bgr)):
            data = (folder / name / f"{side}.png").read_bytes()
            files.append(data)
            images.append(cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_COLOR))
    return Data(seq_dir / "stereo.yaml", library, seq_dir / "models" / f"{garment}.npz",
                model_name, folder, frames, ["photomodel", *simulate], rendered_s)


# ----------------------------------------------------------------------------- in process

def in_process(data: Data, slots: list[Slot], counted_from: int, fps: float,
               encodings: Sequence[str], seed: int) -> tuple[dict[str, Any], list[float]]:
    """One round of the in-process tracker on the schedule (after an untimed pass over the
    sequence) and of the decoding of a frame message per encoding: its figures and the
    tracker's seconds of the counted frames."""
    import photomodel as pm
    from photomodel.service._track_socket import decode_frame

    model = pm.load_model(data.model_file)
    rig = pm.load_stereo(data.stereo)
    f = data.frames
    warm = pm.Tracker(model, rig)
    for j in range(len(f.names)):
        warm(f.right_bgr[j], f.left_bgr[j], t_s=j / fps, rng=seed)
    tracker = pm.Tracker(model, rig)
    seconds, modes = [], []
    busy0, own0, wall0 = busy_cpu_s(), time.process_time(), time.perf_counter()
    for s in slots:
        t0 = time.perf_counter()
        result = tracker(f.right_bgr[s.index], f.left_bgr[s.index], t_s=s.t_s, rng=seed + s.k)
        seconds.append(time.perf_counter() - t0)
        modes.append(result.mode)
    wall = time.perf_counter() - wall0
    busy1 = busy_cpu_s()
    other = other_cores(None if busy0 is None or busy1 is None else busy1 - busy0,
                        time.process_time() - own0, wall)
    decode: dict[str, Any] = {}
    for encoding in encodings:
        times = []
        for j in range(len(f.names)):
            message = f.message(j, j / fps, encoding)
            t0 = time.perf_counter()
            decode_frame(message)
            times.append(time.perf_counter() - t0)
        decode[encoding] = quantiles_ms(times)
    counted = seconds[counted_from:]
    counted_modes = modes[counted_from:]
    return {"track_ms": quantiles_ms(counted),
            "modes": {m: counted_modes.count(m) for m in ("detect", "track", "lost")},
            "decode_ms": decode, "frames": len(counted), "wall_s": wall,
            "other_cores": other, "contaminated": contaminated(other)}, counted


# ----------------------------------------------------------------------------- streaming

@dataclass
class Answer:
    """One text message of the service: when it was read, what it says, and how many frames
    had been sent by then."""

    t_recv: float
    doc: dict[str, Any]
    sent_before: int
    size: int


GRANT = json.dumps({"credit": 1})
"""The text message that asks ``/track`` for one more answer."""


def _read(ws: Any, answers: list[Answer], sent: list[int], slow_read_s: float,
          stopped: threading.Event, last_t_s: float, got_last: threading.Event,
          grants: list[int] | None = None) -> None:
    """The reader thread: every answer with its time of receipt; waits ``slow_read_s``
    after each until ``stopped`` is set (the sending ended), then reads as fast as it can;
    sets ``got_last`` on the answer of the frame at ``last_t_s``. With ``grants`` (a stream
    opened with ``credit``) it asks for the next answer (``{"credit": 1}``, counted in
    ``grants[0]``) once it is ready to read it: after its wait. The sender thread sends
    frames on the same connection meanwhile: the websockets sync connection serialises whole
    messages under its lock (only a fragmented send may not be interleaved), and ``recv`` in
    one thread goes with ``send`` in others."""
    from websockets.exceptions import ConnectionClosed

    try:
        while True:
            text = ws.recv()
            t = time.perf_counter()
            doc = json.loads(text)
            answers.append(Answer(t, doc, sent[0], len(text)))
            if doc.get("t_s") == last_t_s:
                got_last.set()
            if slow_read_s > 0 and not stopped.is_set():
                stopped.wait(slow_read_s)
            if grants is not None:
                ws.send(GRANT)
                grants[0] += 1
    except ConnectionClosed:
        pass


def stream(service: ServiceProcess, model: str, frames: Frames, slots: list[Slot],
           counted_from: int, fps: float, encoding: str, slow_read_s: float = 0.0,
           credit: int | None = None) -> dict[str, Any]:
    """One run: send the schedule at ``fps`` over one WebSocket, read the answers (with
    ``credit``: ask for that many at the start and one more after each answer read); the
    run's figures (see the module's docstring)."""
    import httpx
    from websockets.sync.client import connect

    ws_url = service.url.replace("http://", "ws://") + f"/track?model={model}"
    if credit is not None:
        ws_url += f"&credit={credit}"
    grants = None if credit is None else [0]
    counters0 = track_counters(httpx.get(service.url + "/metrics", timeout=30).text)
    answers: list[Answer] = []
    sent = [0]
    t_send = [float("nan")] * len(slots)
    send_s: list[float] = []
    late = 0
    stopped, got_last = threading.Event(), threading.Event()
    rss_trace: list[tuple[float, float]] = []
    stop_rss = threading.Event()

    def sample_rss() -> None:
        while not stop_rss.is_set():
            rss_trace.append((time.perf_counter(), service.memory_mib()["rss"]))
            stop_rss.wait(RSS_PERIOD_S)

    cpu_server0, cpu_client0, busy0 = service.cpu_s(), time.process_time(), busy_cpu_s()
    with connect(ws_url, max_size=2**25, compression=None, open_timeout=60,
                 close_timeout=10) as ws:
        reader = threading.Thread(target=_read, args=(ws, answers, sent, slow_read_s, stopped,
                                                      slots[-1].t_s, got_last, grants),
                                  name="bench-reader", daemon=True)
        reader.start()
        sampler = threading.Thread(target=sample_rss, name="bench-rss", daemon=True)
        sampler.start()
        rss_start = None
        t0 = time.perf_counter() + 0.05
        for s in slots:
            message = frames.message(s.index, s.t_s, encoding)
            due = t0 + s.k / fps
            if s.k == counted_from:
                rss_start = service.memory_mib()["rss"]
            wait = due - time.perf_counter()
            if wait > 0:
                time.sleep(wait)
            elif wait < -1.0 / fps:
                late += 1
            t_send[s.k] = time.perf_counter()
            ws.send(message)
            send_s.append(time.perf_counter() - t_send[s.k])
            sent[0] = s.k + 1
        t_stop = time.perf_counter()
        stopped.set()
        answered_last = got_last.wait(ANSWER_TIMEOUT_S)
        t_last = time.perf_counter()
        stop_rss.set()
        sampler.join()
        rss_end = service.memory_mib()
    reader.join(timeout=30)
    wall = t_last - t0
    cpu_server, cpu_client = service.cpu_s() - cpu_server0, time.process_time() - cpu_client0
    busy1 = busy_cpu_s()
    counters1 = track_counters(httpx.get(service.url + "/metrics", timeout=30).text)
    return summarise_run(answers, slots, t_send, counted_from, fps, t0, t_stop, t_last,
                         answered_last, late, rss_start, rss_end["rss"], rss_trace, counters0,
                         counters1, encoding, slow_read_s, send_s[counted_from:], {
                             "server_s": cpu_server, "client_s": cpu_client,
                             "other_cores": other_cores(
                                 None if busy0 is None or busy1 is None else busy1 - busy0,
                                 cpu_server + cpu_client, wall),
                             "wall_s": wall},
                         None if credit is None else {"initial": credit,
                                                      "granted": grants[0] if grants else 0})


def summarise_run(answers: list[Answer], slots: list[Slot], t_send: list[float],
                  counted_from: int, fps: float, t0: float, t_stop: float, t_last: float,
                  answered_last: bool, late: int, rss_start: float | None, rss_end: float,
                  rss_trace: list[tuple[float, float]], counters0: dict[str, float],
                  counters1: dict[str, float], encoding: str, slow_read_s: float,
                  send_s: list[float], cpu: dict[str, Any],
                  credit: dict[str, int] | None = None) -> dict[str, Any]:
    """A run's figures from its raw record (``credit``: the answers asked for, ``initial``
    in the query and ``granted`` one by one; None without)."""
    n = len(slots)
    tracked = [a for a in answers if "error" not in a.doc]
    errors = [a.doc["error"] for a in answers if "error" in a.doc]
    latency, sent_at, server_s, server_lag, client_lag = [], [], [], [], []
    modes: dict[str, int] = {}
    for a in tracked:
        k = frame_of(float(a.doc["t_s"]), fps)
        if not 0 <= k < n or k < counted_from:
            continue
        latency.append(a.t_recv - t_send[k])
        sent_at.append(t_send[k])
        server_s.append(float(a.doc["seconds"]))
        server_lag.append(int(a.doc["received"]) - (k + 1))
        client_lag.append(a.sent_before - (k + 1))
        modes[a.doc["mode"]] = modes.get(a.doc["mode"], 0) + 1
    last = answers[-1].doc if answers else {}
    diff = {k: counters1.get(k, 0.0) - counters0.get(k, 0.0) for k in counters1}
    dropped = int(last.get("dropped", 0))
    counted_s = (n - counted_from) / fps
    after_stop = sum(1 for a in answers if a.t_recv > t_stop)
    start_t = t_send[counted_from] if counted_from < n else t0
    return {
        "encoding": encoding, "slow_read_s": slow_read_s, "credit": credit,
        "frames_sent": n, "frames_counted": n - counted_from, "late_sends": late,
        "answers": len(answers), "tracked_answers": len(tracked), "errors": len(errors),
        "error_samples": sorted(set(errors))[:5],
        "last_received": last.get("received"), "last_dropped": dropped,
        "metrics_delta": diff,
        "superseded": int(last.get("superseded", 0)),
        "accounted": len(tracked) + dropped + len(errors) + int(last.get("superseded", 0)) == n,
        "dropped_share": dropped / n,
        "latency_ms": quantiles_ms(latency),
        "send_ms": quantiles_ms(send_s),
        "latency_p50_ms_by_second": by_second(sent_at, latency, start_t,
                                              max(1, int(round(counted_s)))),
        "server_seconds_ms": quantiles_ms(server_s),
        "modes": modes,
        "server_lag_frames": {"median": float(np.median(server_lag)) if server_lag else None,
                              "max": max(server_lag) if server_lag else None},
        "client_lag_frames": {"median": float(np.median(client_lag)) if client_lag else None,
                              "p50_s": float(np.median(client_lag)) / fps if client_lag
                              else None,
                              "p99": float(np.percentile(client_lag, 99)) if client_lag
                              else None,
                              "max": max(client_lag) if client_lag else None},
        "drain_s": t_last - t_stop if answered_last else None,
        "answers_after_stop": after_stop,
        "answer_bytes_median": float(np.median([a.size for a in answers])) if answers
        else None,
        "last_frame_answered": answered_last,
        "rss_mib": {"start": rss_start, "end": rss_end,
                    "max": max((r for _, r in rss_trace), default=None),
                    "growth": growth(rss_start, rss_end)},
        "rss_trace_mib": [[round(t - t0, 2), round(r, 1)] for t, r in rss_trace],
        "cpu": {**cpu, "contaminated": contaminated(cpu["other_cores"])},
    }


# ----------------------------------------------------------------------------- the run

def _slow_reader_targets(slow: dict[str, Any], prefix: str) -> dict[str, Any]:
    """A slow reader's targets: resident memory growth, every frame accounted and no backlog
    in the service; their names start with ``prefix``."""
    g = slow["rss_mib"]["growth"]
    metrics_dropped = slow["metrics_delta"].get("dropped")
    counted = slow["accounted"] and metrics_dropped == slow["last_dropped"]
    d, lag = slow["drain_s"], slow["server_lag_frames"]["median"]
    keeps_up = (slow["last_received"] == slow["frames_sent"] and lag is not None
                and lag <= 1 and verdict(d, TARGET_DRAIN_S) == "pass")
    return {
        f"{prefix}_rss_growth": {"value": g, "below": TARGET_RSS_GROWTH,
                                 "verdict": verdict(g, TARGET_RSS_GROWTH, below=True)},
        f"{prefix}_dropped_counted": {
            "answers": slow["tracked_answers"], "errors": slow["errors"],
            "dropped": slow["last_dropped"], "metrics_dropped": metrics_dropped,
            "sent": slow["frames_sent"], "verdict": "pass" if counted else "fail"},
        f"{prefix}_no_backlog_in_service": {
            "last_received": slow["last_received"], "sent": slow["frames_sent"],
            "server_lag_frames_median": lag, "drain_s": d, "drain_s_max": TARGET_DRAIN_S,
            "verdict": "pass" if keeps_up else "fail"}}


def _answer_backlog(run: dict[str, Any]) -> dict[str, Any]:
    """How many answers waited for a reader when the sending ended, and how old they were."""
    return {"answers_read_after_the_last_send": run["answers_after_stop"],
            "answer_age_p50_ms": run["latency_ms"]["p50"],
            "answer_age_max_ms": run["latency_ms"]["max"]}


def run_targets(result: dict[str, Any]) -> dict[str, Any]:
    """Each target: its figure, its limit and the verdict. The slow readers' figures are
    targets for both (with and without credit) but the backlog of answers, which only the
    reader that asks for its answers (``credit``) can avoid: it is evaluated on that run, and
    the plain slow reader's backlog is shown beside it (``without_credit``, no verdict)."""
    runs = result["runs"]
    raw, slow, asks = runs.get("raw"), runs.get("slow_reader"), runs.get("slow_reader_credit")
    out: dict[str, Any] = {}
    if raw is not None:
        r = result["ratios"]["raw_p50_over_in_process_p50"]
        out["p50_ratio"] = {"value": r, "max": TARGET_P50_RATIO,
                            "verdict": verdict(r, TARGET_P50_RATIO)}
        g = raw["rss_mib"]["growth"]
        out["rss_growth"] = {"value": g, "below": TARGET_RSS_GROWTH,
                             "verdict": verdict(g, TARGET_RSS_GROWTH, below=True)}
    if slow is not None:
        out.update(_slow_reader_targets(slow, "slow_reader"))
    if asks is not None:
        out.update(_slow_reader_targets(asks, "slow_reader_credit"))
        backlog = _answer_backlog(asks)
        out["slow_reader_no_backlog_of_answers"] = {
            "run": "slow_reader_credit", **backlog, "max": TARGET_QUEUED_ANSWERS,
            "without_credit": None if slow is None else {"run": "slow_reader",
                                                         **_answer_backlog(slow)},
            "verdict": verdict(backlog["answers_read_after_the_last_send"],
                               TARGET_QUEUED_ANSWERS)}
    return out


def _relative(word: str) -> str:
    """A command's word with the repository's path left out."""
    return word.replace(str(REPO) + os.sep, "")


def tcp_buffers() -> dict[str, Any]:
    """The kernel's TCP buffer sizes (min, default, max bytes), which hold what a slow reader
    has not read."""
    out: dict[str, Any] = {}
    for name in ("tcp_rmem", "tcp_wmem"):
        try:
            out[name] = [int(v) for v in Path(f"/proc/sys/net/ipv4/{name}").read_text().split()]
        except (OSError, ValueError):
            out[name] = None
    return out


def threads() -> dict[str, Any]:
    import cv2
    import numba

    return {"NUMBA_NUM_THREADS": os.environ.get("NUMBA_NUM_THREADS"),
            "numba_threads": numba.get_num_threads(), "opencv_threads": cv2.getNumThreads(),
            "service": "inherits the benchmark's environment"}


def _load_average() -> list[float] | None:
    """The machine's 1, 5 and 15 minute load averages (None where the system has none)."""
    try:
        return [round(v, 2) for v in os.getloadavg()]
    except OSError:
        return None


def run(args: argparse.Namespace) -> dict[str, Any]:
    t_start = time.perf_counter()
    load_start = _load_average()
    meta, source = metadata("track_stream", args.seed), tracker_source()   # what is measured
    data = prepare_data(args.work, args.garment, args.kind, args.fps, args.sequence_seconds,
                        args.seed)
    f = data.frames
    _log(f"{len(f.names)} frames of {data.sequence} in memory"
         + (f" (rendered in {data.rendered_s:.0f} s)" if data.rendered_s else " (cached)"))
    counted_from = int(round(args.warmup_s * args.fps))
    slots = schedule(counted_from + int(round(args.seconds * args.fps)), len(f.names),
                     args.fps)
    encodings = ["raw", "png"] if args.encoding == "both" else [args.encoding]
    rounds = [in_process(data, slots, counted_from, args.fps, encodings, args.seed)]
    _log(f"in process: track p50 {rounds[0][0]['track_ms']['p50']:.2f} ms, p99 "
         f"{rounds[0][0]['track_ms']['p99']:.2f} ms over {rounds[0][0]['frames']} frames")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    service = ServiceProcess(data.stereo, data.library, SEARCHES, args.work / "service.log")
    runs: dict[str, Any] = {}
    try:
        startup_s = service.start()
        rss_ready = service.memory_mib()
        plan: list[tuple[str, str, float, int | None]] = [(e, e, 0.0, None)
                                                         for e in encodings]
        if args.slow_read_s > 0:
            plan += [("slow_reader", "raw", args.slow_read_s, None),
                     ("slow_reader_credit", "raw", args.slow_read_s, 1)]
        for label, encoding, slow, credit in plan:
            r = stream(service, data.model_name, f, slots, counted_from, args.fps, encoding,
                       slow, credit)
            runs[label] = r
            lat = r["latency_ms"]
            _log(f"{label}: {r['answers']} answers / {r['frames_sent']} sent, dropped "
                 f"{r['last_dropped']}, latency p50 {lat['p50']} ms p99 {lat['p99']} ms "
                 f"max {lat['max']} ms, {r['answers_after_stop']} answers after the last "
                 f"send, drain {r['drain_s']} s, rss {r['rss_mib']['start']} -> "
                 f"{r['rss_mib']['end']} MiB")
        rss_final = service.memory_mib()
    finally:
        code = service.stop()
    rounds.append(in_process(data, slots, counted_from, args.fps, encodings, args.seed))
    _log(f"in process again: track p50 {rounds[1][0]['track_ms']['p50']:.2f} ms")
    baseline = {"track_ms": quantiles_ms([v for _, seconds in rounds for v in seconds]),
                "decode_ms": {e: quantiles_ms([]) for e in encodings},
                "frames": sum(r["frames"] for r, _ in rounds),
                "rounds": [r for r, _ in rounds]}
    for e in encodings:       # the decoding's p50 and p99: the rounds' mean
        baseline["decode_ms"][e] = {
            key: float(np.mean([r["decode_ms"][e][key] for r, _ in rounds]))
            for key in ("p50", "p99")}
    track_p50 = baseline["track_ms"]["p50"]
    ratios: dict[str, Any] = {}
    for label in ("raw", "png"):
        if label in runs:
            p50 = runs[label]["latency_ms"]["p50"]
            ratios[f"{label}_p50_over_in_process_p50"] = ratio(p50, track_p50)
            ratios[f"{label}_p50_over_in_process_decode_track_p50"] = ratio(
                p50, None if track_p50 is None else
                track_p50 + baseline["decode_ms"][label]["p50"])
    result = {
        **meta,
        **({"note": args.note} if args.note else {}),
        "issue": "a loopback client sending 60 frames per second for 30 s: p50 per-frame "
                 "latency at most 2x the in-process tracker's, resident memory growth under "
                 "5 %, and with a client that reads slowly, dropped frames counted and no "
                 "backlog",
        "settings": {"seconds": args.seconds, "warmup_s": args.warmup_s, "fps": args.fps,
                     "encoding": args.encoding, "slow_read_s": args.slow_read_s,
                     "garment": args.garment, "kind": args.kind,
                     "sequence_seconds": args.sequence_seconds,
                     "cycling": "the sequence is played back and forth from its middle "
                                "frame (no jump, no reset); t_s = k / fps rising",
                     "client": "websockets sync client, compression=None, one sender and "
                               "one reader thread, frames sent at t0 + k / fps; "
                               "slow_reader_credit: credit=1 in the query and {\"credit\": 1} "
                               "sent by the reader after each answer, once its wait is over",
                     "threads": threads(), "tcp_buffers": tcp_buffers(), "targets": {
                         "p50_ratio_max": TARGET_P50_RATIO,
                         "rss_growth_below": TARGET_RSS_GROWTH,
                         "drain_s_max": TARGET_DRAIN_S,
                         "queued_answers_max": TARGET_QUEUED_ANSWERS,
                         "other_cores_limit": OTHER_CORES_LIMIT}},
        "data": {"simulate": [_relative(w) for w in data.simulate_argv],
                 "sequence": _relative(str(data.sequence)),
                 "frames": len(f.names), "shape": list(f.shape), "model": data.model_name,
                 "message_bytes": {e: len(f.message(0, 0.0, e)) for e in encodings},
                 "rendered_s": data.rendered_s},
        "service": {"command": [_relative(w) for w in service.cmd[1:]], "startup_s": startup_s,
                    "rss_ready_mib": rss_ready["rss"], "rss_final_mib": rss_final["rss"],
                    "exit_code": code},
        "tracker": source,
        "in_process": baseline,
        "runs": runs,
        "ratios": ratios,
        "wall_seconds": time.perf_counter() - t_start,
        "load_average": {"start": load_start, "end": _load_average()},
    }
    result["targets"] = run_targets(result)
    return result


def main(argv: Sequence[str] | None = None) -> dict[str, Any]:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seconds", type=float, default=None,
                    help="counted seconds of each run (default 30; --quick 2)")
    ap.add_argument("--warmup-s", type=float, default=None,
                    help="seconds sent before the counted ones (default 3; --quick 1)")
    ap.add_argument("--fps", type=float, default=60.0, help="frames per second (default 60)")
    ap.add_argument("--encoding", choices=["raw", "png", "both"], default=None,
                    help="frames as raw pixels, PNG files or a run of each (default both; "
                         "--quick raw)")
    ap.add_argument("--slow-read-s", type=float, default=0.2,
                    help="the slow readers' sleep after each answer (default 0.2; 0: no "
                         "slow-reader runs)")
    ap.add_argument("--garment", default="No.6", help="simulated garment (default No.6)")
    ap.add_argument("--kind", default="conveyor", help="sequence kind (default conveyor)")
    ap.add_argument("--sequence-seconds", type=float, default=None,
                    help="length of the simulated sequence that is cycled (default 2; "
                         "--quick 0.5)")
    ap.add_argument("--seed", type=int, default=0, help="simulation seed (default 0)")
    ap.add_argument("--note", default=None,
                    help="a note kept in the JSON (e.g. what else ran on the machine)")
    ap.add_argument("--quick", action="store_true", help="a smoke run: " + ", ".join(
        f"{k} {v}" for k, v in QUICK.items()))
    ap.add_argument("--work", type=Path, default=DEFAULT_WORK,
                    help=f"data directory (default {DEFAULT_WORK.relative_to(REPO)}; kept)")
    ap.add_argument("--out", type=Path, default=DEFAULT_OUT,
                    help=f"JSON output (default {DEFAULT_OUT.relative_to(REPO)})")
    args = ap.parse_args(argv)
    defaults = QUICK if args.quick else {"seconds": 30.0, "warmup_s": 3.0,
                                         "sequence_seconds": 2.0, "encoding": "both"}
    for key, value in defaults.items():
        if getattr(args, key) is None:
            setattr(args, key, value)
    if not (args.seconds > 0 and args.warmup_s >= 0 and args.fps > 0
            and args.sequence_seconds > 0 and args.slow_read_s >= 0):
        ap.error("--seconds, --fps and --sequence-seconds must be positive, --warmup-s and "
                 "--slow-read-s not negative")
    result = run(args)
    tmp = args.out.with_name(f".{args.out.name}.tmp")
    tmp.write_text(json.dumps(finite(result), indent=1, allow_nan=False) + "\n")
    os.replace(tmp, args.out)
    for name, t in result["targets"].items():
        print(f"{name:30s} {t['verdict']:5s} {json.dumps(finite(t))}")
    print(f"wrote {args.out}")
    return result


if __name__ == "__main__":
    main()
