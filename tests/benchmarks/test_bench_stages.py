"""The stage-cost benchmark (``benchmarks/bench_stages.py``): its stages add up, its timers
leave the library as it was, and its comparison measures pose moves."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from benchmark_helpers import load_benchmark

import photomodel.locate._locate as locate_module
import photomodel.search._pyramid as pyramid_module
from photomodel.experiments import ExperimentConfig, Trial, trial_inputs
from photomodel.locate import locate
from photomodel.sim import scene_rng

load_benchmark("_meta")
load_benchmark("peer_sift")
bench_stages = load_benchmark("bench_stages")


def test_stages_of_one_scene_add_up_and_the_pose_is_locate_s(tmp_path: Path) -> None:
    originals = (locate_module.score_terms, pyramid_module.gauss_newton_refine)
    out = bench_stages.main(["--conditions", "paper", "--garments", "No.10",
                             "--trial-index", "1", "--out", str(tmp_path / "s.json")])
    assert (locate_module.score_terms, pyramid_module.gauss_newton_refine) == originals
    (row,) = out["scenes"]
    stages = out["summary"]["stages"]
    for name in ("features", "coarse scan", "score", "Gauss-Newton L0", "other"):
        assert name in stages, name
    assert sum(s for s, _ in row["stages"].values()) <= row["seconds"]
    assert sum(v["share"] for v in stages.values()) == pytest.approx(1.0)
    assert out["summary"]["time_peer_over_default"] > 0
    config = ExperimentConfig(garments=("No.10",), conditions=("paper",), trials=2, seed=0)
    model, rig, right, left, _, _ = trial_inputs(config, Trial("paper_No.10_0001", "No.10",
                                                               "paper", 1))
    again = locate(model, rig, right, left, rng=scene_rng(0, "search", "paper_No.10_0001"))
    np.testing.assert_allclose(row["T_cam1_model"], again.T_cam1_model, atol=1e-6)
    assert row["found"] and row["err_pos_mm"] < 2.0


def test_compare_reports_the_moves_and_the_ratio() -> None:
    T = np.eye(4)
    moved = T.copy()
    moved[0, 3] = 0.3
    old = [{"trial_id": "a", "seconds": 0.02, "T_cam1_model": T.tolist(), "fitness": 0.5,
            "found": True}]
    new = [{"trial_id": "a", "seconds": 0.01, "T_cam1_model": moved.tolist(), "fitness": 0.6,
            "found": True}]
    got = bench_stages.compare(new, old)
    assert got["per_scene_ratio_median"] == pytest.approx(0.5)
    assert got["pose_moved_max_mm"] == pytest.approx(0.3)
    assert got["poses_moved_over_0.05_mm"] == 1
    assert got["fitness_changed_max"] == pytest.approx(0.1)
    with pytest.raises(ValueError, match="no scene in common"):
        bench_stages.compare(new, [{**old[0], "trial_id": "b"}])
