"""The service load benchmark (``benchmarks/bench_service.py``): its statistics, pose
comparison, client schedule, multipart bodies (parsed by Starlette as the service parses them)
and a short run against a real ``photomodel serve`` process."""

from __future__ import annotations

import json
from pathlib import Path

import anyio
import numpy as np
import pytest
from benchmark_helpers import load_benchmark

load_benchmark("_meta")
load_benchmark("_faces")
bench_service = load_benchmark("bench_service")


def test_summarise_ms_gives_tails_only_with_enough_samples() -> None:
    few = bench_service.summarise_ms([0.003, 0.001, 0.002])
    assert few["n"] == 3 and few["p50"] == pytest.approx(2.0) and few["max"] == pytest.approx(3.0)
    assert few["p90"] is None and few["p99"] is None
    many = bench_service.summarise_ms(np.arange(100.0) / 1000.0)
    assert many["p90"] == pytest.approx(89.1) and many["p99"] == pytest.approx(98.01)
    empty = bench_service.summarise_ms([])
    assert empty["n"] == 0 and empty["p50"] is None and empty["max"] is None


def test_ratio_growth_and_verdicts() -> None:
    assert bench_service.ratio(26.0, 20.0) == pytest.approx(1.3)
    assert bench_service.ratio(1.0, None) is None and bench_service.ratio(1.0, 0.0) is None
    assert bench_service.growth(400.0, 420.0) == pytest.approx(0.05)
    assert bench_service.growth(None, 1.0) is None
    assert bench_service.at_most(1.3, 1.3) == "pass"
    assert bench_service.at_most(1.31, 1.3) == "fail"
    assert bench_service.at_most(None, 1.3) == "n/a"


def test_pose_difference_treats_no_pose_and_shapes() -> None:
    T = np.eye(4)
    T[:3, 3] = (10.0, -5.0, 700.0)
    moved = T.copy()
    moved[0, 3] += 0.25
    assert bench_service.pose_difference(T.tolist(), T) == 0.0
    assert bench_service.pose_difference(moved.tolist(), T) == pytest.approx(0.25)
    nothing = [[None] * 4 for _ in range(4)]                 # JSON of a NaN pose
    assert bench_service.pose_difference(nothing, np.full((4, 4), np.nan)) == 0.0
    assert bench_service.pose_difference(None, np.full((4, 4), np.nan)) == 0.0
    assert bench_service.pose_difference(nothing, T) == float("inf")
    assert bench_service.pose_difference([[1.0, 2.0]], T) is None


def test_client_orders_cycle_over_the_pairs_from_different_offsets() -> None:
    orders = bench_service.client_orders(4, 5, 12)
    assert [o[0] for o in orders] == [0, 3, 6, 9]
    assert orders[3] == [9, 10, 11, 0, 1]
    assert bench_service.client_orders(4, 2, 2) == [[0, 1], [1, 0], [0, 1], [1, 0]]
    with pytest.raises(ValueError, match="clients"):
        bench_service.client_orders(0, 5, 12)


def test_other_cores_and_contamination() -> None:
    assert bench_service.other_cores(12.0, 10.0, 4.0) == pytest.approx(0.5)
    assert bench_service.other_cores(9.0, 10.0, 4.0) == 0.0       # clock ticks: never < 0
    assert bench_service.other_cores(None, 1.0, 1.0) is None
    assert bench_service.contaminated(0.5) and not bench_service.contaminated(0.1)
    assert not bench_service.contaminated(None)


def test_requests_split_into_rounds_and_the_order_rotates() -> None:
    assert bench_service.split_requests(500, 2) == [250, 250]
    assert bench_service.split_requests(3, 2) == [2, 1]
    assert bench_service.split_requests(1, 3) == [1]             # no empty rounds
    with pytest.raises(ValueError, match="rounds"):
        bench_service.split_requests(5, 0)
    assert bench_service.round_order([1, 2, 4], 0) == [1, 2, 4]
    assert bench_service.round_order([1, 2, 4], 1) == [2, 4, 1]
    assert bench_service.round_order([1, 2, 4], 3) == [1, 2, 4]


def _record(latency_s: list[float], wall_s: float, other: float | None, errors: int = 0,
            health: list[tuple[float, bool]] | None = None) -> dict:
    return {"clients": 2, "requests": len(latency_s) + errors, "wall_s": wall_s,
            "latency_s": latency_s, "locate_s": [0.5 * v for v in latency_s],
            "pose_diffs": [0.0] * len(latency_s), "errors": ["503: warming"] * errors,
            "health": health, "cpu_server_s": 2.0 * wall_s, "cpu_client_s": 0.1 * wall_s,
            "other_cores": other, "loadavg_before": [0.5, 0.5, 0.5],
            "loadavg_after": [0.6, 0.5, 0.5], "rss_after_mib": 400.0, "round": 0}


def test_summarise_passes_pools_the_rounds() -> None:
    a = _record([0.010, 0.020, 0.030], wall_s=1.0, other=0.0)
    b = _record([0.040], wall_s=3.0, other=0.4, errors=1,
                health=[(0.002, True), (0.060, True), (0.004, False)])
    got = bench_service.summarise_passes([a, b])
    assert got["requests"] == 5 and got["errors"] == 1
    assert got["error_samples"] == ["503: warming"]
    assert got["throughput_rps"] == pytest.approx(5 / 4.0)
    assert got["latency_ms"]["n"] == 4 and got["latency_ms"]["p50"] == pytest.approx(25.0)
    assert got["locate_seconds_ms"]["p50"] == pytest.approx(12.5)
    assert got["other_cores"] == pytest.approx(0.3)         # weighted by wall time
    assert got["contaminated"]
    assert got["server_cpu_ms_per_request"] == pytest.approx(1000.0 * 8.0 / 5)
    assert got["pose_max_abs_diff"] == 0.0 and got["poses_differing"] == 0
    assert [r["throughput_rps"] for r in got["rounds"]] == [3.0, pytest.approx(2 / 3.0)]
    assert got["health_ms"]["n"] == 3 and got["health_over_50ms"] == 1
    assert got["health_not_ok"] == 1
    assert got["samples_ms"] == [10.0, 20.0, 30.0, 40.0]
    assert "health_ms" not in bench_service.summarise_passes([a])


def test_a_contaminated_baseline_round_is_repeated_and_left_out(
        monkeypatch: pytest.MonkeyPatch) -> None:
    import argparse

    base = object.__new__(bench_service.InProcess)
    base.rounds, base._samples = [], []
    busy = iter([0.9, 0.8, 0.0])                # others' cores in three attempts

    def fake_round(calls: int, label: str) -> dict:
        other = next(busy)
        out = {"label": label, "other_cores": other,
               "contaminated": bench_service.contaminated(other), "kept": True,
               "locate_ms": {"p50": 1.0}, "decode_locate_ms": {"p50": 2.0}}
        base.rounds.append(out)
        base._samples.append(([other + 0.01], [other + 0.02]))
        return out

    monkeypatch.setattr(base, "round", fake_round)
    args = argparse.Namespace(baseline_calls=1, retry_contaminated=2, retry_wait=0.0)
    bench_service.baseline_round(base, args, "round 0")
    assert [r["kept"] for r in base.rounds] == [False, False, True]
    assert base.locate_s == [0.01] and base.decode_locate_s == [0.02]
    busy = iter([0.9])                          # no repeats left: kept whatever it shows
    bench_service.baseline_round(base, argparse.Namespace(baseline_calls=1,
                                                          retry_contaminated=0,
                                                          retry_wait=0.0), "after")
    assert base.rounds[-1]["kept"] and base.locate_s == [0.01, 0.91]


def test_finite_makes_strict_json() -> None:
    got = bench_service.finite({"a": float("inf"), "b": [1.0, float("nan")], "c": "x"})
    assert got == {"a": None, "b": [1.0, None], "c": "x"}
    json.dumps(got, allow_nan=False)


def test_the_multipart_body_parses_as_the_service_parses_it() -> None:
    from starlette.datastructures import UploadFile
    from starlette.requests import Request

    right, left = bytes(range(256)) * 40, b"\x89PNG\r\n--not-a-boundary\r\n"
    boundary = "photomodel-bench-0000000011-boundary"
    body = bench_service.multipart_body(
        {"model": "No.3", "seed": "7"},
        {"right": ("right.png", right, "image/png"), "left": ("left.png", left, "image/png")},
        boundary)
    sent = False

    async def receive() -> dict:
        nonlocal sent
        if sent:
            return {"type": "http.disconnect"}
        sent = True
        return {"type": "http.request", "body": body, "more_body": False}

    async def parse() -> dict:
        scope = {"type": "http", "method": "POST", "path": "/locate", "query_string": b"",
                 "headers": [(b"content-type",
                              f"multipart/form-data; boundary={boundary}".encode()),
                             (b"content-length", str(len(body)).encode())]}
        form = await Request(scope, receive).form()
        out = {"model": form["model"], "seed": form["seed"]}
        for name in ("right", "left"):
            value = form[name]
            assert isinstance(value, UploadFile)
            out[name] = await value.read()
        return out

    got = anyio.run(parse)
    assert got == {"model": "No.3", "seed": "7", "right": right, "left": left}
    with pytest.raises(ValueError, match="boundary"):
        bench_service.multipart_body({}, {"right": ("r", f"x--{boundary}y".encode(), "a/b")},
                                     boundary)


def _check_run(result: dict, out: Path, searches: list[int], clients: list[int],
               requests: int) -> None:
    written = json.loads(out.read_text())
    assert written["meta"]["benchmark"] == "service" and "commit" in written["meta"]
    assert [s["searches"] for s in result["services"]] == searches
    for s in result["services"]:
        assert s["searches_effective"] in (1, s["searches"])
        assert [p["clients"] for p in s["passes"]] == clients
        assert s["memory_mib"]["before"]["rss"] > 50.0
        for p in s["passes"]:
            assert p["requests"] == p["clients"] * requests
            assert p["errors"] == 0, p["error_samples"]
            assert p["pose_max_abs_diff"] == 0.0        # the service finds in-process's pose
            assert p["latency_ms"]["p50"] > 0 and p["throughput_rps"] > 0
            assert p["ratio_p50_to_in_process"] > 0
            assert ("health_ms" in p) == (p["clients"] >= 4)
        assert len(s["rss_trace_mib"]) == 1 + len(clients) * len(p["rounds"])
    assert result["in_process"]["locate_ms"]["n"] > 0
    assert result["targets"]["errors"]["verdict"] == "pass"
    assert result["targets"]["same_pose"]["verdict"] == "pass"


def test_a_short_run_against_a_service_process(tmp_path: Path) -> None:
    out = tmp_path / "out" / "service.json"
    result = bench_service.main(["--quick", "--requests", "3", "--clients", "1", "--searches",
                                 "2", "--garments", "No.3", "--scenes", "2", "--no-faces",
                                 "--work", str(tmp_path / "work"), "--out", str(out)])
    _check_run(result, out, [2], [1], 3)
    assert (out.parent / "service-2.log").is_file()
    assert "faces" not in result


def test_the_faces_against_a_service_with_a_source_and_opc_ua(tmp_path: Path) -> None:
    """The trigger, raw and PNG uploads, OPC UA and a camera stream, each beside in-process."""
    pytest.importorskip("asyncua")
    load_benchmark("bench_track")
    load_benchmark("bench_track_stream")
    out = tmp_path / "out" / "service.json"
    result = bench_service.main([
        "--quick", "--requests", "1", "--clients", "1", "--searches", "2", "--garments",
        "No.3", "--scenes", "2", "--faces-requests", "4", "--stream-seconds", "1",
        "--stream-warmup-s", "0.5", "--stream-sequence-s", "0.25",
        "--faces-work", str(tmp_path / "faces"), "--work", str(tmp_path / "work"),
        "--out", str(out)])
    faces = result["faces"]
    for row in ("trigger", "raw", "png"):
        assert faces[row]["errors"] == [] and faces[row]["pose_max_abs_diff"] == 0.0
        assert faces[row]["in_process_ms"]["n"] == 4
    assert faces["trigger"]["grab_ms"]["n"] == 4 and faces["trigger"]["frames_seen"] == 4
    assert faces["opcua"]["errors"] == [] and faces["opcua"]["round_trip_ms"]["n"] == 4
    assert faces["opcua"]["position_diff_mm_max"] < 5.0
    stream = faces["stream"]
    assert stream["answers"] > 0 and stream["errors"] == [] and stream["rss_growth"] is not None
    assert set(faces["targets"]) == {"trigger_p50", "raw_p50", "opcua_p50", "stream_no_drop",
                                     "stream_memory"}
    assert all(t["verdict"] in ("pass", "fail") for t in faces["targets"].values())
    assert json.loads(out.read_text())["faces"]["model"] == "No.3"


@pytest.mark.slow
def test_a_quick_run_of_every_setting(tmp_path: Path) -> None:
    out = tmp_path / "out" / "service.json"
    result = bench_service.main(["--quick", "--work", str(tmp_path / "work"), "--out",
                                 str(out)])
    _check_run(result, out, [1, 2, 4], [1, 2, 4], bench_service.QUICK_REQUESTS)
    health = result["targets"]["health_while_four_search"]
    assert health["verdict"] in ("pass", "fail") and health["max_ms"] > 0
