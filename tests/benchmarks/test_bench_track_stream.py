"""The ``/track`` stream benchmark (``benchmarks/bench_track_stream.py``): its schedule, its
figures and a short run against a real ``photomodel serve`` process."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from benchmark_helpers import load_benchmark

load_benchmark("_meta")
load_benchmark("_faces")
load_benchmark("bench_service")
load_benchmark("bench_track")
bench = load_benchmark("bench_track_stream")


def test_the_schedule_plays_the_sequence_back_and_forth_with_rising_times() -> None:
    slots = bench.schedule(9, 4, 60.0)
    assert [s.index for s in slots] == [2, 3, 2, 1, 0, 1, 2, 3, 2]
    times = [s.t_s for s in slots]
    assert times == sorted(set(times)) and times[6] == pytest.approx(0.1)
    assert [bench.frame_of(t, 60.0) for t in times] == list(range(9))
    assert [s.index for s in bench.schedule(3, 1, 60.0)] == [0, 0, 0]
    with pytest.raises(ValueError, match="n_frames"):
        bench.schedule(0, 3, 60.0)


def test_track_counters_are_read_from_the_metrics_page() -> None:
    text = ("# HELP photomodel_track_frames_total Frames received on /track, by outcome\n"
            'photomodel_track_frames_total{outcome="tracked"} 12.0\n'
            'photomodel_track_frames_total{outcome="dropped"} 3.0\n'
            'photomodel_track_frames_created{outcome="dropped"} 1.7e9\n')
    assert bench.track_counters(text) == {"tracked": 12.0, "dropped": 3.0, "bad": 0.0}


def test_quantiles_verdicts_and_per_second_medians() -> None:
    q = bench.quantiles_ms([0.001 * v for v in range(1, 101)])
    assert q["n"] == 100 and q["p50"] == pytest.approx(50.5) and q["max"] == pytest.approx(100)
    assert bench.quantiles_ms([])["p50"] is None
    assert bench.verdict(2.0, 2.0) == "pass" and bench.verdict(2.01, 2.0) == "fail"
    assert bench.verdict(0.05, 0.05, below=True) == "fail"
    assert bench.verdict(None, 1.0) == "n/a"
    got = bench.by_second([10.1, 10.2, 12.5], [0.004, 0.006, 0.010], 10.0, 3)
    assert got == [pytest.approx(5.0), None, pytest.approx(10.0)]


def test_a_short_run_against_a_service_process(tmp_path: Path) -> None:
    out = tmp_path / "out" / "track_stream.json"
    result = bench.main(["--quick", "--seconds", "2", "--warmup-s", "0.5",
                         "--sequence-seconds", "0.25", "--work", str(tmp_path / "work"),
                         "--out", str(out)])
    written = json.loads(out.read_text())
    assert written["benchmark"] == "track_stream" and "commit" in written
    assert written["versions"] and written["settings"]["seconds"] == 2.0
    assert written["tracker"]["track_sha256"]
    assert set(written["runs"]) == {"raw", "slow_reader", "slow_reader_credit"}
    baseline = written["in_process"]
    assert baseline["track_ms"]["p50"] > 0 and len(baseline["rounds"]) == 2
    assert baseline["track_ms"]["n"] == sum(r["track_ms"]["n"] for r in baseline["rounds"]) == 240
    assert baseline["decode_ms"]["raw"]["p50"] > 0
    assert written["data"]["frames"] == 15 and written["data"]["shape"][2] == 3
    for label, run in written["runs"].items():
        assert run["frames_sent"] == 150 and run["frames_counted"] == 120, label
        assert run["answers"] > 0 and run["errors"] == 0, run["error_samples"]
        assert run["latency_ms"]["n"] > 0 and run["latency_ms"]["p50"] > 0
        assert run["send_ms"]["n"] == run["frames_counted"]
        assert run["accounted"], label                     # answered + dropped = sent
        assert run["last_received"] == run["frames_sent"] and run["last_frame_answered"]
        assert run["rss_mib"]["start"] > 50 and run["rss_mib"]["end"] > 50
        # with credit, frames tracked while no answer was asked for are superseded, not sent
        assert run["metrics_delta"]["tracked"] == run["tracked_answers"] + run["superseded"]
    slow, asks = written["runs"]["slow_reader"], written["runs"]["slow_reader_credit"]
    assert slow["credit"] is None and written["runs"]["raw"]["credit"] is None
    assert slow["metrics_delta"]["dropped"] == slow["last_dropped"]
    assert slow["answers_after_stop"] > 0          # it had not read them all while sending
    # asking for one answer at a time (however fast the loaded machine tracks): never more
    # answers than asked for, at most one per sleep while sending, and when the sending ends
    # at most the one asked for last and the last frame's
    assert asks["metrics_delta"]["dropped"] == asks["last_dropped"]
    assert asks["credit"]["initial"] == 1
    assert asks["answers"] - 1 <= asks["credit"]["granted"] <= asks["answers"]
    assert asks["answers"] <= 1 + 2.5 / asks["slow_read_s"] + 2
    assert 1 <= asks["answers_after_stop"] <= 2
    targets = written["targets"]
    assert set(targets) == {"p50_ratio", "rss_growth", "slow_reader_rss_growth",
                            "slow_reader_dropped_counted", "slow_reader_no_backlog_in_service",
                            "slow_reader_credit_rss_growth", "slow_reader_credit_dropped_counted",
                            "slow_reader_credit_no_backlog_in_service",
                            "slow_reader_no_backlog_of_answers"}
    backlog = targets["slow_reader_no_backlog_of_answers"]
    assert backlog["run"] == "slow_reader_credit" and backlog["verdict"] == "pass"
    assert backlog["answers_read_after_the_last_send"] == asks["answers_after_stop"]
    assert backlog["without_credit"]["answers_read_after_the_last_send"] \
        == slow["answers_after_stop"] and "verdict" not in backlog["without_credit"]
    assert all(t["verdict"] in ("pass", "fail") for t in targets.values())
    assert targets["slow_reader_dropped_counted"]["verdict"] == "pass"
    assert targets["slow_reader_credit_dropped_counted"]["verdict"] == "pass"
    assert result["ratios"]["raw_p50_over_in_process_p50"] > 0
