"""The decision threshold: calibration rule and the stored, calibrated file."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from photomodel.errors import InputError
from photomodel.locate import Threshold, calibrate_threshold, load_threshold, save_threshold


def test_separable_scores_give_the_middle_of_the_gap() -> None:
    t, stats = calibrate_threshold([0.6, 0.7, 0.9], [0.1, 0.2, 0.3])
    assert t == pytest.approx(0.45)
    assert stats["false_accept_rate"] == 0 and stats["false_reject_rate"] == 0


def test_false_acceptance_cap_wins_over_rejections() -> None:
    rng = np.random.default_rng(0)
    pos = np.concatenate([rng.uniform(0.5, 0.9, 95), [0.05] * 5])  # five missed garments
    neg = np.concatenate([rng.uniform(0.0, 0.3, 199), [0.55]])  # one high negative
    t, stats = calibrate_threshold(pos, neg, max_false_accept=0.0)
    assert t > 0.55 and stats["false_accept_rate"] == 0
    t, stats = calibrate_threshold(pos, neg, max_false_accept=0.01)
    assert 0.3 < t <= 0.5 and stats["false_accept_rate"] <= 0.01
    assert stats["false_reject_rate"] == pytest.approx(0.05)


def test_bad_calibration_input() -> None:
    with pytest.raises(ValueError, match="needs positive and negative"):
        calibrate_threshold([], [0.1])


def test_stored_threshold_is_calibrated() -> None:
    th = load_threshold()
    assert 0.0 < th.min_score < 1.0
    meta = th.metadata
    assert meta["command"].startswith("photomodel experiment --identify --calibrate")
    assert meta["positives"] > 0 and meta["negatives"] > 0 and meta["commit"]
    assert meta["negative_scores"]["max"] < th.min_score


def test_round_trip_and_bad_file(tmp_path: Path) -> None:
    p = save_threshold(Threshold(0.42, {"source": "test"}), tmp_path / "t.json")
    assert load_threshold(p) == Threshold(0.42, {"source": "test"})
    (tmp_path / "bad.json").write_text("[]")
    with pytest.raises(InputError, match="not a threshold file"):
        load_threshold(tmp_path / "bad.json")
    with pytest.raises(ValueError, match="min_score"):
        Threshold(1.5)


def test_a_file_read_before_is_read_again_when_it_changes(tmp_path: Path) -> None:
    """``load_threshold`` keeps a file's text while it is unchanged (``locate`` asks for it
    with every pair), and reads it again after a new calibration is saved or the file is
    rewritten in place; what it returns is the caller's own."""
    p = save_threshold(Threshold(0.42, {"source": "first"}), tmp_path / "t.json")
    first = load_threshold(p)
    first.metadata["source"] = "changed by a caller"
    assert load_threshold(p) == Threshold(0.42, {"source": "first"})
    save_threshold(Threshold(0.55, {"source": "second"}), p)
    assert load_threshold(p) == Threshold(0.55, {"source": "second"})
    p.write_text('{"min_score": 0.61, "metadata": {"source": "third, in place"}}\n')
    assert load_threshold(p) == Threshold(0.61, {"source": "third, in place"})
    p.unlink()
    with pytest.raises(InputError, match="not found"):
        load_threshold(p)


def test_the_threshold_that_applies_and_where_a_calibration_goes(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Explicit file, else the library's, else the user's, else the package's; a new
    calibration goes to the user's file, never into the installed package."""
    from photomodel.locate import threshold_path, user_threshold_path
    from photomodel.locate._threshold import _package_path

    user = tmp_path / "config" / "photomodel" / "threshold.json"
    monkeypatch.delenv("PHOTOMODEL_THRESHOLD", raising=False)
    monkeypatch.setenv("XDG_CONFIG_HOME", str(tmp_path / "config"))
    assert user_threshold_path() == user
    package = _package_path()
    before = package.read_bytes()
    assert threshold_path() == package
    assert save_threshold(Threshold(0.37, {"source": "test"})) == user
    assert threshold_path() == user and load_threshold().min_score == 0.37
    library = tmp_path / "library"
    library.mkdir()
    assert threshold_path(library=library) == user
    save_threshold(Threshold(0.44), library / "threshold.json")
    assert load_threshold(library=library).min_score == 0.44
    assert load_threshold(user).min_score == 0.37
    with pytest.raises(InputError, match="package"):
        save_threshold(Threshold(0.1), package)
    assert package.read_bytes() == before
    monkeypatch.setenv("PHOTOMODEL_THRESHOLD", str(tmp_path / "elsewhere.json"))
    assert user_threshold_path() == tmp_path / "elsewhere.json"
