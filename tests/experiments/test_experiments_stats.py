"""Table 1 statistics on records with known errors, against values computed by hand."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
from experiments_helpers import concat_records, make_records

from photomodel.errors import InputError
from photomodel.experiments._stats import (
    AXES,
    PAPER_TABLE1,
    AxisError,
    ErrorTable,
    error_table,
    error_tables,
    garment_order,
    garment_summary_markdown,
    table1_markdown,
)

# Table 1 of the paper as printed, rows "average error + k sigma" for k = -3..3 (x, y, z, theta).
PRINTED_SIGMA_ROWS = {
    -3: (-3.24, -2.89, -21.3, -2.46),
    -2: (-2.01, -1.88, -15.3, -1.51),
    -1: (-0.782, -0.874, 9.39, -0.566),
    0: (0.449, 0.136, -3.46, 0.379),
    1: (1.68, 1.15, 2.48, 1.32),
    2: (2.91, 2.16, 8.24, 2.27),
    3: (4.14, 3.17, 14.4, 3.21),
}
# Printing typos in the paper's z column: -1σ lost its sign, +2σ has its digits swapped.
TYPOS = {(-1, 2): -9.40, (2, 2): 8.42}


def _standardised(n: int, seed: int) -> np.ndarray:
    """n values with mean exactly 0 and sample standard deviation (ddof=1) exactly 1."""
    u = np.random.default_rng(seed).normal(size=n)
    return (u - u.mean()) / u.std(ddof=1)


def _with_moments(means: tuple[float, ...], stds: tuple[float, ...], n: int = 1000,
                  garment: str = "No.3") -> dict[str, np.ndarray]:
    errs = [m + s * _standardised(n, seed)
            for seed, (m, s) in enumerate(zip(means, stds, strict=True))]
    return make_records(*errs, garment=garment)


def test_paper_table_rows_follow_from_mean_and_std_as_printed() -> None:
    rows = dict(PAPER_TABLE1.rows()[2:])
    labels = ["Average error (-3σ)", "Average error (-2σ)", "Average error (-1σ)",
              "Average error", "Average error (+1σ)", "Average error (+2σ)",
              "Average error (+3σ)"]
    assert [label for label, _ in PAPER_TABLE1.rows()[2:]] == labels
    for k, label in zip(range(-3, 4), labels, strict=True):
        for i, printed in enumerate(PRINTED_SIGMA_ROWS[k]):
            printed = TYPOS.get((k, i), printed)
            # Agreement to one unit in the last printed digit (3 significant figures); the
            # paper computed its rows from unrounded means and deviations.
            unit = 10.0 ** (math.floor(math.log10(abs(printed))) - 2)
            assert abs(rows[label][i] - printed) <= 1.01 * unit, (k, i, rows[label][i], printed)


def test_table_of_records_with_the_papers_moments_reproduces_the_papers_table() -> None:
    means = tuple(PAPER_TABLE1.axis(a).mean for a in AXES)
    stds = tuple(PAPER_TABLE1.axis(a).std for a in AXES)
    table = error_table(_with_moments(means, stds), "No.3")
    for (label, ours), (plabel, paper) in zip(table.rows(), PAPER_TABLE1.rows(), strict=True):
        assert label == plabel
        np.testing.assert_allclose(ours, paper, rtol=0, atol=1e-9)
    assert (table.trials, table.found) == (1000, 1000)
    assert all(table.axis(a).n == 1000 for a in AXES)


def test_exact_values_give_mean_sample_std_and_sigma_rows() -> None:
    records = make_records([1, 2, 3, 4, 5], [0, 0, 0, 0, 2], [-5, -5, -5, -5, -5],
                           [0.5, -0.5, 0.5, -0.5, 0.0], seconds=[1, 2, 3, 4, 50])
    t = error_table(records)
    assert t.label == "all"
    assert (t.x_mm.mean, t.x_mm.std) == pytest.approx((3.0, math.sqrt(2.5)))
    assert (t.y_mm.mean, t.y_mm.std) == pytest.approx((0.4, math.sqrt(0.8)))
    assert (t.z_mm.mean, t.z_mm.std) == pytest.approx((-5.0, 0.0))
    assert (t.theta_deg.mean, t.theta_deg.std) == pytest.approx((0.0, math.sqrt(1.0 / 4)))
    rows = dict(t.rows())
    assert rows["Average error (+2σ)"][0] == pytest.approx(3.0 + 2 * math.sqrt(2.5))
    assert rows["Average error (-3σ)"][1] == pytest.approx(0.4 - 3 * math.sqrt(0.8))
    assert rows["Standard deviation (σ)"][2] == 0.0
    assert t.median_seconds == 3.0


def test_standard_deviation_is_the_sample_one() -> None:
    t = error_table(make_records([0.0, 2.0], 0, 0, 0))
    assert t.x_mm.std == pytest.approx(math.sqrt(2.0))  # ddof=0 would give 1
    single = error_table(make_records([4.0], 0, 0, 0))
    assert single.x_mm.mean == 4.0 and math.isnan(single.x_mm.std)


def test_per_garment_filtering_and_natural_order() -> None:
    records = concat_records(
        make_records([10.0] * 3, 1, 2, 3, garment="No.10"),
        make_records([-1.0] * 2, 0, 0, 0, garment="No.3"),
        make_records([5.0, 7.0], 0, 0, 0, garment="No.1"),
    )
    tables = error_tables(records)
    assert list(tables) == ["No.1", "No.3", "No.10", "all"]
    assert tables["No.10"].x_mm.mean == 10.0 and tables["No.10"].trials == 3
    assert tables["No.3"].x_mm.mean == -1.0 and tables["No.3"].trials == 2
    assert tables["No.1"].x_mm.mean == 6.0
    assert tables["all"].trials == 7
    assert tables["all"].x_mm.mean == pytest.approx((30 - 2 + 12) / 7)
    assert error_table(records, "No.3") == tables["No.3"]
    assert garment_order(["No.12", "No.2", "No.2", "No.1"]) == ["No.1", "No.2", "No.12"]


def test_found_only_keeps_the_accepted_trials() -> None:
    records = make_records([1.0, 2.0, 30.0, 40.0], 0, 0, 0, found=[1, 1, 0, 0])
    everything = error_table(records)
    assert (everything.trials, everything.found) == (4, 2)
    assert everything.x_mm.mean == pytest.approx(18.25)
    assert everything.found_fraction == 0.5
    found = error_table(records, found_only=True)
    assert (found.trials, found.found, found.x_mm.n) == (2, 2, 2)
    assert found.x_mm.mean == pytest.approx(1.5)
    assert found.gross_failures == 0 and everything.gross_failures == 2


def test_gross_failures_count_xy_above_10_mm_or_theta_above_10_deg() -> None:
    x = [10.0, 8.0, 7.1, 0.0, 0.0, 0.0, 0.0, math.nan]
    y = [0.0, 6.0, 7.1, 0.0, 0.0, 0.0, 0.0, math.nan]
    theta = [0.0, 0.0, 0.0, 10.0, -10.0, -10.5, 10.5, math.nan]
    # xy: 10 (not above), 10 (not), 10.04 (gross); theta: +-10 (not), -10.5 and 10.5 (gross).
    t = error_table(make_records(x, y, 0, theta))
    assert t.gross_failures == 3
    assert t.trials == 8 and t.x_mm.n == 7 and t.theta_deg.n == 7
    assert error_table(make_records(x, y, 0, theta), gross_xy_mm=5.0).gross_failures == 5


def test_theta_error_is_taken_as_recorded_not_recomputed() -> None:
    # Truth 179 deg, estimate -179 deg: the recorded (wrapped) error is +2 deg, not -358.
    records = make_records([0.0, 0.0], 0, 0, [2.0, 2.0])
    records["true_theta_deg"][:] = 179.0
    records["est_theta_deg"][:] = -179.0
    t = error_table(records)
    assert t.theta_deg.mean == 2.0 and t.gross_failures == 0


def test_missing_errors_are_skipped_per_axis() -> None:
    records = make_records([1.0, 3.0, math.nan], [2.0, math.nan, math.nan], 0, 0,
                           found=[1, 0, 0], seconds=[1.0, math.nan, 3.0])
    t = error_table(records)
    assert (t.trials, t.x_mm.n, t.y_mm.n, t.z_mm.n) == (3, 2, 1, 3)
    assert t.x_mm.mean == 2.0 and t.y_mm.mean == 2.0 and math.isnan(t.y_mm.std)
    assert t.median_seconds == 2.0


def test_empty_selection_gives_nan_without_warnings() -> None:
    records = make_records([1.0], 0, 0, 0, garment="No.1")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        t = error_table(records, "No.7")
        empty = error_table(make_records([], [], [], []))
    assert t.trials == 0 and t.x_mm.n == 0 and math.isnan(t.x_mm.mean)
    assert math.isnan(t.found_fraction) and math.isnan(t.median_seconds)
    assert empty.trials == 0 and empty.gross_failures == 0


def test_missing_column_is_an_input_error() -> None:
    records = make_records([1.0], 0, 0, 0)
    del records["err_z_mm"]
    with pytest.raises(InputError, match="records: missing columns \\['err_z_mm'\\]"):
        error_table(records)


def test_within_paper_band() -> None:
    # The paper's claim holds for its own No.3: x, y within +-10 mm, theta within +-10 deg
    # (z, at -21.3..14.4 mm, is not part of the claim).
    assert PAPER_TABLE1.within_paper_band()
    wide_x = ErrorTable("t", AxisError(10, 0.5, 3.2), PAPER_TABLE1.y_mm, PAPER_TABLE1.z_mm,
                        PAPER_TABLE1.theta_deg)  # +3σ = 10.1 mm
    wide_theta = ErrorTable("t", PAPER_TABLE1.x_mm, PAPER_TABLE1.y_mm, PAPER_TABLE1.z_mm,
                            AxisError(10, -0.5, 3.2))  # -3σ = -10.1 deg
    assert not wide_x.within_paper_band() and not wide_theta.within_paper_band()
    assert wide_x.within_paper_band(xy_mm=10.2)
    assert not ErrorTable("t", *(AxisError(0, math.nan, math.nan),) * 4).within_paper_band()


def test_table1_markdown_sets_ours_beside_the_papers() -> None:
    records = make_records([1, 2, 3, 4, 5], 0, -2, 0.25, found=[1, 1, 1, 1, 0])
    text = table1_markdown(error_table(records, "No.3"))
    header = text.splitlines()[0]
    assert "x mm (ours / paper)" in header and "θ deg (ours / paper)" in header
    for paper_value in ("0.449", "0.136", "-3.46", "0.379", "1.23", "1.01", "5.94", "0.945",
                        "-21.3", "14.4", "-9.40", "8.42"):
        assert f" / {paper_value} " in text, paper_value
    assert "| Average error | 3.00 / 0.449 | 0.00 / 0.136 | -2.00 / -3.46 | 0.250 / 0.379 |" in text
    assert "| Standard deviation (σ) | 1.58 / 1.23 |" in text
    assert ("No.3: 5 trials, 4 found; gross failures (x-y error > 10 mm or |θ error| > 10 deg): 0;"
            in text)
    assert "errors measured per axis: x 5, y 5, z 5, theta 5." in text
    assert text.rstrip().endswith("the paper's claim: yes.")
    assert len([line for line in text.splitlines() if line.startswith("| Average")]) == 8
    alone = table1_markdown(error_table(records), paper=None)
    assert " / " not in alone.split("\n\n")[0] and "| x mm |" in alone


def test_garment_summary_markdown_has_a_row_per_garment_and_all() -> None:
    records = concat_records(
        make_records([1.0, 3.0], 0, 0, 0, garment="No.2", found=[1, 0], seconds=[2, 4]),
        make_records([0.0, 0.0, 0.0, 20.0], 0, 0, 0, garment="No.11", seconds=1.5),
    )
    text = garment_summary_markdown(error_tables(records))
    lines = text.splitlines()
    assert lines[0].startswith("| Garment | n | found % | x mm mean ± σ")
    assert "gross failures | median s |" in lines[0]
    assert lines[2].startswith("| No.2 | 2 | 50.0 | 2.00 ± 1.41 | 0.00 ± 0.00 |")
    assert lines[2].endswith("| 0 | 3.00 |")
    assert lines[3].startswith("| No.11 | 4 | 100.0 | 5.00 ± 10.0 |")
    assert lines[3].endswith("| 1 | 1.50 |")
    assert lines[4].startswith("| **all** | 6 | 83.3 |")
