"""The benchmark's SIFT peer (``benchmarks/peer_sift.py``) and its table (``locate_table.py``).

``benchmarks/`` is not a package: its scripts are loaded by path (``benchmark_helpers``).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from benchmark_helpers import load_benchmark

from photomodel.experiments import ExperimentConfig, Trial, trial_inputs
from photomodel.geometry import in_plane_angle_rad

POSITION_TOL_MM = 2.0
ANGLE_TOL_DEG = 1.0

peer_sift = load_benchmark("peer_sift")
locate_table = load_benchmark("locate_table")

CONFIG = ExperimentConfig(garments=("No.8", "No.10"), conditions=("paper",), trials=1, seed=0)


def _inputs(garment: str):
    return trial_inputs(CONFIG, Trial(f"paper_{garment}_0000", garment, "paper", 0))


def test_peer_recovers_the_pose_of_a_printed_garment() -> None:
    model, rig, right, left, T_true, _ = _inputs("No.10")
    result = peer_sift.sift_locate(model, rig, right, left)
    assert result.ok, result.reason
    assert result.reason == "ok"
    T = result.T_cam1_model
    assert T.shape == (4, 4)
    position_error = np.linalg.norm(T[:3, 3] - T_true[:3, 3])
    cos = (np.trace(T[:3, :3].T @ T_true[:3, :3]) - 1.0) / 2.0
    rotation_error = np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))
    theta_error = np.degrees(in_plane_angle_rad(T[:3, :3]) - in_plane_angle_rad(T_true[:3, :3]))
    assert position_error < POSITION_TOL_MM
    assert rotation_error < ANGLE_TOL_DEG
    assert abs((theta_error + 180.0) % 360.0 - 180.0) < ANGLE_TOL_DEG
    assert result.inliers >= 10
    assert result.seconds > 0


def test_peer_gives_up_with_a_reason_on_a_plain_garment() -> None:
    model, rig, right, left, _, _ = _inputs("No.8")
    result = peer_sift.sift_locate(model, rig, right, left)
    assert not result.ok
    assert result.T_cam1_model is None
    assert result.reason and result.reason != "ok"


def test_peer_gives_up_with_a_reason_on_empty_images() -> None:
    model, rig, right, _, _, _ = _inputs("No.10")
    empty = np.full_like(right, 128)
    result = peer_sift.sift_locate(model, rig, empty, empty)
    assert not result.ok
    assert result.T_cam1_model is None
    assert "matches" in result.reason


def test_model_features_lie_inside_the_model_outline() -> None:
    model, _, _, _, _, _ = _inputs("No.10")
    feats = peer_sift.model_features(model)
    assert feats.n > 50
    assert feats.descriptors.shape == (feats.n, 128)
    assert np.all(feats.points_mm[:, 2] == 0.0)
    lo, hi = model.outline_mm[:, :2].min(axis=0), model.outline_mm[:, :2].max(axis=0)
    assert np.all((feats.points_mm[:, :2] >= lo - 1.0) & (feats.points_mm[:, :2] <= hi + 1.0))


def _stats(success: float, std_x: float | None, ms: float) -> dict:
    std = {"x_mm": std_x, "y_mm": 0.2, "z_mm": 0.4, "theta_deg": 0.03}
    return {"trials": 10, "success_rate": success, "std_success": std,
            "seconds_pool": {"median": 2 * ms / 1e3, "p90": ms / 1e3, "n": 10},
            "seconds_2threads": {"median": ms / 1e3, "p90": ms / 1e3, "n": 2}}


TINY = {
    "meta": {"seed": 3, "commit": "0123456789abcdef"},
    "settings": {"trials": 10, "paper_trials": 1, "garments": ["No.1"],
                 "success": {"position_error_3d_mm_below": 10.0,
                             "rotation_error_3d_deg_below": 5.0}},
    "conditions": {
        "paper": {"default": _stats(1.0, 0.11, 30.0), "peer": _stats(0.9, None, 120.0),
                  "ratios": {"time_peer_over_default": 4.0}},
        "dim": {"default": _stats(0.995, 0.12, 35.0), "peer": _stats(0.5, 0.3, 110.0),
                "ratios": {"time_peer_over_default": 3.14159}},
    },
    "overall": {"default": _stats(0.9975, None, 32.0), "peer": _stats(0.7, None, 115.0),
                "ratios": {"time_peer_over_default": 3.6}},
}


def test_table_renders_a_row_per_condition() -> None:
    table = locate_table.render_table(TINY)
    rows = [line for line in table.splitlines() if line.startswith("|")]
    assert len(rows) == 2 + 2 + 1  # header, rule, two conditions, overall
    assert "paper success" not in rows[0]  # no paper-method columns without its data
    paper = rows[2].split("|")
    assert paper[1].strip() == "paper"
    assert paper[2].strip() == "100.0"
    assert paper[3].strip() == "0.11 / 0.20 / 0.40 / 0.030"
    assert paper[4].strip() == "30"
    assert paper[6].strip() == "– / 0.20 / 0.40 / 0.030"
    assert paper[-2].strip() == "4"
    dim = rows[3].split("|")
    assert dim[2].strip() == "99.5"
    assert dim[-2].strip() == "3.14"
    assert rows[4].split("|")[1].strip() == "**all**"
    assert "seed 3" in table and "0123456789" in table
    assert "first stereo pair" not in table
    prepared = {**TINY, "settings": {**TINY["settings"], "default_model_preparation": {
        "first_pair_seconds_median": 0.25}}}
    assert "took 250 ms (median)" in locate_table.render_table(prepared)


def test_table_replaces_only_the_readme_block(tmp_path: Path) -> None:
    result = tmp_path / "locate.json"
    result.write_text(json.dumps(TINY))
    readme = tmp_path / "README.md"
    readme.write_text(f"# Title\n\nbefore\n{locate_table.START}\nold table\n"
                      f"{locate_table.END}\nafter\n")
    assert locate_table.main([str(result), "--readme", str(readme)]) == 0
    text = readme.read_text()
    assert text.startswith("# Title\n\nbefore\n" + locate_table.START + "\n| condition")
    assert text.endswith(locate_table.END + "\nafter\n")
    assert "old table" not in text
    assert locate_table.main([str(result), "--readme", str(readme)]) == 0
    assert readme.read_text() == text  # idempotent


def test_table_refuses_a_readme_without_markers(tmp_path: Path, capsys) -> None:
    result = tmp_path / "locate.json"
    result.write_text(json.dumps(TINY))
    readme = tmp_path / "README.md"
    readme.write_text("# Title\n")
    assert locate_table.main([str(result), "--readme", str(readme)]) == 2
    assert "locate-benchmark:start" in capsys.readouterr().err
    assert readme.read_text() == "# Title\n"


@pytest.mark.parametrize("text", ["no markers", f"{locate_table.END}\n{locate_table.START}"])
def test_replace_block_rejects_bad_markers(text: str) -> None:
    with pytest.raises(ValueError):
        locate_table.replace_block(text, "table")
