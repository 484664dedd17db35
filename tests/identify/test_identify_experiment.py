"""The identification experiment's statistics, on hand-made records (no scenes)."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from photomodel.experiments import (
    IdentifyExperimentConfig,
    plan_identify_trials,
    summarise_identify,
)
from photomodel.experiments._identify import _append, read_identify_records

NAN = math.nan


def _row(truth: str, best: str, score: float, cond: str = "paper", true_score: float = NAN,
         err: float = 1.0) -> dict:
    return {"trial_id": f"{cond}_{truth}_{best}_{score}", "truth": truth, "condition": cond,
            "index": 0, "best_model": best, "best_score": score, "runner_up": "none",
            "runner_up_score": 0.0, "searched": 3, "true_searched": int(truth != "none"),
            "true_score": true_score, "true_err_pos_mm": err, "true_err_rot_deg": 0.5,
            "err_pos_mm": err, "err_rot_deg": 0.5, "err_x_mm": 0.1, "err_y_mm": -0.1,
            "err_z_mm": 0.3, "err_theta_deg": 0.05, "visible_fraction": 1.0, "seconds": 2.0,
            "scores": "{}"}


def test_confusion_matrix_and_rates() -> None:
    rows = [
        _row("No.1", "No.1", 0.8), _row("No.1", "No.1-small", 0.7),  # confused twin
        _row("No.1-small", "No.1-small", 0.9), _row("No.3", "No.3", 0.3),  # rejected
        _row("none", "No.3", 0.2, "empty"), _row("none", "No.1", 0.6, "no-target"),
    ]
    s = summarise_identify(rows, ["No.1", "No.1-small", "No.3"], min_score=0.5)
    assert s["labels"] == ["No.1", "No.1-small", "No.3", "none"]
    assert s["confusion"] == [[1, 1, 0, 0], [0, 1, 0, 0], [0, 0, 0, 1], [1, 0, 0, 1]]
    assert s["top1"] == pytest.approx(0.5) and s["rejection_rate"] == pytest.approx(0.25)
    assert s["false_accept"] == pytest.approx(0.5)
    assert s["per_condition"]["empty"]["false_accept"] == 0.0
    assert s["per_condition"]["no-target"]["false_accept"] == 1.0
    assert s["similar_pairs"] == [{"pair": ["No.1", "No.1-small"], "scenes": 3,
                                   "confused": 1, "confusion_rate": pytest.approx(1 / 3)}]
    assert s["pose"]["identified"]["n"] == 2 and s["pose"]["identified"]["success"] == 1.0


def test_plan_and_records_round_trip(tmp_path: Path) -> None:
    cfg = IdentifyExperimentConfig(library=("No.1", "No.3"), conditions=("paper", "overlap"),
                                   trials=2, negatives=("empty",), negative_trials=3)
    ids = [t.trial_id for t in plan_identify_trials(cfg)]
    assert ids[:2] == ["paper_No.1_0000", "paper_No.1_0001"] and ids[-1] == "empty_0002"
    assert len(ids) == 2 * 2 * 2 + 3
    path = tmp_path / "identify.csv"
    _append(path, _row("No.1", "No.1", 0.8))
    with path.open("a") as f:
        f.write("paper_No.3_0000,No.3,paper,0,No")  # a row torn by an interruption
    rows = read_identify_records(path)
    assert len(rows) == 1 and rows[0]["best_score"] == 0.8 and rows[0]["scores"] == {}
    with pytest.raises(ValueError, match="library"):
        IdentifyExperimentConfig(library=())


def test_calibration_refuses_scores_of_other_code(tmp_path: Path) -> None:
    """A finished run directory is resumed, not re-run: calibrating on it after the code
    changed would store a threshold for the old scores."""
    import json

    from photomodel.errors import InputError
    from photomodel.experiments import calibrate_from_records
    from photomodel.experiments._identify import RUNS_FILE
    from photomodel.experiments._run import run_metadata

    for row in (_row("No.1", "No.1", 0.8, true_score=0.8), _row("No.3", "No.3", 0.7,
                                                                 true_score=0.7),
                _row("none", "No.3", 0.2, "empty"), _row("none", "No.1", 0.3, "no-target")):
        _append(tmp_path / "identify.csv", row)
    with pytest.raises(InputError, match="no record of which code"):
        calibrate_from_records(tmp_path)
    runs = tmp_path / RUNS_FILE
    runs.write_text(json.dumps({"runs": [{"commit": "0123456789abcdef", "trials": 4}]}))
    with pytest.raises(InputError, match="made at commit 0123456789"):
        calibrate_from_records(tmp_path)
    runs.write_text(json.dumps({"runs": [{"commit": run_metadata()["commit"], "trials": 4}]}))
    threshold = calibrate_from_records(tmp_path)
    assert 0.3 < threshold.min_score < 0.7
