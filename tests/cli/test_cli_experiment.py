"""``photomodel experiment`` on the command line: a short run, resuming, clear errors."""

from __future__ import annotations

from pathlib import Path

import pytest

from photomodel.cli._main import main
from photomodel.experiments import read_records


def _error_line(capsys: pytest.CaptureFixture[str]) -> str:
    err = capsys.readouterr().err
    assert "Traceback" not in err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("photomodel: error:")
    return lines[0]


def test_a_short_experiment_records_and_resumes(tmp_path: Path,
                                                capsys: pytest.CaptureFixture[str]) -> None:
    argv = ["experiment", "--out", str(tmp_path / "run"), "--garments", "No.3", "--trials", "2",
            "--generations", "5", "--workers", "1", "--seed", "2", "--no-report"]
    assert main(argv) == 0
    assert "2 trials (2 run now" in capsys.readouterr().out
    records = read_records(tmp_path / "run" / "records.csv")
    assert sorted(records["trial_id"].tolist()) == ["paper_No.3_0000", "paper_No.3_0001"]
    assert main(argv) == 0
    assert "2 trials (0 run now" in capsys.readouterr().out


@pytest.mark.parametrize(("extra", "fragment"), [
    (["--garments", "No.99"], "--garments: unknown garment 'No.99'"),
    (["--conditions", "sunny"], "--conditions: unknown condition 'sunny'"),
    (["--trials", "0"], "--trials: expected an integer from 1 to 100000, got 0"),
    (["--workers", "0"], "--workers: expected an integer from 1 to 1024, got 0"),
    (["--dataset", "/nonexistent/dataset"], "dataset directory not found"),
])
def test_bad_options_give_one_clear_line(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                         extra: list[str], fragment: str) -> None:
    out = tmp_path / "run"
    assert main(["experiment", "--out", str(out), "--no-report", *extra]) == 2
    assert fragment in _error_line(capsys)
    assert not out.exists()


def test_other_settings_in_a_run_directory_are_refused(tmp_path: Path,
                                                       capsys: pytest.CaptureFixture[str]) -> None:
    base = ["experiment", "--out", str(tmp_path), "--garments", "No.3", "--trials", "1",
            "--generations", "3", "--workers", "1", "--no-report"]
    assert main([*base, "--seed", "1"]) == 0
    capsys.readouterr()
    assert main([*base, "--seed", "2"]) == 2
    assert "other settings (seed)" in _error_line(capsys)


def test_the_report_of_a_soft_run_maps_the_soft_fitness(tmp_path: Path,
                                                        capsys: pytest.CaptureFixture[str]) -> None:
    """The default method's report (its fitness map re-evaluates the ``soft`` fitness)."""
    argv = ["experiment", "--out", str(tmp_path / "run"), "--garments", "No.1", "--trials", "1",
            "--workers", "1", "--seed", "0"]
    assert main(argv) == 0
    assert "Traceback" not in capsys.readouterr().err
    report = (tmp_path / "run" / "report.md").read_text()
    assert "No.1" in report
    assert (tmp_path / "run" / "fitness_map.png").exists()
