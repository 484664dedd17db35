"""Trial records of an experiment: one CSV row per recognition, appended as trials finish.

The CSV is the experiment's durable state: a run that is interrupted keeps every finished row,
and a rerun skips the trials whose ``trial_id`` is already there (resumable). Errors are
estimate minus truth in camera 1's frame (the paper's x, y, z of the model frame seen from the
right camera), ``err_theta_deg`` wrapped to (-180, 180].
"""

from __future__ import annotations

import csv
import io
import os
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from photomodel._files import append_lines
from photomodel.errors import InputError

__all__ = ["COLUMNS", "FLOAT_COLUMNS", "append_records", "done_trial_ids", "read_records"]

COLUMNS: tuple[str, ...] = (
    "trial_id", "garment", "condition", "index", "found", "score", "fitness",
    "evaluations", "generations", "seconds",
    "true_x_mm", "true_y_mm", "true_z_mm", "true_theta_deg",
    "est_x_mm", "est_y_mm", "est_z_mm", "est_theta_deg",
    "err_x_mm", "err_y_mm", "err_z_mm", "err_theta_deg", "err_xy_mm", "err_tilt_deg",
    "visible_fraction", "stop_reason",
)
"""Columns of ``records.csv``, in order."""

_TEXT = {"trial_id", "garment", "condition", "stop_reason"}
_INT = {"index", "found", "evaluations", "generations"}
FLOAT_COLUMNS: tuple[str, ...] = tuple(c for c in COLUMNS if c not in _TEXT | _INT)


def append_records(path: str | os.PathLike[str], rows: Iterable[Mapping[str, Any]]) -> None:
    """Append rows to the CSV (writing the header first if the file is new), then flush to disk.

    Floats are written with ``repr`` precision, so a reread value is bit-identical.
    """
    append_csv_rows(path, COLUMNS, [{k: (repr(float(v)) if k in FLOAT_COLUMNS else v)
                                     for k, v in row.items()} for row in rows])


def append_csv_rows(path: str | os.PathLike[str], columns: Sequence[str],
                    rows: Iterable[Mapping[str, Any]]) -> None:
    """Append ``rows`` (each keyed by ``columns``) to the CSV ``path`` in one write, flushed to
    disk (:func:`~photomodel._files.append_lines`): the header first when the file holds no
    whole line; a last row cut short by an interruption (no line break) is dropped first."""
    buf = io.StringIO()
    writer = csv.DictWriter(buf, fieldnames=columns, extrasaction="raise", lineterminator="")

    def line(row: Mapping[str, Any] | None) -> bytes:
        buf.seek(0)
        buf.truncate()
        if row is None:
            writer.writeheader()
        else:
            writer.writerow(row)
        return buf.getvalue().encode("utf-8")

    append_lines(path, [line(row) for row in rows], mode=0o644, header=line(None))


def whole_lines(path: Path) -> io.StringIO:
    """The text of the CSV ``path`` up to its last line break, to read rows from: a last row
    without one was cut short by an interruption, and :func:`append_csv_rows` drops it.

    Raises ``OSError`` or ``UnicodeDecodeError``."""
    text = path.read_bytes().decode("utf-8")
    return io.StringIO(text[:text.rfind("\n") + 1], newline="")


def _rows(path: Path) -> list[dict[str, str]]:
    try:
        with whole_lines(path) as f:
            reader = csv.DictReader(f)
            if reader.fieldnames is None:
                return []
            missing = [c for c in COLUMNS if c not in reader.fieldnames]
            if missing:
                raise InputError(path, f"not a records file: missing columns {missing}")
            # A row cut short by an interruption (no newline, missing fields) is dropped, and
            # a trial recorded twice (by runs before the run lock) counts once: the first.
            rows, seen = [], set()
            for row in reader:
                if (None in row or None in row.values() or not row["stop_reason"]
                        or row["trial_id"] in seen):
                    continue
                seen.add(row["trial_id"])
                rows.append(row)
            return rows
    except (OSError, UnicodeDecodeError, csv.Error) as exc:
        raise InputError(path, f"cannot read records: {exc}") from exc


def done_trial_ids(path: str | os.PathLike[str]) -> set[str]:
    """Trial ids already recorded in the CSV (empty if it does not exist)."""
    path = Path(path)
    if not path.exists():
        return set()
    return {row["trial_id"] for row in _rows(path)}


def read_records(path: str | os.PathLike[str]) -> dict[str, NDArray[Any]]:
    """The CSV as columns: text columns as str arrays, counts as int, the rest float (N,).

    Raises
    ------
    InputError
        Missing, unreadable or not a records file.
    """
    path = Path(path)
    if not path.is_file():
        raise InputError(path, "records file not found")
    rows = _rows(path)
    out: dict[str, NDArray[Any]] = {}
    for c in COLUMNS:
        values = [row[c] for row in rows]
        if c in _TEXT:
            out[c] = np.array(values, dtype=str)
        elif c in _INT:
            out[c] = np.array([int(v) for v in values], dtype=np.int64)
        else:
            out[c] = np.array([float(v) for v in values], dtype=np.float64)
    return out
