"""``records.csv``: rows appended whole, a row cut short by an interruption dropped."""

from __future__ import annotations

from pathlib import Path

from photomodel.experiments import COLUMNS, read_records
from photomodel.experiments._records import FLOAT_COLUMNS, append_records, done_trial_ids


def _row(trial_id: str, x: float) -> dict[str, object]:
    row: dict[str, object] = {c: 0.1 * k for k, c in enumerate(FLOAT_COLUMNS)}
    row.update(trial_id=trial_id, garment="No.3", condition="clean", index=1, found=1,
               evaluations=100, generations=3, stop_reason="max_generations", err_x_mm=x)
    assert set(row) == set(COLUMNS)
    return row


def test_appended_rows_read_back_bit_identical(tmp_path: Path) -> None:
    path = tmp_path / "records.csv"
    append_records(path, [_row("a", 1 / 3), _row("b", -2e-17)])
    append_records(path, [_row("c", 1e300)])
    records = read_records(path)
    assert list(records["trial_id"]) == ["a", "b", "c"]
    assert list(records["err_x_mm"]) == [1 / 3, -2e-17, 1e300]
    assert path.read_text().count("trial_id") == 1               # one header


def test_a_row_cut_short_is_dropped_by_the_reader_and_the_next_append(tmp_path: Path) -> None:
    """Interrupted in the middle of a row, or just before its line break: the reader does
    not count it (its trial runs again) and the next append writes over it."""
    path = tmp_path / "records.csv"
    append_records(path, [_row("a", 1.0), _row("b", 2.0)])
    whole = path.read_bytes()
    for cut in (len(whole) - 1, len(whole) - 20):                # no line break; half a row
        path.write_bytes(whole[:cut])
        assert done_trial_ids(path) == {"a"}
        append_records(path, [_row("c", 3.0)])
        assert list(read_records(path)["trial_id"]) == ["a", "c"]
        assert path.read_bytes().endswith(b"\n")


def test_a_header_cut_short_is_written_again(tmp_path: Path) -> None:
    path = tmp_path / "records.csv"
    path.write_text("trial_id,garm")
    assert done_trial_ids(path) == set()
    append_records(path, [_row("a", 1.0)])
    assert list(read_records(path)["trial_id"]) == ["a"]
