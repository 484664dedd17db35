"""Error statistics of an experiment in the form of the paper's Table 1, and as Markdown.

The paper (sec. 4, Table 1) gives, for garment No.3, the average error and standard deviation
of the estimated x, y, z (mm) and in-plane angle theta (deg), then the rows "average error
+- k sigma" for k = 1, 2, 3, and claims that for all 12 garments the average +- 3 sigma lies
within 10 mm in x-y and within 10 deg in theta. This module computes the same table from the
columns of ``records.csv`` (:func:`photomodel.experiments._records.read_records`).

Choices made here (the paper does not state them):

* **Which trials count.** By default *every* trial counts, found or not, because the paper
  reports its statistics over all of its 1000 recognitions and does not mention discarding
  any. ``found_only=True`` restricts the table to trials whose recognition was accepted.
* **Standard deviation.** The sample standard deviation (``ddof=1``, divisor ``n - 1``);
  with fewer than two values it is NaN.
* **Missing errors.** A trial without a truth pose (a scene with no target) or without an
  estimate has non-finite errors; it counts in ``trials`` (and ``found``) but is skipped, axis
  by axis, in the means and deviations (each axis keeps its own ``n``).
* **Theta** is taken exactly as recorded (``err_theta_deg``, already wrapped to (-180, 180]);
  it is not recomputed from the true and estimated angles.
* **Gross failure.** A trial whose x-y error ``err_xy_mm`` exceeds 10 mm or whose
  ``|err_theta_deg|`` exceeds 10 deg: the band the paper's +-3 sigma claim names. Trials
  without a measured error are not counted as gross failures (they show in ``found``).
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from photomodel.errors import InputError

__all__ = [
    "AXES",
    "GROSS_THETA_DEG",
    "GROSS_XY_MM",
    "PAPER_TABLE1",
    "AxisError",
    "ErrorTable",
    "error_table",
    "error_tables",
    "garment_order",
    "garment_summary_markdown",
    "table1_markdown",
]

AXES: tuple[str, ...] = ("x_mm", "y_mm", "z_mm", "theta_deg")
"""Axes of Table 1, in the paper's column order; the records column is ``"err_" + axis``."""

AXIS_LABELS: dict[str, str] = {"x_mm": "x mm", "y_mm": "y mm", "z_mm": "z mm",
                               "theta_deg": "θ deg"}

GROSS_XY_MM = 10.0
"""x-y error (mm) above which a trial is a gross failure (the paper's +-3 sigma band)."""

GROSS_THETA_DEG = 10.0
"""|theta| error (deg) above which a trial is a gross failure (the paper's +-3 sigma band)."""

SIGMAS: tuple[int, ...] = (-3, -2, -1, 0, 1, 2, 3)
"""The k of the paper's rows "average error + k sigma"."""

_NEEDED = ("garment", "found", "seconds", "err_xy_mm") + tuple(f"err_{a}" for a in AXES)


@dataclass(frozen=True)
class AxisError:
    """Statistics of one error axis.

    Attributes
    ----------
    n : int or None
        Number of finite errors that entered ``mean`` and ``std`` (None: not reported).
    mean : float
        Average error (mm, or deg for theta); NaN when ``n`` is 0.
    std : float
        Sample standard deviation (``ddof=1``), same unit; NaN when ``n`` < 2.
    """

    n: int | None
    mean: float
    std: float

    def at_sigma(self, k: float) -> float:
        """``mean + k * std``: the paper's row "average error (k sigma)"."""
        return self.mean + k * self.std


@dataclass(frozen=True)
class ErrorTable:
    """Table 1 of the paper for one set of trials.

    Attributes
    ----------
    label : str
        The garment name (``"No.3"``), ``"all"``, or a description for the paper's table.
    x_mm, y_mm, z_mm : AxisError
        Position errors, estimate minus truth in camera 1's frame, mm.
    theta_deg : AxisError
        In-plane angle error about camera 1's z axis, deg.
    trials : int or None
        Rows (trials) the table was computed from (None: not reported).
    found : int or None
        How many of them were accepted as found.
    gross_failures : int or None
        Trials with x-y error > ``gross_xy_mm`` or |theta error| > ``gross_theta_deg``.
    median_seconds : float
        Median recognition time per trial, s (NaN when unknown).
    gross_xy_mm, gross_theta_deg : float
        Thresholds of a gross failure, mm and deg (by default the paper's 10 mm, 10 deg).
    """

    label: str
    x_mm: AxisError
    y_mm: AxisError
    z_mm: AxisError
    theta_deg: AxisError
    trials: int | None = None
    found: int | None = None
    gross_failures: int | None = None
    median_seconds: float = math.nan
    gross_xy_mm: float = GROSS_XY_MM
    gross_theta_deg: float = GROSS_THETA_DEG

    def axis(self, name: str) -> AxisError:
        """The statistics of axis ``name`` (one of ``AXES``)."""
        if name not in AXES:
            raise ValueError(f"axis: expected one of {AXES}, got {name!r}")
        stats: AxisError = getattr(self, name)
        return stats

    @property
    def found_fraction(self) -> float:
        """``found / trials`` in [0, 1] (NaN when unknown or no trials)."""
        if not self.trials or self.found is None:
            return math.nan
        return self.found / self.trials

    def rows(self) -> list[tuple[str, tuple[float, ...]]]:
        """The paper's rows: (label, values in ``AXES`` order).

        "Average error", "Standard deviation (σ)", then "Average error (-3σ)" ... "(+3σ)",
        the middle one (k = 0) printed as "Average error" as in the paper.
        """
        stats = [self.axis(a) for a in AXES]
        out = [("Average error", tuple(s.mean for s in stats)),
               ("Standard deviation (σ)", tuple(s.std for s in stats))]
        for k in SIGMAS:
            label = "Average error" if k == 0 else f"Average error ({k:+d}σ)"
            out.append((label, tuple(s.at_sigma(k) for s in stats)))
        return out

    def within_paper_band(self, xy_mm: float = GROSS_XY_MM,
                          theta_deg: float = GROSS_THETA_DEG) -> bool:
        """Whether mean +- 3 sigma of x and y lies within +-``xy_mm`` and of theta within
        +-``theta_deg``: the paper's claim for its 12 garments (False if a value is NaN)."""
        limits = {"x_mm": xy_mm, "y_mm": xy_mm, "theta_deg": theta_deg}
        for name, limit in limits.items():
            s = self.axis(name)
            lo, hi = s.at_sigma(-3), s.at_sigma(3)
            if not (-limit <= lo and hi <= limit):
                return False
        return True


# The paper's Table 1 (garment No.3). Only the averages and deviations are data; its rows
# "average error +- k sigma" follow from them and agree with the printed values to the printed
# precision except for two typos in the z column: "-1σ" is printed 9.39 (a sign typo for -9.40)
# and "+2σ" is printed 8.24 (digits swapped; -3.46 + 2 * 5.94 = 8.42). The paper does not say
# how many of its 1000 recognitions were of No.3, so the counts are left unreported (None).
PAPER_TABLE1 = ErrorTable(
    label="paper, No.3",
    x_mm=AxisError(None, 0.449, 1.23),
    y_mm=AxisError(None, 0.136, 1.01),
    z_mm=AxisError(None, -3.46, 5.94),
    theta_deg=AxisError(None, 0.379, 0.945),
)
"""The seed paper's Table 1 for garment No.3 (errors in mm and deg)."""


def _check_records(records: Mapping[str, NDArray[Any]]) -> int:
    """Number of rows; raises InputError if a needed column is missing or lengths differ."""
    missing = [c for c in _NEEDED if c not in records]
    if missing:
        raise InputError("records", f"missing columns {missing}")
    lengths = {len(records[c]) for c in _NEEDED}
    if len(lengths) != 1:
        raise InputError("records", f"columns of different lengths {sorted(lengths)}")
    return lengths.pop()


def _axis_error(values: NDArray[np.float64]) -> AxisError:
    v = values[np.isfinite(values)]
    n = int(v.size)
    mean = float(v.mean()) if n else math.nan
    std = float(v.std(ddof=1)) if n >= 2 else math.nan
    return AxisError(n, mean, std)


def _select(records: Mapping[str, NDArray[Any]], mask: NDArray[np.bool_], label: str,
            gross_xy_mm: float, gross_theta_deg: float) -> ErrorTable:
    err = {a: np.asarray(records[f"err_{a}"], dtype=np.float64)[mask] for a in AXES}
    xy = np.asarray(records["err_xy_mm"], dtype=np.float64)[mask]
    with np.errstate(invalid="ignore"):
        gross = (xy > gross_xy_mm) | (np.abs(err["theta_deg"]) > gross_theta_deg)
    seconds = np.asarray(records["seconds"], dtype=np.float64)[mask]
    seconds = seconds[np.isfinite(seconds)]
    return ErrorTable(
        label=label,
        **{a: _axis_error(err[a]) for a in AXES},  # type: ignore[arg-type]
        trials=int(mask.sum()),
        found=int(np.count_nonzero(np.asarray(records["found"])[mask])),
        gross_failures=int(gross.sum()),
        median_seconds=float(np.median(seconds)) if seconds.size else math.nan,
        gross_xy_mm=gross_xy_mm,
        gross_theta_deg=gross_theta_deg,
    )


def error_table(records: Mapping[str, NDArray[Any]], garment: str | None = None,
                found_only: bool = False, *, gross_xy_mm: float = GROSS_XY_MM,
                gross_theta_deg: float = GROSS_THETA_DEG) -> ErrorTable:
    """Table 1 of the trials of one garment (or of all), from the records' columns.

    Parameters
    ----------
    records : mapping of str to ndarray (N,)
        Columns as :func:`read_records` returns them; needs ``garment``, ``found``,
        ``seconds``, ``err_x_mm``, ``err_y_mm``, ``err_z_mm``, ``err_theta_deg``,
        ``err_xy_mm``.
    garment : str, optional
        Keep only this garment's trials; None keeps all.
    found_only : bool
        Keep only trials accepted as found. By default all trials count, as in the paper.
    gross_xy_mm, gross_theta_deg : float
        Thresholds of a gross failure, mm and deg.

    Returns
    -------
    ErrorTable
        Labelled with the garment, or ``"all"``. A selection with no trials gives
        ``trials == 0`` and NaN statistics.

    Raises
    ------
    InputError
        A needed column is missing, or the columns differ in length.
    """
    n = _check_records(records)
    mask = np.ones(n, dtype=bool)
    if garment is not None:
        mask &= np.asarray(records["garment"]).astype(str) == garment
    if found_only:
        mask &= np.asarray(records["found"]) != 0
    label = "all" if garment is None else garment
    return _select(records, mask, label, gross_xy_mm, gross_theta_deg)


def garment_order(names: object) -> list[str]:
    """Garment names sorted naturally ("No.2" before "No.10"), without duplicates."""
    def key(name: str) -> tuple[Any, ...]:
        return tuple(int(t) if t.isdigit() else t for t in re.split(r"(\d+)", name))
    return sorted({str(g) for g in np.asarray(names).ravel()}, key=key)


def error_tables(records: Mapping[str, NDArray[Any]], found_only: bool = False,
                 **kw: float) -> dict[str, ErrorTable]:
    """Table 1 per garment (natural order: No.1, No.2, ..., No.10) and over all, key ``"all"``.

    Parameters are those of :func:`error_table`; a garment literally named ``"all"`` would be
    shadowed by the overall table.
    """
    _check_records(records)
    tables = {g: error_table(records, g, found_only, **kw)
              for g in garment_order(records["garment"])}
    tables["all"] = error_table(records, None, found_only, **kw)
    return tables


def _fmt(value: float | None, digits: int = 3) -> str:
    """A number to ``digits`` significant figures, trailing zeros kept, as the paper prints
    them (-9.40, 0.449, -21.3); whole numbers from ``10**digits`` on; "—" if missing."""
    if value is None or not math.isfinite(value):
        return "—"
    if abs(value) >= 10 ** digits:
        return f"{value:.0f}"
    return f"{value + 0.0:#.{digits}g}".rstrip(".")  # + 0.0 turns -0.0 into 0.0


def table1_markdown(table: ErrorTable, paper: ErrorTable | None = PAPER_TABLE1) -> str:
    """Table 1 as a Markdown table, with the paper's value beside each of ours.

    Parameters
    ----------
    table : ErrorTable
        Our statistics.
    paper : ErrorTable or None
        Shown as ``ours / paper`` in every cell (columns "x mm (ours / paper)" ...); None
        shows ours alone.

    Returns
    -------
    str
        The table, then a line with the counts (trials, found, gross failures) and whether
        mean +- 3 sigma is within the paper's band, ending in a newline.
    """
    suffix = " (ours / paper)" if paper is not None else ""
    header = ["Row"] + [AXIS_LABELS[a] + suffix for a in AXES]
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" + "---:|" * len(AXES)]
    paper_rows = paper.rows() if paper is not None else None
    for i, (label, values) in enumerate(table.rows()):
        if paper_rows is None:
            cells = [_fmt(v) for v in values]
        else:
            cells = [f"{_fmt(v)} / {_fmt(p)}" for v, p in zip(values, paper_rows[i][1],
                                                                  strict=True)]
        lines.append(f"| {label} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n\n" + _table_note(table) + "\n"


def _table_note(table: ErrorTable) -> str:
    """One line under a Table 1: counts, gross failures, and the paper's +-3 sigma claim."""
    band = "yes" if table.within_paper_band() else "no"
    claim = (f"Mean ± 3σ within ±{GROSS_XY_MM:g} mm (x, y) and ±{GROSS_THETA_DEG:g} deg (θ), "
             f"the paper's claim: {band}.")
    if table.trials is None:
        return f"{table.label}. {claim}"
    n_axes = ", ".join(f"{a.split('_')[0]} {table.axis(a).n}" for a in AXES)
    return (f"{table.label}: {table.trials} trials, {table.found} found; gross failures "
            f"(x-y error > {table.gross_xy_mm:g} mm or |θ error| > "
            f"{table.gross_theta_deg:g} deg): {table.gross_failures}; errors measured per "
            f"axis: {n_axes}. {claim}")


def _mean_std(s: AxisError) -> str:
    return f"{_fmt(s.mean)} ± {_fmt(s.std)}"


def garment_summary_markdown(tables: Mapping[str, ErrorTable]) -> str:
    """One Markdown row per table (e.g. from :func:`error_tables`): the per-garment summary.

    Columns: garment, trials, found %, mean ± std of the x, y, z (mm) and θ (deg) errors,
    gross failures, median seconds per recognition. Ends in a newline.
    """
    header = ["Garment", "n", "found %"] + [f"{AXIS_LABELS[a]} mean ± σ" for a in AXES] + [
        "gross failures", "median s"]
    lines = ["| " + " | ".join(header) + " |", "|---|" + "---:|" * (len(header) - 1)]
    for name, t in tables.items():
        found = t.found_fraction
        cells = [f"**{name}**" if name == "all" else name, str(t.trials),
                 "—" if math.isnan(found) else f"{100 * found:.1f}"]
        cells += [_mean_std(t.axis(a)) for a in AXES]
        cells += [str(t.gross_failures), _fmt(t.median_seconds)]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"
