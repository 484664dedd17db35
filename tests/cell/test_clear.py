"""Clearing a table: look, pick the garment to pick first, place it into its model's box."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from photomodel.cell import ClearConfig, box_layouts, run_clear
from photomodel.cli import main
from photomodel.robot import CellLayout


def test_one_box_per_model_and_the_config_is_checked() -> None:
    boxes = box_layouts(CellLayout(), ("No.1", "No.2", "No.3"))
    places = {b.box_centre_mm for b in boxes.values()}
    assert len(places) == 3 and boxes["No.1"].box_centre_mm == CellLayout().box_centre_mm
    with pytest.raises(ValueError, match="garments: expected 2 to 6"):
        ClearConfig(garments=7)
    with pytest.raises(ValueError, match="one box each"):
        ClearConfig(models=tuple(f"No.{k}" for k in range(1, 14)))


def test_a_table_of_two_is_cleared_into_the_right_boxes() -> None:
    report = run_clear(ClearConfig(tables=1, garments=2, models=("No.3", "No.5", "No.7"),
                                   seed=3))
    (table,) = report.tables
    s = report.summary
    assert table["cleared"] and table["placed"] == 2 and s["placed"] == 2
    assert s["wrong_box"] == 0 and s["picked_covered"] == 0
    assert all(p["right_box"] and p["under"] == [] for p in table["picks"] if p["placed"])
    assert 0 < s["grasp_error_mm"]["max"] < 10.0


def test_cell_tables_on_the_command_line(tmp_path: Path, capsys) -> None:  # type: ignore[no-untyped-def]
    out = tmp_path / "clear.json"
    assert main(["cell", "--tables", "1", "--garments", "2", "--seed", "1", "--out",
                 str(out)]) == 0
    line = capsys.readouterr().out
    assert "1 tables of 2: 2/2 garments placed" in line and "0 in a wrong box" in line
    doc = json.loads(out.read_text())
    assert doc["summary"]["placed"] == 2 and len(doc["tables"][0]["picks"]) >= 2
