"""The tracking benchmark (``benchmarks/bench_track.py``): its event and stretch rules on made-up
frames, and one short sequence through it into the JSON it writes."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from benchmark_helpers import load_benchmark

load_benchmark("_meta")
bench_track = load_benchmark("bench_track")


def _frame(k: int, visible: float, mode: str, present: bool = True,
           success: bool | None = None) -> dict[str, Any]:
    found = mode != "lost"
    return {"frame": k, "truth_present": present, "truth_visible": visible, "mode": mode,
            "found": found, "success": found and present if success is None else success}


def test_event_latencies_count_frames_from_the_truth_s_event() -> None:
    frames = [_frame(0, 1.0, "detect"), _frame(1, 0.6, "track"), _frame(2, 0.05, "track"),
              _frame(3, 0.0, "track", present=False), _frame(4, 0.0, "lost", present=False),
              _frame(5, 0.7, "lost"), _frame(6, 1.0, "detect", success=False),
              _frame(7, 1.0, "track")]
    got = bench_track.event_latencies(frames)
    assert (got["gone_frame"], got["lost_frame"], got["lost_latency"]) == (2, 4, 2)
    assert (got["back_frame"], got["refound_frame"], got["refound_latency"]) == (5, 6, 1)
    assert got["refound_success"] is False and got["refound_correct_latency"] == 2
    never = bench_track.event_latencies(frames[:4])
    assert never["lost_never"] and never["lost_latency"] is None
    assert never["back_frame"] is None
    assert bench_track.event_latencies(frames[:2])["gone_frame"] is None


def test_still_stretch_ends_at_the_first_move_or_cover() -> None:
    T = np.eye(4)
    moved = T.copy()
    moved[0, 3] = 0.02
    truth = [(T, 1.0), (T.copy(), 1.0), (T, 0.995), (moved, 1.0), (T, 1.0)]
    assert bench_track.still_frames(truth) == [0, 1, 2]
    assert bench_track.still_frames([(T, 1.0), (T, 0.9), (T, 1.0)]) == [0]
    assert bench_track.still_frames([(None, 0.0), (T, 1.0)]) == []


def test_position_sd_is_the_rms_distance_from_the_mean() -> None:
    got = bench_track.position_sd([[0.0, 0.0, 0.0], [2.0, 0.0, 0.0]])
    assert got["sd"] == pytest.approx(np.sqrt(2.0))
    assert got["sd_xyz"] == pytest.approx([np.sqrt(2.0), 0.0, 0.0])
    assert bench_track.position_sd([[1.0, 2.0, 3.0]])["sd"] is None


def test_one_short_sequence_into_the_json(tmp_path: Path) -> None:
    out_path = tmp_path / "track.json"
    out = bench_track.main(["--garments", "No.6", "--kinds", "lost", "--fps", "30",
                            "--seconds", "0.3", "--out", str(out_path)])
    data = json.loads(out_path.read_text())
    assert data["benchmark"] == "track" and data["seed"] == 0 and "commit" in data
    assert data["settings"]["threads"]["numba_threads"] >= 1
    (row,) = data["rows"]
    assert (row["garment"], row["kind"], row["fps"]) == ("No.6", "lost", 30.0)
    assert [f["frame"] for f in row["frames"]] == list(range(9))
    first = row["frames"][0]
    assert first["mode"] == "detect" and first["found"] and first["success"]
    assert first["locate"] is not None and first["locate"]["timed"]
    assert {f["mode"] for f in row["frames"]} <= {"detect", "track", "lost"}
    summary = data["summary"]
    assert summary["targets"] == bench_track.TARGETS
    assert set(summary["met"]) == set(bench_track.TARGETS)
    assert all(isinstance(v, bool) for v in summary["met"].values())
    assert summary["frames"] == 9 and summary["locate_ms"]["n"] == 3
    assert 0.0 <= summary["figures"]["success"] <= 1.0
    assert out["summary"]["figures"] == summary["figures"]
