"""A cleared table's looks kept and drawn: ``run_clear(..., keep=0)``, :func:`animate_clear`,
and ``photomodel cell --tables K --animate PATH`` with its path errors."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from PIL import Image

from photomodel.cell import ClearConfig, ClearReport, animate_clear, run_clear
from photomodel.cli import main

MODELS = ("No.3", "No.5", "No.7")


@pytest.fixture(scope="module")
def report() -> ClearReport:
    return run_clear(ClearConfig(tables=1, garments=2, models=MODELS, seed=3), keep=0)


def _frames(gif: Path) -> int:
    assert gif.read_bytes()[:6] in (b"GIF89a", b"GIF87a")
    with Image.open(gif) as im:
        return int(im.n_frames)


def test_the_kept_looks_follow_the_table_record(report: ClearReport) -> None:
    (table,) = report.tables
    looks = report.kept
    assert looks is not None and report.setup is not None
    assert set(report.to_json_dict()) == {"summary", "tables"}
    assert [lk.pick for lk in looks if lk.pick is not None] == table["picks"]
    assert [lk.look for lk in looks] == list(range(len(looks)))
    cam1 = report.setup.rig.cam1
    for lk in looks:
        assert lk.table == 0 and lk.right_bgr.dtype.name == "uint8"
        assert lk.right_bgr.shape == (cam1.height_px, cam1.width_px, 3)
        assert set(lk.models) == {g.model for g in lk.found.garments}
    assert sum(looks[-1].placed.values()) == table["placed"] == 2
    assert looks[-1].remaining == 0 and table["cleared"]


def test_animate_clear_draws_one_picture_a_look(report: ClearReport, tmp_path: Path) -> None:
    assert report.kept is not None and report.setup is not None
    gif = animate_clear(report.kept, tmp_path / "clear.gif", rig=report.setup.rig,
                        models=MODELS, title="a table of two")
    assert gif == tmp_path / "clear.gif"
    assert _frames(gif) == len(report.kept) >= 2
    assert [p.name for p in tmp_path.iterdir()] == ["clear.gif"]
    with pytest.raises(ValueError, match="none kept"):
        animate_clear([], tmp_path / "none.gif", rig=report.setup.rig)


def test_cli_cell_tables_animates_the_first_table(tmp_path: Path,
                                                   capsys: pytest.CaptureFixture[str]) -> None:
    gif, out = tmp_path / "tables.gif", tmp_path / "tables.json"
    code = main(["cell", "--tables", "1", "--garments", "2", "--seed", "1", "--animate",
                 str(gif), "--out", str(out), "--json"])
    captured = capsys.readouterr()
    assert code == 0, captured.err
    assert len(captured.out.strip().splitlines()) == 1      # the summary, nothing else
    summary = json.loads(captured.out)
    assert summary["placed"] == 2
    doc = json.loads(out.read_text())
    assert set(doc) >= {"summary", "tables"}
    assert _frames(gif) == doc["tables"][0]["looks"] > 1
    assert gif.stat().st_size < 1_500_000


@pytest.mark.parametrize("name, needle", [
    ("no_such_dir/x.gif", "does not exist"),
    ("x.txt", "unknown animation type"),
])
def test_cli_cell_tables_animate_path_errors(name: str, needle: str, tmp_path: Path,
                                             monkeypatch: pytest.MonkeyPatch,
                                             capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.chdir(tmp_path)
    code = main(["cell", "--tables", "1", "--garments", "2", "--animate", name, "--out",
                 "t.json"])
    captured = capsys.readouterr()
    assert code == 2
    assert needle in captured.err and "Traceback" not in captured.err
    assert len(captured.err.strip().splitlines()) == 1 and captured.out == ""
    assert list(tmp_path.iterdir()) == []
