"""Benchmark: what TLS and the throttle cost a cell controller, through the service.

Two ``photomodel serve`` processes over one copy of a simulated library and one token file,
one plain and one with ``--tls-cert/--tls-key`` (made as ``photomodel certs`` makes them),
both warm.
``POST /locate`` with raw uploads (one ``application/octet-stream`` body of both views' BGR
pixels, fields in the query, each pair searched for its own garment with its own seed), one
request at a time, the two services in turn with the order alternating, so that the machine's
load falls on both alike:

``keepalive``  one connection per service for the whole run (a cell controller's client);
``connect``    a new connection per request (the TLS handshake in every request).

Then the throttle: on the TLS service, a client at another loopback address sends wrong
tokens (401 ten times, then 429) while the controller's ``/locate`` requests go on: 20 of
them (the issue's case), and a flood from a thread as fast as it can (on two cores the
flooding client itself takes a core); the controller's latency against the same requests
with nobody knocking.

Reported: p50, p90, p99 per row, the ratio of the p50s TLS / plain (target at most 1.10 for
``keepalive``, the issue's), and the throttle's ratio; JSON with the commit and versions.

Run: ``.venv/bin/python benchmarks/bench_tls.py`` (about 3 minutes on two cores).
Smoke: ``--requests 6``.
"""

from __future__ import annotations

import argparse
import json
import os
import socket
import ssl
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path
from typing import Any
from urllib.parse import urlencode

import numpy as np
from _meta import metadata

ADMIN = "bench-admin-token-0123456789"
TARGET = 1.10


def _log(msg: str) -> None:
    print(msg, file=sys.stderr, flush=True)


def _cli(*args: str) -> None:
    subprocess.run([sys.executable, "-m", "photomodel", *args], check=True,
                   stdout=subprocess.DEVNULL)


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def _stats(seconds: list[float]) -> dict[str, Any]:
    ms = np.asarray(seconds) * 1e3
    return {"n": len(ms), "p50_ms": float(np.median(ms)), "p90_ms": float(np.percentile(ms, 90)),
            "p99_ms": float(np.percentile(ms, 99)), "mean_ms": float(ms.mean())}


def prepare(work: Path, garments: list[str], scenes: int, seed: int) -> dict[str, Any]:
    """Scenes, a library of their garments, certificates and a token file."""
    import cv2

    data = work / "data"
    _cli("simulate", "--out", str(data), "--garments", ",".join(garments), "--scenes",
         str(scenes), "--seed", str(seed))
    for g in garments:
        d = data / "models" / g
        _cli("build", "--photo", str(d / "photo.bmp"), "--background",
             str(d / "background.bmp"), "--camera", str(data / "model_camera.yaml"), "--out",
             str(work / f"{g}.npz"), "--name", g, "--no-preview")
        _cli("models", "add", "--models", str(work / "library"), str(work / f"{g}.npz"))
    from photomodel.service import make_certs

    make_certs(work / "certs", ["localhost"])
    (work / "tokens.txt").write_text(f"admin {ADMIN} bench\n")
    truth = json.loads((data / "truth.json").read_text())
    pairs = []
    for k, (name, scene) in enumerate(sorted(truth.items())):
        right = cv2.imread(str(data / "scenes" / name / "right.png"))
        left = cv2.imread(str(data / "scenes" / name / "left.png"))
        query = urlencode({"model": scene["model"], "seed": k, "width": right.shape[1],
                           "height": right.shape[0], "pixel_format": "bgr8"})
        pairs.append((f"/locate?{query}", right.tobytes() + left.tobytes()))
    return {"data": data, "pairs": pairs}


class Service:
    """One ``photomodel serve`` subprocess."""

    def __init__(self, work: Path, tls: bool) -> None:
        self.port = _free_port()
        self.tls = tls
        self.url = f"{'https' if tls else 'http'}://127.0.0.1:{self.port}"
        args = ["serve", "--stereo", str(work / "data" / "stereo.yaml"), "--models",
                str(work / "library"), "--port", str(self.port), "--token-file",
                str(work / "tokens.txt"), "--searches", "1", "--log-level", "warning",
                "--audit-log", str(work / f"audit-{'tls' if tls else 'plain'}.jsonl")]
        if tls:
            args += ["--tls-cert", str(work / "certs" / "server.pem"), "--tls-key",
                     str(work / "certs" / "server.key")]
        self.log = open(work / f"serve-{'tls' if tls else 'plain'}.log", "w")  # noqa: SIM115
        self.proc = subprocess.Popen([sys.executable, "-m", "photomodel", *args],
                                     stdout=self.log, stderr=subprocess.STDOUT)

    def client(self, verify: ssl.SSLContext | bool, address: str = "127.0.0.1",
               token: str = ADMIN) -> Any:
        import httpx

        return httpx.Client(base_url=self.url, headers={"Authorization": f"Bearer {token}"},
                            timeout=120.0, transport=httpx.HTTPTransport(
                                local_address=address, verify=verify))

    def wait_ready(self, verify: ssl.SSLContext | bool, timeout_s: float = 300.0) -> None:
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            if self.proc.poll() is not None:
                raise RuntimeError(f"the service stopped (see {self.log.name})")
            try:
                with self.client(verify) as c:
                    if c.get("/health").json()["status"] == "ok":
                        return
            except Exception:  # noqa: BLE001 - not listening yet
                pass
            time.sleep(0.5)
        raise RuntimeError("the service did not warm up")

    def stop(self) -> None:
        self.proc.terminate()
        self.proc.wait(timeout=30)
        self.log.close()


def _post(client: Any, pair: tuple[str, bytes]) -> float:
    t0 = time.perf_counter()
    response = client.post(pair[0], content=pair[1],
                           headers={"Content-Type": "application/octet-stream"})
    dt = time.perf_counter() - t0
    if response.status_code != 200 or not response.json()["found"]:
        raise RuntimeError(f"{pair[0]}: {response.status_code} {response.text[:200]}")
    return dt


def latency_rows(services: dict[str, Service], verify: dict[str, Any],
                 pairs: list[tuple[str, bytes]], requests: int) -> dict[str, Any]:
    """``keepalive`` and ``connect`` rows, plain and TLS in turn."""
    out: dict[str, Any] = {}
    for row in ("keepalive", "connect"):
        samples: dict[str, list[float]] = {"plain": [], "tls": []}
        kept = {k: s.client(verify[k]) for k, s in services.items()}
        for _ in range(2):                               # untimed: connections, caches
            for k in services:
                _post(kept[k], pairs[0])
        for i in range(requests):
            order = ("plain", "tls") if i % 2 == 0 else ("tls", "plain")
            for k in order:
                time.sleep(0.02)
                if row == "keepalive":
                    samples[k].append(_post(kept[k], pairs[i % len(pairs)]))
                else:
                    with services[k].client(verify[k]) as fresh:
                        samples[k].append(_post(fresh, pairs[i % len(pairs)]))
        for c in kept.values():
            c.close()
        stats = {k: _stats(v) for k, v in samples.items()}
        ratio = stats["tls"]["p50_ms"] / stats["plain"]["p50_ms"]
        out[row] = {**stats, "ratio_p50": ratio,
                    "pairwise_ratio_median": float(np.median(np.asarray(samples["tls"])
                                                             / np.asarray(samples["plain"])))}
        _log(f"  {row}: plain p50 {stats['plain']['p50_ms']:.1f} ms, TLS p50 "
             f"{stats['tls']['p50_ms']:.1f} ms, ratio {ratio:.3f}")
    return out


def throttle_row(service: Service, verify: Any, pairs: list[tuple[str, bytes]],
                 requests: int) -> dict[str, Any]:
    """The controller's latency while another address sends wrong tokens: ``twenty`` (the
    issue's case: 20 wrong tokens, one before each of the first 20 timed requests, 401 ten
    times then 429) and ``flood`` (a thread sending them as fast as it can, from another
    address), each against ``quiet`` requests in turn."""
    out: dict[str, Any] = {}
    with service.client(verify) as c:
        _post(c, pairs[0])
        for row, address in (("twenty", "127.0.0.2"), ("flood", "127.0.0.3")):
            samples: dict[str, list[float]] = {"quiet": [], row: []}
            knocks: dict[int, int] = {}
            stop, knocking = threading.Event(), threading.Event()
            bad = service.client(verify, address=address, token="wrong-token-000000000")

            def knock(bad: Any = bad, knocks: dict[int, int] = knocks,
                      stop: threading.Event = stop, knocking: threading.Event = knocking
                      ) -> None:
                while not stop.is_set():
                    if knocking.wait(0.01):
                        status = bad.get("/health").status_code
                        knocks[status] = knocks.get(status, 0) + 1

            thread = threading.Thread(target=knock, daemon=True)
            if row == "flood":
                thread.start()
            for i in range(requests):
                for k in ("quiet", row) if i % 2 == 0 else (row, "quiet"):
                    if k == row and row == "twenty" and i < 20:
                        status = bad.get("/health").status_code
                        knocks[status] = knocks.get(status, 0) + 1
                    elif k == row:
                        knocking.set()
                        time.sleep(0.05)
                    samples[k].append(_post(c, pairs[i % len(pairs)]))
                    knocking.clear()
                    time.sleep(0.02)
            stop.set()
            if thread.is_alive():
                thread.join(timeout=10)
            bad.close()
            stats = {k: _stats(v) for k, v in samples.items()}
            ratio = stats[row]["p50_ms"] / stats["quiet"]["p50_ms"]
            _log(f"  throttle {row}: quiet p50 {stats['quiet']['p50_ms']:.1f} ms, with wrong "
                 f"tokens p50 {stats[row]['p50_ms']:.1f} ms (ratio {ratio:.3f}); {knocks}")
            out[row] = {**stats, "ratio_p50": ratio, "knocks_by_status": knocks}
    return out


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--garments", default="No.3,No.5,No.8")
    parser.add_argument("--scenes", type=int, default=2)
    parser.add_argument("--requests", type=int, default=60)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", type=Path,
                        default=Path(__file__).parent / "results" / "tls.json")
    args = parser.parse_args()
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        _log("tls: preparing data, library and certificates")
        prepared = prepare(work, args.garments.split(","), args.scenes, args.seed)
        verify = {"plain": False, "tls": ssl.create_default_context(
            cafile=str(work / "certs" / "ca.pem"))}
        services = {"plain": Service(work, tls=False), "tls": Service(work, tls=True)}
        try:
            for k, s in services.items():
                s.wait_ready(verify[k])
            _log("tls: both services ready")
            rows = latency_rows(services, verify, prepared["pairs"], args.requests)
            rows["throttle"] = throttle_row(services["tls"], verify["tls"], prepared["pairs"],
                                            max(4, args.requests // 2))
        finally:
            for s in services.values():
                s.stop()
    ratio = rows["keepalive"]["ratio_p50"]
    result = {"meta": metadata("tls", args.seed), "settings": vars(args) | {"out": str(args.out)},
              "body_bytes": len(prepared["pairs"][0][1]), "rows": rows,
              "targets": {"tls_keepalive_p50_ratio": {
                  "value": ratio, "target": f"<= {TARGET}",
                  "verdict": "pass" if ratio <= TARGET else "fail"}},
              "seconds": time.perf_counter() - t0, "loadavg": list(os.getloadavg())}
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(result, indent=1, default=str) + "\n")
    _log(f"tls: TLS / plain p50 (keep-alive) {ratio:.3f} (target <= {TARGET}); wrote "
         f"{args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
