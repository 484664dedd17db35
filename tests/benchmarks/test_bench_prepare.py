"""The preparation benchmark (``benchmarks/bench_prepare.py``): this tree against itself gives
the same results to the bit, and its comparison reports what moved."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from benchmark_helpers import load_benchmark

load_benchmark("_meta")
load_benchmark("bench_startup")
bench_prepare = load_benchmark("bench_prepare")


def test_this_tree_against_itself_finds_the_same_poses(tmp_path: Path) -> None:
    out = bench_prepare.main(["--baseline", "WORKTREE", "--models", "2", "--repeats", "1",
                              "--no-warmup", "--work", str(tmp_path / "work"),
                              "--out", str(tmp_path / "prepare.json")])
    assert (tmp_path / "prepare.json").exists()
    for kind in ("locator", "cold_results"):
        assert out["results"][kind] == {"scenes": 2, "identical": 2, "found_differs": 0,
                                        "position_difference_max_mm": 0.0}
    for figure in ("prepare", "prepare_cpu", "cold", "warm"):
        assert out["figures"][figure]["current"]["n"] == 2
    assert 1.0 < out["memory_mb"]["current"] == out["memory_mb"]["baseline"] < 100.0


def test_compare_results_counts_the_moves() -> None:
    T = np.eye(4)
    moved = T.copy()
    moved[1, 3] = 0.04
    a = [{"T_cam1_model": T.tolist(), "found": True, "digest": "x"},
         {"T_cam1_model": T.tolist(), "found": True, "digest": "y"}]
    b = [{"T_cam1_model": T.tolist(), "found": True, "digest": "x"},
         {"T_cam1_model": moved.tolist(), "found": False, "digest": "z"}]
    got = bench_prepare.compare_results(a, b)
    assert got["identical"] == 1 and got["found_differs"] == 1
    assert got["position_difference_max_mm"] == pytest.approx(0.04)
    with pytest.raises(ValueError, match="results"):
        bench_prepare.compare_results(a, b[:1])


def test_kept_bytes_counts_each_array_once() -> None:
    a = np.zeros(100)
    holder = {"a": a, "again": [a, a[:10]], "b": np.ones((2, 3), dtype=np.float32)}
    assert bench_prepare.kept_bytes(holder) == 800 + 24
