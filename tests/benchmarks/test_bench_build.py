"""benchmarks/bench_build.py: one garment's truth and builds, and the JSON it writes."""

from __future__ import annotations

import json
from pathlib import Path

from benchmark_helpers import load_benchmark


def test_measure_and_json(tmp_path: Path, capsys) -> None:
    bench = load_benchmark("bench_build")
    out = tmp_path / "build.json"
    assert bench.main(["--garments", "green-hem", "--out", str(out)]) == 0
    data = json.loads(out.read_text())
    assert data["benchmark"] == "build" and data["seed"] == 0
    (row,) = data["garments"]
    assert row["garment"] == "green-hem"
    assert abs(row["robust"]["area_error_pct"]) < 1 < abs(row["hue"]["area_error_pct"])
    assert row["robust"]["centroid_error_mm"] < 0.5 < row["hue"]["centroid_error_mm"]
    assert row["robust"]["warned"] and not row["hue"]["warned"]
    assert row["robust_vs_hue"]["centroid_shift_mm"] > 5
    assert "green-hem" in capsys.readouterr().out
