"""Benchmark: the cell service (``photomodel serve``) under load over loopback, against the
in-process :class:`photomodel.Locator` on the same stereo pairs in the same run.

The issue asks: with 1, 2 and 4 concurrent clients posting the same seeded simulated stereo
pairs, 500 requests each, the p50 / p99 latency of ``POST /locate`` against the in-process
median (target: p50 at most 1.3 x the in-process median with one client), the throughput, the
error count (target 0), the service's resident memory before and after (growth under 5 %), and
``GET /health`` answering within 50 ms while four searches run. It also asks how many searches
should run at once (``ServiceConfig.searches``, ``photomodel serve --searches N``): every
``--searches`` setting is measured with every ``--clients`` count, so that the default is
chosen on data.

Data
----
``photomodel simulate --garments G --scenes S --seed SEED`` (paper condition) into ``--work``,
each garment's photo-model built (``photomodel build``) and added to a library (``photomodel
models add``). Every scene is one stereo pair; pair ``j`` (scenes in sorted order) is always
searched for its own garment with seed ``j``, so that each request of a pair must give the
pose the in-process Locator gives for that pair.

The services
------------
One process per ``--searches`` setting, all started before the first pass (one at a time, so
that each start-up is timed alone) and kept until the last: ``python -m photomodel serve
--stereo S --models LIB --port P --searches N --log-level warning`` (its log:
``service-N.log`` beside ``--out``; ``--service-env NAME=VALUE`` sets a variable for these
processes only), so that its resident memory can be read from ``/proc/<pid>/status``
(``VmRSS``) and it does not share the benchmark's GIL. An idle service costs no CPU. Ready when
``/health`` says ``ok``; then a warm-up (every pair once, then ``2 x max(clients)`` requests
from as many threads, so that the worker threads exist and the ring of recent results, 20
results with their stereo pairs, is full) before the memory is read (``rss_before``); it is
read again after every pass (``rss_trace_mib``) and at the end (``rss_after``); growth =
after / before - 1 (``rss_growth_from_ready`` counts from the start-up instead).

Rounds
------
The ``--requests`` per client are split into ``--rounds`` rounds (default 2: 250 + 250). Each
round runs one in-process baseline round, then every setting (searches x clients), the order
of the searches settings rotated from round to round, so that a burst of load from other
processes falls on every setting alike rather than on the one measured at that moment. A
setting's figures pool its rounds; each round's throughput and p50 are kept beside them.

Clients
-------
``--clients`` threads in the benchmark process, one ``httpx.Client`` each (keep-alive), all
released at once by a barrier; each posts its requests, cycling over the pairs from its own
offset. The multipart bodies (``right``, ``left`` files as the dataset's PNG bytes, or
``--upload bmp``: the same pixels as BMP; fields ``model``, ``seed``) are encoded once before
timing, so that a client costs little CPU. Latency: from sending to the decoded JSON answer.
Throughput: requests / wall time of the pass(es). An error: an exception or any status other
than 200. Each answer's ``T_cam1_model`` is compared with the in-process pose of the same pair
and seed (``pose_max_abs_diff``: the largest absolute difference over the 4 x 4 entries, mm in
the translation). During every pass with 4 or more clients a separate thread polls ``/health``
every 50 ms (its own connection); its latencies are reported (target: every answer within
50 ms with four searches running, i.e. ``--searches 4`` and 4 clients).

In-process baseline
-------------------
In the benchmark process: ``Locator(model, rig, min_score=...)`` per model (the service's
threshold), warmed on every pair, then ``--baseline-calls`` calls of every pair at the start of
every round and once after the last (never while a service is under load: a loopback
benchmark on few cores must not run both at once). numba's and OpenMP's settings
(``NUMBA_NUM_THREADS``, ``OMP_WAIT_POLICY``) come from the environment and hold for both
sides, unless ``--service-env`` overrides them for the services. Two figures: ``locate``
(``locator(right, left, rng=seed)`` on decoded arrays, the issue's "in-process median") and
``decode_locate`` (decoding both uploaded files with
:func:`photomodel.image.decode_color_image`, as the service does, then the same locate):
``p50 / decode_locate`` isolates what HTTP, the multipart parse and the queue add.

CPU and load
------------
Per pass: the service's CPU seconds (``/proc/<pid>/stat``, all threads) and the benchmark
process's, per request; the load average before and after; and the cores that other processes
kept busy meanwhile (``other_cores``: the machine's busy CPU time from ``/proc/stat`` less the
service's and the benchmark's, over the wall time; likewise for each in-process round). The
reference machine has two cores that clients, event loop and searches share: a figure taken
while others used more than 0.2 cores is flagged ``contaminated`` (and marked in the table).
On a shared machine ``--retry-contaminated K`` repeats such a pass or round (after
``--retry-wait`` seconds, up to K times; the last attempt is kept whatever it shows); the
discarded attempts are listed under ``discarded`` and left out of the figures.

Output: ``--out`` (JSON: meta with the commit and versions, settings, data, in-process figures,
per searches setting the service's start-up, memory and passes, targets with verdicts) and a
table on stdout. Target misses are reported, the exit code stays 0.

Run (full: searches 1, 2, 4 x clients 1, 2, 4 x 500 requests; 6.5 minutes on two quiet cores):
``.venv/bin/python benchmarks/bench_service.py``
Smoke: ``--quick`` (20 requests per client); ``--quick --requests 3 --clients 1 --searches 2``.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import signal
import socket
import subprocess
import sys
import threading
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from _faces import render_faces, run_faces
from _meta import metadata

REPO = Path(__file__).resolve().parents[1]
DEFAULT_OUT = REPO / "build" / "bench" / "service.json"
DEFAULT_WORK = REPO / "build" / "bench-service"
DEFAULT_FACES_WORK = REPO / "build" / "bench-service-faces"
DEFAULT_GARMENTS = ("No.3", "No.5", "No.7")
STAMP = "bench_service.stamp"
"""File that marks ``--work`` as this benchmark's (so that it may be replaced)."""

TARGET_P50_RATIO = 1.3
"""Issue: p50 of ``/locate`` with one client at most 1.3 x the in-process median."""
TARGET_RSS_GROWTH = 0.05
"""Issue: resident memory after the passes at most 5 % above before."""
TARGET_HEALTH_MS = 50.0
"""Issue: ``/health`` answers within 50 ms while four searches run."""
HEALTH_PERIOD_S = 0.05
P90_MIN_SAMPLES = 10
P99_MIN_SAMPLES = 100
REQUEST_TIMEOUT_S = 120.0
QUICK_REQUESTS = 20
OTHER_CORES_LIMIT = 0.2
"""A figure measured while other processes kept more cores busy than this is flagged."""


# ----------------------------------------------------------------------------- statistics

def summarise_ms(seconds: Sequence[float]) -> dict[str, Any]:
    """``n``, p50, mean, min, max and, with enough samples, p90 and p99 of ``seconds``, in ms.

    p90 needs at least :data:`P90_MIN_SAMPLES` samples and p99 :data:`P99_MIN_SAMPLES` (None
    otherwise); an empty sequence gives ``n = 0`` and None everywhere.
    """
    x = np.asarray(seconds, dtype=np.float64) * 1000.0
    n = int(x.size)
    if n == 0:
        return {"n": 0, "p50": None, "p90": None, "p99": None, "mean": None, "min": None,
                "max": None}
    return {"n": n, "p50": float(np.median(x)),
            "p90": float(np.percentile(x, 90)) if n >= P90_MIN_SAMPLES else None,
            "p99": float(np.percentile(x, 99)) if n >= P99_MIN_SAMPLES else None,
            "mean": float(x.mean()), "min": float(x.min()), "max": float(x.max())}


def ratio(value: float | None, reference: float | None) -> float | None:
    """``value / reference``; None when either is missing or the reference is not positive."""
    if value is None or reference is None or not reference > 0:
        return None
    return float(value / reference)


def growth(before: float | None, after: float | None) -> float | None:
    """Relative growth ``after / before - 1`` (0.05 is 5 %); None without both figures."""
    r = ratio(after, before)
    return None if r is None else r - 1.0


def at_most(value: float | None, limit: float) -> str:
    """``"pass"`` when ``value <= limit``, ``"fail"`` above, ``"n/a"`` without a value."""
    if value is None:
        return "n/a"
    return "pass" if value <= limit + 1e-12 else "fail"


def pose_difference(a: Any, b: Any) -> float | None:
    """Largest absolute difference between two 4 x 4 poses (nested lists or arrays; None or
    NaN entries for "no pose"). 0.0 when both are "no pose", infinity when only one is;
    None when either is not 4 x 4."""
    def as_array(T: Any) -> np.ndarray | None:
        if T is None:
            return np.full((4, 4), np.nan)
        arr = np.array([[np.nan if v is None else v for v in row] for row in T],
                       dtype=np.float64) if isinstance(T, list) else np.asarray(T, np.float64)
        return arr if arr.shape == (4, 4) else None

    A, B = as_array(a), as_array(b)
    if A is None or B is None:
        return None
    nan_a, nan_b = np.isnan(A), np.isnan(B)
    if not np.array_equal(nan_a, nan_b):
        return float("inf")
    both = ~nan_a
    return float(np.abs(A[both] - B[both]).max()) if both.any() else 0.0


def client_orders(clients: int, requests: int, pairs: int) -> list[list[int]]:
    """The pair index of each request of each client: client ``c`` cycles over the pairs from
    offset ``c * max(1, pairs // clients)``, so that clients send different pairs at once."""
    if clients < 1 or requests < 0 or pairs < 1:
        raise ValueError(f"expected clients >= 1, requests >= 0, pairs >= 1; got {clients}, "
                         f"{requests}, {pairs}")
    stride = max(1, pairs // clients)
    return [[(c * stride + k) % pairs for k in range(requests)] for c in range(clients)]


def other_cores(busy_s: float | None, own_s: float, wall_s: float) -> float | None:
    """Cores that other processes kept busy on average: the machine's busy CPU seconds
    ``busy_s`` less this benchmark's own ``own_s`` (its process and the service's), over
    ``wall_s``; None without a machine figure."""
    if busy_s is None or not wall_s > 0:
        return None
    return max(0.0, (busy_s - own_s) / wall_s)


def contaminated(other: float | None) -> bool:
    """Whether other processes used more than :data:`OTHER_CORES_LIMIT` cores meanwhile."""
    return other is not None and other > OTHER_CORES_LIMIT


# ----------------------------------------------------------------------------- multipart

def multipart_body(fields: dict[str, str], files: dict[str, tuple[str, bytes, str]],
                   boundary: str) -> bytes:
    """A ``multipart/form-data`` body: text ``fields`` (name -> value), then ``files`` (name ->
    (filename, bytes, content type)), separated by ``boundary`` (which no part may contain)."""
    marker = f"--{boundary}".encode()
    parts: list[bytes] = []
    for name, value in fields.items():
        parts += [marker, b"\r\n", f'Content-Disposition: form-data; name="{name}"\r\n\r\n'
                  .encode(), value.encode(), b"\r\n"]
    for name, (filename, data, ctype) in files.items():
        if marker in data:
            raise ValueError(f"{name}: the boundary {boundary!r} occurs in the file's bytes")
        parts += [marker, b"\r\n",
                  f'Content-Disposition: form-data; name="{name}"; filename="{filename}"\r\n'
                  f"Content-Type: {ctype}\r\n\r\n".encode(), data, b"\r\n"]
    parts += [marker, b"--\r\n"]
    return b"".join(parts)


# ----------------------------------------------------------------------------- data

@dataclass
class Pair:
    """One seeded stereo pair: the scene, its garment (the model searched for), the seed,
    the uploaded files' bytes and their decoded images, and its pre-encoded request."""

    scene: str
    model: str
    seed: int
    right: bytes
    left: bytes
    right_bgr: np.ndarray = field(repr=False)
    left_bgr: np.ndarray = field(repr=False)
    body: bytes = field(default=b"", repr=False)
    content_type: str = ""


@dataclass(frozen=True)
class Data:
    """The simulated cell: calibration, library and pairs."""

    stereo: Path
    library: Path
    pairs: list[Pair]


def _log(msg: str) -> None:
    print(msg, file=sys.stderr, flush=True)


def _cli(args: list[str]) -> None:
    from photomodel.cli import main as cli_main

    rc = cli_main(args)
    if rc != 0:
        raise RuntimeError(f"photomodel {' '.join(args)}: exit code {rc}")


def prepare_data(work: Path, garments: Sequence[str], scenes: int, seed: int,
                 upload: str) -> Data:
    """Simulate the scenes, build and register the models (replacing an earlier ``work`` of
    this benchmark), read the pairs and encode their requests."""
    import cv2

    from photomodel.image import decode_color_image

    if work.exists():
        if not (work / STAMP).is_file() and any(work.iterdir()):
            raise SystemExit(f"--work {work}: exists and is not this benchmark's directory "
                             f"(no {STAMP}); give an empty or new directory")
        shutil.rmtree(work)
    work.mkdir(parents=True)
    (work / STAMP).write_text(json.dumps({"garments": list(garments), "scenes": scenes,
                                          "seed": seed}))
    dataset = work / "data"
    _cli(["simulate", "--out", str(dataset), "--garments", ",".join(garments), "--scenes",
          str(scenes), "--seed", str(seed)])
    built = []
    for g in garments:
        folder = dataset / "models" / g
        out = work / f"{g}.model"
        _cli(["build", "--photo", str(folder / "photo.bmp"), "--background",
              str(folder / "background.bmp"), "--camera", str(dataset / "model_camera.yaml"),
              "--out", str(out), "--name", g, "--no-preview"])
        built.append(str(out))
    library = work / "library"
    _cli(["models", "add", "--models", str(library), *built])
    truth = json.loads((dataset / "truth.json").read_text())
    boundary = f"photomodel-bench-{seed:010d}-boundary"
    pairs = []
    for j, scene in enumerate(sorted(truth)):
        files = []
        for side in ("right", "left"):
            data = (dataset / "scenes" / scene / f"{side}.png").read_bytes()
            if upload == "bmp":
                image = decode_color_image(data, side)
                ok, buf = cv2.imencode(".bmp", image)
                if not ok:  # pragma: no cover - OpenCV writes any uint8 BGR image as BMP
                    raise RuntimeError(f"{scene}: cannot encode {side} as BMP")
                data = buf.tobytes()
            files.append(data)
        right, left = files
        pair = Pair(scene, truth[scene]["model"], j, right, left,
                    decode_color_image(right, "right"), decode_color_image(left, "left"))
        ctype = "image/png" if upload == "png" else "image/bmp"
        pair.body = multipart_body({"model": pair.model, "seed": str(pair.seed)},
                                   {"right": (f"right.{upload}", right, ctype),
                                    "left": (f"left.{upload}", left, ctype)}, boundary)
        pair.content_type = f"multipart/form-data; boundary={boundary}"
        pairs.append(pair)
    return Data(dataset / "stereo.yaml", library, pairs)


# ----------------------------------------------------------------------------- in process

class InProcess:
    """The in-process baseline: a Locator per model with the service's threshold."""

    def __init__(self, data: Data) -> None:
        import photomodel as pm
        from photomodel.locate import load_threshold

        library = pm.ModelLibrary(data.library)
        models, skipped = library.load()
        if skipped:
            raise RuntimeError(f"the library skipped models: {skipped}")
        min_score = load_threshold(None, library=library.root).min_score
        rig = pm.load_stereo(data.stereo)
        t0 = time.perf_counter()
        self.locators = {m.name: pm.Locator(m, rig, min_score=min_score) for m in models}
        self.prepare_s = time.perf_counter() - t0
        self.min_score = min_score
        self.pairs = data.pairs
        self.poses: list[Any] = [None] * len(data.pairs)
        self.found: list[bool] = [False] * len(data.pairs)
        self.rounds: list[dict[str, Any]] = []
        self._samples: list[tuple[list[float], list[float]]] = []

    def warm(self) -> float:
        """One call per pair (kernels loaded, buffers made); records each pair's pose. The
        seconds it took."""
        t0 = time.perf_counter()
        for j, p in enumerate(self.pairs):
            result = self.locators[p.model](p.right_bgr, p.left_bgr, rng=p.seed)
            self.poses[j] = result.T_cam1_model.tolist()
            self.found[j] = bool(result.found)
        return time.perf_counter() - t0

    def round(self, calls: int, label: str) -> dict[str, Any]:
        """``calls`` timed calls of every pair, each as ``locate`` and as ``decode_locate``;
        the poses checked against the warm-up's. The round's summary."""
        from photomodel.image import decode_color_image

        locate_s, decode_locate_s, worst = [], [], 0.0
        load = _loadavg()
        busy0, own0, wall0 = busy_cpu_s(), time.process_time(), time.perf_counter()
        for _ in range(calls):
            for j, p in enumerate(self.pairs):
                locator = self.locators[p.model]
                t0 = time.perf_counter()
                r1 = locator(p.right_bgr, p.left_bgr, rng=p.seed)
                t1 = time.perf_counter()
                right = decode_color_image(p.right, "right")
                left = decode_color_image(p.left, "left")
                r2 = locator(right, left, rng=p.seed)
                t2 = time.perf_counter()
                locate_s.append(t1 - t0)
                decode_locate_s.append(t2 - t1)
                for r in (r1, r2):
                    d = pose_difference(r.T_cam1_model, self.poses[j])
                    worst = max(worst, float("inf") if d is None else d)
        busy1 = busy_cpu_s()
        other = other_cores(None if busy0 is None or busy1 is None else busy1 - busy0,
                            time.process_time() - own0, time.perf_counter() - wall0)
        out = {"label": label, "loadavg_before": load, "other_cores": other,
               "contaminated": contaminated(other), "locate_ms": summarise_ms(locate_s),
               "decode_locate_ms": summarise_ms(decode_locate_s),
               "pose_max_abs_diff_vs_warmup": worst, "kept": True}
        self.rounds.append(out)
        self._samples.append((locate_s, decode_locate_s))
        return out

    def discard_last(self) -> None:
        """Leave the last round's times out of the pooled figures (it stays listed, with
        ``kept`` false)."""
        self.rounds[-1]["kept"] = False

    @property
    def locate_s(self) -> list[float]:
        """Every kept round's ``locate`` times, s."""
        return [v for r, (a, _) in zip(self.rounds, self._samples, strict=True) if r["kept"]
                for v in a]

    @property
    def decode_locate_s(self) -> list[float]:
        """Every kept round's ``decode_locate`` times, s."""
        return [v for r, (_, b) in zip(self.rounds, self._samples, strict=True) if r["kept"]
                for v in b]


# ----------------------------------------------------------------------------- the service

def _loadavg() -> list[float] | None:
    try:
        return [float(v) for v in Path("/proc/loadavg").read_text().split()[:3]]
    except OSError:
        return None


def busy_cpu_s() -> float | None:
    """CPU seconds the whole machine has been busy (every core; ``/proc/stat``: all but idle
    and iowait), None where it cannot be read."""
    try:
        first = Path("/proc/stat").read_text().splitlines()[0].split()
    except (OSError, IndexError):
        return None
    ticks = [int(v) for v in first[1:9]]       # user nice system idle iowait irq softirq steal
    return (sum(ticks) - ticks[3] - ticks[4]) / os.sysconf("SC_CLK_TCK")


def free_port() -> int:
    """A TCP port free on the loopback interface now."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


class ServiceProcess:
    """``python -m photomodel serve`` in a child process on a free loopback port."""

    def __init__(self, stereo: Path, library: Path, searches: int, log_path: Path,
                 env: dict[str, str] | None = None, extra: Sequence[str] = ()) -> None:
        self.port = free_port()
        self.env = env
        self.url = f"http://127.0.0.1:{self.port}"
        self.searches = searches
        self.log_path = log_path
        self.cmd = [sys.executable, "-m", "photomodel", "serve", "--stereo", str(stereo),
                    "--models", str(library), "--port", str(self.port), "--searches",
                    str(searches), "--log-level", "warning", *extra]
        self.proc: subprocess.Popen[bytes] | None = None

    def start(self, timeout_s: float = 600.0) -> float:
        """Start the process and wait until ``/health`` says ``ok``; the seconds that took."""
        import httpx

        self.log_path.parent.mkdir(parents=True, exist_ok=True)
        log = self.log_path.open("wb")
        t0 = time.perf_counter()
        self.proc = subprocess.Popen(self.cmd, stdout=log, stderr=subprocess.STDOUT,
                                     cwd=REPO, env=self.env)
        log.close()
        deadline = time.monotonic() + timeout_s
        while True:
            if self.proc.poll() is not None:
                raise RuntimeError(f"the service exited ({self.proc.returncode}): "
                                   f"{self.log_tail()}")
            try:
                health = httpx.get(self.url + "/health", timeout=5.0).json()
                if health.get("status") == "ok":
                    return time.perf_counter() - t0
                if health.get("status") == "failed":
                    raise RuntimeError(f"the service failed to warm up: {health}")
            except httpx.HTTPError:
                pass
            if time.monotonic() > deadline:
                raise RuntimeError(f"the service was not ready in {timeout_s:.0f} s")
            time.sleep(0.1)

    def health(self) -> dict[str, Any]:
        import httpx

        return httpx.get(self.url + "/health", timeout=10.0).json()

    def _status(self) -> dict[str, int]:
        assert self.proc is not None
        out = {}
        for line in Path(f"/proc/{self.proc.pid}/status").read_text().splitlines():
            key, _, value = line.partition(":")
            if key in ("VmRSS", "VmHWM", "Threads"):
                out[key] = int(value.split()[0])
        return out

    def memory_mib(self) -> dict[str, float]:
        """Resident memory now (``rss``) and its peak so far (``hwm``), MiB; and threads."""
        s = self._status()
        return {"rss": s["VmRSS"] / 1024.0, "hwm": s["VmHWM"] / 1024.0,
                "threads": float(s["Threads"])}

    def cpu_s(self) -> float:
        """CPU seconds the process has used (user + system, all threads)."""
        assert self.proc is not None
        text = Path(f"/proc/{self.proc.pid}/stat").read_text()
        fields = text[text.rindex(")") + 2:].split()
        return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")

    def log_tail(self, chars: int = 2000) -> str:
        try:
            return self.log_path.read_text(errors="replace")[-chars:]
        except OSError:
            return ""

    def stop(self) -> int | None:
        """Interrupt the process (uvicorn shuts down gracefully), kill it if it lingers; its
        exit code."""
        if self.proc is None or self.proc.poll() is not None:
            return None if self.proc is None else self.proc.returncode
        self.proc.send_signal(signal.SIGINT)    # as Ctrl-C: the CLI then exits with 130
        try:
            return self.proc.wait(timeout=15)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            return self.proc.wait(timeout=15)


# ----------------------------------------------------------------------------- load

@dataclass
class Sample:
    """One request: its pair, status (None: no answer), latency, the locate's own seconds as
    the service reports them, the pose difference to in-process and an error message."""

    pair: int
    status: int | None
    seconds: float
    locate_seconds: float | None = None
    pose_diff: float | None = None
    error: str | None = None


def _client(url: str, pairs: list[Pair], order: list[int], reference: list[Any],
            barrier: threading.Barrier, out: list[Sample]) -> None:
    import httpx

    with httpx.Client(base_url=url, timeout=REQUEST_TIMEOUT_S) as client:
        barrier.wait()
        for j in order:
            p = pairs[j]
            t0 = time.perf_counter()
            try:
                r = client.post("/locate", content=p.body,
                                headers={"content-type": p.content_type})
                answer = r.json()
                dt = time.perf_counter() - t0
            except (httpx.HTTPError, ValueError) as exc:
                out.append(Sample(j, None, time.perf_counter() - t0,
                                  error=f"{type(exc).__name__}: {exc}"))
                continue
            if r.status_code != 200:
                out.append(Sample(j, r.status_code, dt, error=str(answer.get("error"))[:300]))
                continue
            out.append(Sample(j, 200, dt, answer.get("seconds"),
                              pose_difference(answer.get("T_cam1_model"), reference[j])))


def _health_poller(url: str, stop: threading.Event, out: list[tuple[float, bool]]) -> None:
    import httpx

    with httpx.Client(base_url=url, timeout=10.0) as client:
        while not stop.is_set():
            t0 = time.perf_counter()
            try:
                ok = client.get("/health").json().get("status") == "ok"
            except (httpx.HTTPError, ValueError):
                ok = False
            dt = time.perf_counter() - t0
            out.append((dt, ok))
            stop.wait(max(0.0, HEALTH_PERIOD_S - dt))


def load_pass(service: ServiceProcess, pairs: list[Pair], reference: list[Any], clients: int,
              requests: int, poll_health: bool) -> dict[str, Any]:
    """``clients`` threads posting ``requests`` each, all at once: the pass's raw record
    (``latency_s``, ``locate_s``, ``pose_diffs``, ``errors``, ``health`` (seconds, ok) or None,
    ``wall_s``, CPU seconds of the service and of this process, ``other_cores``, load average
    and the service's memory after); :func:`summarise_passes` pools records."""
    orders = client_orders(clients, requests, len(pairs))
    results: list[list[Sample]] = [[] for _ in range(clients)]
    barrier = threading.Barrier(clients + 1)
    threads = [threading.Thread(target=_client, args=(service.url, pairs, orders[c], reference,
                                                      barrier, results[c]),
                                name=f"bench-client-{c}") for c in range(clients)]
    health: list[tuple[float, bool]] = []
    stop = threading.Event()
    poller = threading.Thread(target=_health_poller, args=(service.url, stop, health),
                              name="bench-health")
    load_before = _loadavg()
    for t in threads:
        t.start()
    cpu_server0, cpu_client0, busy0 = service.cpu_s(), time.process_time(), busy_cpu_s()
    if poll_health:
        poller.start()
    barrier.wait()
    t0 = time.perf_counter()
    for t in threads:
        t.join()
    wall = time.perf_counter() - t0
    stop.set()
    if poll_health:
        poller.join()
    cpu_server, cpu_client = service.cpu_s() - cpu_server0, time.process_time() - cpu_client0
    busy1 = busy_cpu_s()
    samples = [s for r in results for s in r]
    ok = [s for s in samples if s.status == 200]
    return {
        "clients": clients, "requests": len(samples), "wall_s": wall,
        "latency_s": [s.seconds for s in ok],
        "locate_s": [s.locate_seconds for s in ok if s.locate_seconds is not None],
        "pose_diffs": [s.pose_diff for s in ok],
        "errors": [f"{s.status}: {s.error}" for s in samples if s.status != 200],
        "health": health if poll_health else None,
        "cpu_server_s": cpu_server, "cpu_client_s": cpu_client,
        "other_cores": other_cores(None if busy0 is None or busy1 is None else busy1 - busy0,
                                   cpu_server + cpu_client, wall),
        "loadavg_before": load_before, "loadavg_after": _loadavg(),
        "rss_after_mib": service.memory_mib()["rss"],
    }


def summarise_passes(records: Sequence[dict[str, Any]]) -> dict[str, Any]:
    """The figures of one (searches, clients) setting pooled over its passes (rounds):
    latency percentiles over every request, throughput = requests / summed wall time, errors,
    pose agreement, CPU per request, other processes' cores (wall-weighted), ``/health``
    latency when polled, and each round's own throughput and p50."""
    n = sum(r["requests"] for r in records)
    wall = sum(r["wall_s"] for r in records)
    latency = [v for r in records for v in r["latency_s"]]
    errors = [e for r in records for e in r["errors"]]
    diffs = [d for r in records for d in r["pose_diffs"]]
    others = [(r["other_cores"], r["wall_s"]) for r in records if r["other_cores"] is not None]
    other = (sum(o * w for o, w in others) / sum(w for _, w in others)
             if others and sum(w for _, w in others) > 0 else None)
    cpu_server = sum(r["cpu_server_s"] for r in records)
    out: dict[str, Any] = {
        "clients": records[0]["clients"] if records else None, "requests": n,
        "errors": len(errors), "error_samples": sorted(set(errors))[:5],
        "wall_s": wall, "throughput_rps": n / wall if wall > 0 else None,
        "latency_ms": summarise_ms(latency),
        "locate_seconds_ms": summarise_ms([v for r in records for v in r["locate_s"]]),
        "pose_max_abs_diff": (None if not diffs or any(d is None for d in diffs)
                              else float(max(diffs))),
        "poses_differing": sum(1 for d in diffs if d is None or d > 1e-9),
        "server_cpu_ms_per_request": 1000.0 * cpu_server / n if n else None,
        "client_cpu_ms_per_request": (1000.0 * sum(r["cpu_client_s"] for r in records) / n
                                      if n else None),
        "server_cpu_cores": cpu_server / wall if wall > 0 else None,
        "other_cores": other, "contaminated": contaminated(other),
        "rounds": [{"round": r.get("round"), "requests": r["requests"], "wall_s": r["wall_s"],
                    "throughput_rps": r["requests"] / r["wall_s"] if r["wall_s"] > 0 else None,
                    "p50_ms": summarise_ms(r["latency_s"])["p50"],
                    "other_cores": r["other_cores"], "loadavg_before": r["loadavg_before"],
                    "rss_after_mib": r["rss_after_mib"]} for r in records],
        "samples_ms": [round(v * 1000.0, 3) for v in latency],
    }
    polled = [h for r in records if r["health"] is not None for h in r["health"]]
    if any(r["health"] is not None for r in records):
        out["health_ms"] = summarise_ms([dt for dt, _ in polled])
        out["health_not_ok"] = sum(1 for _, good in polled if not good)
        out["health_over_50ms"] = sum(1 for dt, _ in polled if dt * 1000.0 > TARGET_HEALTH_MS)
    return out


def warm_service(service: ServiceProcess, pairs: list[Pair], reference: list[Any],
                 clients: int) -> dict[str, Any]:
    """Every pair once, then ``2 x clients`` requests from ``clients`` threads (the worker
    threads made, the ring of results filled); its errors and the idle ``/health`` latency."""
    import httpx

    first = summarise_passes([load_pass(service, pairs, reference, 1, len(pairs), False)])
    rest = summarise_passes([load_pass(service, pairs, reference, clients,
                                       max(2, 2 * len(pairs) // clients), False)])
    idle = []
    with httpx.Client(base_url=service.url, timeout=10.0) as client:
        for _ in range(20):
            t0 = time.perf_counter()
            client.get("/health")
            idle.append(time.perf_counter() - t0)
            time.sleep(0.01)
    return {"requests": first["requests"] + rest["requests"],
            "errors": first["errors"] + rest["errors"],
            "error_samples": first["error_samples"] + rest["error_samples"],
            "first_pass_latency_ms": first["latency_ms"],
            "pose_max_abs_diff": max(first["pose_max_abs_diff"] or 0.0,
                                     rest["pose_max_abs_diff"] or 0.0),
            "idle_health_ms": summarise_ms(idle)}


# ----------------------------------------------------------------------------- the benchmark

def split_requests(total: int, rounds: int) -> list[int]:
    """``total`` requests per client over ``rounds`` rounds, as even as may be (the first
    rounds take the remainder); rounds left with none are dropped."""
    if total < 1 or rounds < 1:
        raise ValueError(f"expected total >= 1 and rounds >= 1, got {total}, {rounds}")
    base, extra = divmod(total, rounds)
    return [base + (1 if k < extra else 0) for k in range(rounds) if base + (k < extra) > 0]


def round_order(settings: Sequence[int], round_index: int) -> list[int]:
    """The ``--searches`` settings in round ``round_index``: rotated by one each round, so
    that none is always measured first or last."""
    k = round_index % len(settings)
    return list(settings[k:]) + list(settings[:k])


def baseline_round(base: InProcess, args: argparse.Namespace, label: str) -> None:
    """One in-process round, repeated (up to ``--retry-contaminated`` times, the earlier
    attempts discarded) while other processes were busy."""
    for attempt in range(args.retry_contaminated + 1):
        b = base.round(args.baseline_calls, label)
        _log(f"{label}: in process locate p50 {_fmt(b['locate_ms']['p50'])} ms, decode+locate "
             f"p50 {_fmt(b['decode_locate_ms']['p50'])} ms (others "
             f"{_fmt(b['other_cores'], 2)} cores)")
        if not b["contaminated"] or attempt == args.retry_contaminated:
            return
        base.discard_last()
        time.sleep(args.retry_wait)


def run(args: argparse.Namespace) -> dict[str, Any]:
    """The benchmark with parsed arguments; its JSON object."""
    import numba

    cores = os.cpu_count() or 1
    meta = metadata("service", args.seed)
    meta["loadavg_before"] = _loadavg()
    _log(f"simulating {len(args.garments)} garment(s) x {args.scenes} scene(s), building the "
         f"library in {args.work} ...")
    data = prepare_data(args.work, args.garments, args.scenes, args.seed, args.upload)
    base = InProcess(data)
    warm_s = base.warm()
    _log(f"in process: {len(base.locators)} locators prepared in {base.prepare_s:.1f} s, "
         f"warmed on {len(data.pairs)} pairs in {warm_s:.1f} s")
    env = {**os.environ, **args.service_env}
    running = {n: ServiceProcess(data.stereo, data.library, n,
                                 args.out.parent / f"service-{n}.log", env)
               for n in args.searches}
    info: dict[int, dict[str, Any]] = {}
    records: dict[tuple[int, int], list[dict[str, Any]]] = {
        (n, c): [] for n in args.searches for c in args.clients}
    discarded: dict[tuple[int, int], list[dict[str, Any]]] = {k: [] for k in records}
    try:
        for n, service in running.items():        # one at a time: start-up is timed
            ready_s = service.start()
            health = service.health()
            mem_ready = service.memory_mib()
            warm = warm_service(service, data.pairs, base.poses, max(args.clients))
            info[n] = {"ready_s": ready_s, "health_at_ready": health,
                       "searches_effective": health.get("searches"), "warmup": warm,
                       "memory_ready": mem_ready}
            _log(f"service searches={n}: ready in {ready_s:.1f} s (health says searches="
                 f"{health.get('searches')}), RSS {mem_ready['rss']:.0f} MiB at ready")
        time.sleep(1.0)
        for n, service in running.items():
            info[n]["memory_before"] = service.memory_mib()
        for r, requests in enumerate(split_requests(args.requests, args.rounds)):
            baseline_round(base, args, f"round {r}")
            for n in round_order(args.searches, r):
                for clients in args.clients:
                    for attempt in range(args.retry_contaminated + 1):
                        rec = load_pass(running[n], data.pairs, base.poses, clients, requests,
                                        poll_health=clients >= 4)
                        rec["round"] = r
                        lat = summarise_ms(rec["latency_s"])
                        _log(f"  searches={n} clients={clients}: {rec['requests']} requests, "
                             f"{len(rec['errors'])} errors, p50 {_fmt(lat['p50'])} ms, max "
                             f"{_fmt(lat['max'])} ms, {rec['requests'] / rec['wall_s']:.1f} "
                             f"req/s (others {_fmt(rec['other_cores'], 2)} cores)")
                        if (not contaminated(rec["other_cores"])
                                or attempt == args.retry_contaminated):
                            records[(n, clients)].append(rec)
                            break
                        discarded[(n, clients)].append(rec)
                        _log(f"  ... other processes were busy: again in "
                             f"{args.retry_wait:.0f} s")
                        time.sleep(args.retry_wait)
        baseline_round(base, args, "after")
        time.sleep(1.0)
        for n, service in running.items():
            info[n]["memory_after"] = service.memory_mib()
            info[n]["log_tail"] = service.log_tail(1000)
    finally:
        for n, service in running.items():
            code = service.stop()
            if n in info:
                info[n]["exit_code"] = code
    in_process = {"prepare_s": base.prepare_s, "warm_s": warm_s, "min_score": base.min_score,
                  "numba_threads": numba.get_num_threads(),
                  "numba_threading_layer": numba.threading_layer(),
                  "locate_ms": summarise_ms(base.locate_s),
                  "decode_locate_ms": summarise_ms(base.decode_locate_s),
                  "rounds": base.rounds, "found": base.found}
    ref, ref_decode = in_process["locate_ms"]["p50"], in_process["decode_locate_ms"]["p50"]
    services = []
    for n in args.searches:
        s = info[n]
        passes = []
        for clients in args.clients:
            p = summarise_passes(records[(n, clients)])
            thrown = discarded[(n, clients)]
            p["discarded"] = (summarise_passes(thrown)["rounds"] if thrown else [])
            p["ratio_p50_to_in_process"] = ratio(p["latency_ms"]["p50"], ref)
            p["ratio_p50_to_decode_locate"] = ratio(p["latency_ms"]["p50"], ref_decode)
            passes.append(p)
        before, after = s["memory_before"]["rss"], s["memory_after"]["rss"]
        services.append({
            "searches": n, "searches_effective": s["searches_effective"],
            "ready_s": s["ready_s"], "health_at_ready": s["health_at_ready"],
            "warmup": s["warmup"],
            "memory_mib": {"at_ready": s["memory_ready"], "before": s["memory_before"],
                           "after": s["memory_after"]},
            "rss_growth": growth(before, after),
            "rss_growth_from_ready": growth(s["memory_ready"]["rss"], after),
            "rss_trace_mib": [before] + [rec["rss_after_mib"] for r in range(args.rounds)
                                         for c in args.clients
                                         for rec in records[(n, c)] if rec["round"] == r],
            "passes": passes, "exit_code": s.get("exit_code"),
            "log": str(running[n].log_path), "log_tail": s.get("log_tail", "")})
    result = {
        "meta": meta,
        "settings": {"searches": list(args.searches), "clients": list(args.clients),
                     "requests_per_client": args.requests, "rounds": args.rounds,
                     "retry_contaminated": args.retry_contaminated,
                     "retry_wait_s": args.retry_wait,
                     "baseline_calls": args.baseline_calls, "garments": list(args.garments),
                     "scenes_per_garment": args.scenes, "upload": args.upload,
                     "service_env": args.service_env, "work": str(args.work),
                     "health_period_s": HEALTH_PERIOD_S, "cores": cores,
                     "environment": {k: os.environ.get(k) for k in
                                     ("NUMBA_NUM_THREADS", "NUMBA_THREADING_LAYER",
                                      "OMP_NUM_THREADS", "OMP_WAIT_POLICY")}},
        "data": {"stereo": str(data.stereo), "library": str(data.library),
                 "pairs": [{"scene": p.scene, "model": p.model, "seed": p.seed,
                            "right_bytes": len(p.right), "left_bytes": len(p.left),
                            "body_bytes": len(p.body)} for p in data.pairs]},
        "in_process": in_process,
        "services": services,
    }
    result["targets"] = targets(result)
    if args.faces:       # after the load passes: their services are stopped by now
        result["faces"] = run_faces(args, data, base, env)
        result["targets"].update({f"faces_{k}": v for k, v in
                                  result["faces"]["targets"].items()})
    meta["loadavg_after"] = _loadavg()
    return result


def targets(result: dict[str, Any]) -> dict[str, Any]:
    """The issue's targets, each with its figures and a verdict."""
    services = result["services"]
    p50_1 = {str(s["searches"]): p["ratio_p50_to_in_process"] for s in services
             for p in s["passes"] if p["clients"] == 1}
    errors = sum(p["errors"] for s in services for p in s["passes"])
    errors += sum(s["warmup"]["errors"] for s in services)
    rss = {str(s["searches"]): s["rss_growth"] for s in services}
    health = {f"searches={s['searches']},clients={p['clients']}": p["health_ms"]
              for s in services for p in s["passes"] if "health_ms" in p}
    four = [p["health_ms"]["max"] for s in services for p in s["passes"]
            if "health_ms" in p and s["searches_effective"] is not None
            and min(s["searches_effective"], p["clients"]) >= 4]
    poses = [p["pose_max_abs_diff"] for s in services for p in s["passes"]]
    worst_pose = None if any(d is None for d in poses) or not poses else max(poses)
    return {
        "p50_one_client": {"criterion": f"p50 / in-process median <= {TARGET_P50_RATIO}",
                           "by_searches": p50_1,
                           "verdicts": {k: at_most(v, TARGET_P50_RATIO)
                                        for k, v in p50_1.items()}},
        "errors": {"criterion": "0 errors", "count": errors,
                   "verdict": "pass" if errors == 0 else "fail"},
        "rss_growth": {"criterion": f"growth < {TARGET_RSS_GROWTH:.0%}", "by_searches": rss,
                       "verdicts": {k: at_most(v, TARGET_RSS_GROWTH) for k, v in rss.items()}},
        "health_while_four_search": {
            "criterion": f"every /health within {TARGET_HEALTH_MS:.0f} ms with 4 searches "
                         "running", "max_ms": max(four) if four else None,
            "by_pass": health,
            "verdict": at_most(max(four), TARGET_HEALTH_MS) if four else "n/a"},
        "same_pose": {"criterion": "the service's pose equals in-process (max abs diff "
                                   "<= 1e-9)", "max_abs_diff": worst_pose,
                      "verdict": at_most(worst_pose, 1e-9)},
    }


def finite(obj: Any) -> Any:
    """``obj`` with every NaN or infinity as None (strict JSON); ``poses_differing`` keeps
    the count of poses that differ."""
    if isinstance(obj, float):
        return obj if np.isfinite(obj) else None
    if isinstance(obj, dict):
        return {k: finite(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [finite(v) for v in obj]
    return obj


def _fmt(value: float | None, digits: int = 1) -> str:
    return "-" if value is None else f"{value:.{digits}f}"


def render_table(result: dict[str, Any]) -> str:
    """The passes as a text table, then the in-process figures, memory and targets."""
    head = (f"{'searches':>8} {'clients':>7} {'n':>5} {'err':>4} {'p50 ms':>7} {'p90 ms':>7} "
            f"{'p99 ms':>7} {'max ms':>7} {'req/s':>6} {'p50/inp':>7} {'p50/dec':>7} "
            f"{'srvCPU':>6} {'health p99/max':>14}")
    lines = [head, "-" * len(head)]
    for s in result["services"]:
        for p in s["passes"]:
            lat = p["latency_ms"]
            h = p.get("health_ms")
            hs = f"{_fmt(h['p99'])}/{_fmt(h['max'])}" if h else ""
            lines.append(
                f"{s['searches']:>8} {p['clients']:>7} {p['requests']:>5} {p['errors']:>4} "
                f"{_fmt(lat['p50']):>7} {_fmt(lat['p90']):>7} {_fmt(lat['p99']):>7} "
                f"{_fmt(lat['max']):>7} {_fmt(p['throughput_rps']):>6} "
                f"{_fmt(p['ratio_p50_to_in_process'], 2):>7} "
                f"{_fmt(p['ratio_p50_to_decode_locate'], 2):>7} "
                f"{_fmt(p['server_cpu_ms_per_request']):>6} {hs:>14}"
                + (f"  (others used {p['other_cores']:.2f} cores)" if p["contaminated"]
                   else "")
                + (f"  [{len(p['discarded'])} repeated]" if p.get("discarded") else ""))
    ip = result["in_process"]
    lines.append("")
    lines.append(f"in process: locate p50 {_fmt(ip['locate_ms']['p50'])} ms, p99 "
                 f"{_fmt(ip['locate_ms']['p99'])} ms; decode+locate p50 "
                 f"{_fmt(ip['decode_locate_ms']['p50'])} ms (n {ip['locate_ms']['n']}; rounds "
                 + ", ".join(_fmt(r["locate_ms"]["p50"]) + ("" if r.get("kept", True) else "*")
                             for r in ip["rounds"]) + " ms; * discarded)")
    for s in result["services"]:
        m = s["memory_mib"]
        lines.append(f"searches={s['searches']}: ready in {s['ready_s']:.1f} s; RSS at ready "
                     f"{m['at_ready']['rss']:.0f} MiB, before {m['before']['rss']:.0f}, after "
                     f"{m['after']['rss']:.0f} MiB (growth {_fmt(100 * s['rss_growth'], 2)} %)")
    t = result["targets"]
    lines.append("")
    lines.append("targets: p50/in-process (1 client) "
                 + ", ".join(f"searches={k}: {_fmt(v, 2)} {t['p50_one_client']['verdicts'][k]}"
                             for k, v in t["p50_one_client"]["by_searches"].items())
                 + f"; errors {t['errors']['count']} {t['errors']['verdict']}; RSS growth "
                 + ", ".join(f"searches={k}: {t['rss_growth']['verdicts'][k]}"
                             for k in t["rss_growth"]["by_searches"])
                 + f"; /health max with 4 searches {_fmt(t['health_while_four_search']['max_ms'])}"
                 f" ms {t['health_while_four_search']['verdict']}; same pose "
                 f"{t['same_pose']['verdict']} (max diff {t['same_pose']['max_abs_diff']})")
    meta = result["meta"]
    lines.append(f"load average before {meta.get('loadavg_before')}, after "
                 f"{meta.get('loadavg_after')}; commit {str(meta.get('commit'))[:12]}")
    return "\n".join(lines)


def _int_list(text: str) -> list[int]:
    try:
        values = [int(v) for v in text.split(",") if v.strip()]
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected comma-separated integers, got {text!r}"
                                         ) from None
    if not values or any(v < 1 for v in values):
        raise argparse.ArgumentTypeError(f"expected integers of at least 1, got {text!r}")
    return values


def main(argv: Sequence[str] | None = None) -> dict[str, Any]:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--searches", type=_int_list, default=[1, 2, 4],
                    help="searches at once, one service per value (default 1,2,4)")
    ap.add_argument("--clients", type=_int_list, default=[1, 2, 4],
                    help="concurrent clients per pass (default 1,2,4)")
    ap.add_argument("--requests", type=int, default=None,
                    help="requests per client and pass (default 500; --quick 20)")
    ap.add_argument("--quick", action="store_true",
                    help=f"a short run: {QUICK_REQUESTS} requests per client, 1 baseline call")
    ap.add_argument("--rounds", type=int, default=2,
                    help="rounds the requests are split into; each round measures every "
                         "setting, in rotated order (default 2)")
    ap.add_argument("--retry-contaminated", type=int, default=0, metavar="K",
                    help="repeat a pass or baseline round up to K times while other processes "
                         f"use more than {OTHER_CORES_LIMIT} cores (default 0: keep every "
                         "pass); the discarded ones stay in the JSON")
    ap.add_argument("--retry-wait", type=float, default=10.0,
                    help="seconds to wait before such a repeat (default 10)")
    ap.add_argument("--service-env", action="append", default=[], metavar="NAME=VALUE",
                    help="environment variable for the service processes only (repeatable)")
    ap.add_argument("--baseline-calls", type=int, default=None,
                    help="in-process timed calls per pair and round (default 5; --quick 1)")
    ap.add_argument("--garments", type=lambda s: [g for g in s.split(",") if g],
                    default=list(DEFAULT_GARMENTS), help="garments (default No.3,No.5,No.7)")
    ap.add_argument("--scenes", type=int, default=4, help="scenes per garment (default 4)")
    ap.add_argument("--seed", type=int, default=11, help="simulation seed (default 11)")
    ap.add_argument("--upload", choices=["png", "bmp"], default="png",
                    help="file format posted: the dataset's PNGs, or the same pixels as BMP")
    ap.add_argument("--work", type=Path, default=DEFAULT_WORK,
                    help=f"data directory (replaced; default {DEFAULT_WORK.relative_to(REPO)})")
    ap.add_argument("--out", type=Path, default=DEFAULT_OUT,
                    help=f"JSON output (default {DEFAULT_OUT.relative_to(REPO)})")
    ap.add_argument("--faces", action=argparse.BooleanOptionalAction, default=True,
                    help="also measure the trigger path, raw uploads, OPC UA and a camera "
                         "stream (benchmarks/_faces.py; default on)")
    ap.add_argument("--faces-model", default=None,
                    help="garment of the trigger service's replay (default: the first)")
    ap.add_argument("--faces-requests", type=int, default=None,
                    help="requests per faces row (default 200; --quick 10)")
    ap.add_argument("--faces-work", type=Path, default=DEFAULT_FACES_WORK,
                    help="the stream's rendered sequence (kept and reused; default "
                         f"{DEFAULT_FACES_WORK.relative_to(REPO)})")
    ap.add_argument("--stream-seconds", type=float, default=None,
                    help="seconds of the camera stream counted (default 60; --quick 3)")
    ap.add_argument("--stream-sequence-s", type=float, default=2.0,
                    help="length of the rendered conveyor sequence, s (default 2)")
    ap.add_argument("--stream-warmup-s", type=float, default=5.0,
                    help="seconds of the camera stream before counting (default 5)")
    args = ap.parse_args(argv)
    if args.faces_requests is None:
        args.faces_requests = 10 if args.quick else 200
    if args.stream_seconds is None:
        args.stream_seconds = 3.0 if args.quick else 60.0
    if args.requests is None:
        args.requests = QUICK_REQUESTS if args.quick else 500
    if args.baseline_calls is None:
        args.baseline_calls = 1 if args.quick else 5
    if min(args.requests, args.baseline_calls, args.scenes, args.rounds) < 1:
        ap.error("--requests, --rounds, --baseline-calls and --scenes must be at least 1")
    if args.retry_contaminated < 0 or not args.retry_wait >= 0:
        ap.error("--retry-contaminated and --retry-wait must not be negative")
    env = {}
    for item in args.service_env:
        name, sep, value = item.partition("=")
        if not sep or not name:
            ap.error(f"--service-env: expected NAME=VALUE, got {item!r}")
        env[name] = value
    args.service_env = env
    args.out.parent.mkdir(parents=True, exist_ok=True)
    result = run(args)
    args.out.write_text(json.dumps(finite(result), indent=1, allow_nan=False) + "\n")
    print(render_table(result))
    if "faces" in result:
        print(render_faces(result["faces"]))
    print(f"wrote {args.out}")
    return result


if __name__ == "__main__":
    main()
