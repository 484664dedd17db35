"""Figures and the report: histograms count what they show, the fitness map finds a known peak,
``write_report`` writes reproducible files."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from experiments_helpers import concat_records, make_records

from photomodel.errors import InputError
from photomodel.experiments._records import append_records, read_records
from photomodel.experiments._report import (
    error_histograms,
    fitness_map,
    fitness_map_figure,
    ga_evolution_figure,
    write_report,
)
from photomodel.geometry import eps_from_rotation, make_transform

SUMMARY = {"commit": "abc1234", "settings": {"seed": 7, "trials": 60},
           "versions": {"numpy": "2.0", "photomodel": "0.1.0"},
           "machine": {"cpus": 16}, "wall_seconds": 12.345}


def _records() -> dict[str, np.ndarray]:
    rng = np.random.default_rng(0)
    parts = []
    for g, n in (("No.1", 20), ("No.3", 30)):
        parts.append(make_records(rng.normal(0.4, 1.2, n), rng.normal(0.1, 1.0, n),
                                  rng.normal(-3.5, 6.0, n), rng.normal(0.4, 0.9, n),
                                  garment=g, found=(rng.random(n) > 0.1).astype(int),
                                  seconds=rng.uniform(1, 2, n)))
    records = concat_records(*parts)
    records["err_x_mm"][3] = 250.0  # one gross outlier
    records["err_xy_mm"][3] = np.hypot(250.0, records["err_y_mm"][3])
    return records


def _true_pose() -> np.ndarray:
    c, s = np.cos(0.4), np.sin(0.4)
    R = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    return make_transform(R, [12.0, -30.0, 690.0])


def test_histograms_show_every_finite_value_and_count_the_outliers() -> None:
    records = _records()
    fig = error_histograms(records)
    axes = fig.axes
    assert len(axes) == 4
    assert [ax.get_xlabel() for ax in axes] == ["x error [mm]", "y error [mm]",
                                                "z error [mm]", "θ error [deg]"]
    x_counts = axes[0].patches[0].get_data().values
    assert x_counts.sum() == 49 and "1 outside the axis" in axes[0].get_title()
    assert axes[0].get_xlim()[1] < 250.0
    for ax in axes[1:]:
        assert ax.patches[0].get_data().values.sum() == 50
        assert "0 outside the axis" in ax.get_title()
    one = error_histograms(records, "No.3")
    assert one.axes[1].patches[0].get_data().values.sum() == 30
    assert "garment No.3 (30 trials)" in one.get_suptitle()


def test_histograms_of_missing_or_constant_errors_still_build() -> None:
    records = make_records([np.nan, np.nan], [1.0, 1.0], 0, 0)
    fig = error_histograms(records)
    assert fig.axes[0].get_title() == "no data"
    assert fig.axes[1].patches[0].get_data().values.sum() == 2
    fig.canvas.draw()


def test_fitness_map_finds_a_known_peak_on_a_grid_around_the_truth() -> None:
    T = _true_pose()
    peak = np.array([12.0 + 7.3, -30.0 - 4.6])
    calls = []

    def bump(poses: np.ndarray) -> np.ndarray:
        calls.append(len(poses))
        assert poses.shape[1] == 6
        np.testing.assert_array_equal(poses[:, 2], 690.0)
        np.testing.assert_allclose(poses[:, 3:], np.broadcast_to(eps_from_rotation(T[:3, :3]),
                                                                 (len(poses), 3)))
        return np.exp(-np.sum((poses[:, :2] - peak) ** 2, axis=1) / (2 * 15.0**2))

    x_mm, y_mm, F = fitness_map(bump, T, half_range_mm=21.0, step_mm=2.0, chunk=100)
    np.testing.assert_allclose(x_mm, 12.0 + np.arange(-20, 21, 2))
    np.testing.assert_allclose(y_mm, -30.0 + np.arange(-20, 21, 2))
    assert F.shape == (21, 21) and calls == [100] * 4 + [41]
    i, j = np.unravel_index(np.argmax(F), F.shape)
    assert abs(x_mm[j] - peak[0]) <= 1.0 and abs(y_mm[i] - peak[1]) <= 1.0
    # F[i, j] is at (x_mm[j], y_mm[i]).
    assert F[3, 17] == pytest.approx(np.exp(-((x_mm[17] - peak[0]) ** 2
                                              + (y_mm[3] - peak[1]) ** 2) / 450.0))


def test_fitness_map_peak_at_the_truth_is_the_centre_node() -> None:
    T = _true_pose()

    def at_truth(poses: np.ndarray) -> np.ndarray:
        return -np.hypot(poses[:, 0] - 12.0, poses[:, 1] + 30.0)

    x_mm, y_mm, F = fitness_map(at_truth, T, half_range_mm=6.0, step_mm=2.0)
    assert np.unravel_index(np.argmax(F), F.shape) == (3, 3)
    assert (x_mm[3], y_mm[3]) == (12.0, -30.0)


@pytest.mark.slow
def test_fitness_map_of_the_real_fitness_peaks_at_the_truth(plaid_case) -> None:
    from photomodel.fitness import make_fitness
    from photomodel.sim import random_stereo_scene

    scene = random_stereo_scene(plaid_case.garment, plaid_case.rig, rng=3)
    fit = make_fitness("balanced", plaid_case.built.model, plaid_case.rig, scene.right_bgr,
                       scene.left_bgr)
    x_mm, y_mm, F = fitness_map(fit, scene.T_cam1_model, half_range_mm=8.0, step_mm=2.0)
    i, j = np.unravel_index(np.argmax(F), F.shape)
    assert abs(x_mm[j] - scene.T_cam1_model[0, 3]) <= 2.0
    assert abs(y_mm[i] - scene.T_cam1_model[1, 3]) <= 2.0
    assert F[4, 4] == pytest.approx(fit(np.r_[scene.T_cam1_model[:3, 3],
                                              eps_from_rotation(scene.T_cam1_model[:3, :3])]
                                        [None])[0])


def test_fitness_map_rejects_bad_arguments() -> None:
    with pytest.raises(ValueError, match="T_cam1_model_true"):
        fitness_map(lambda p: p[:, 0], np.eye(3))
    with pytest.raises(ValueError, match="step_mm"):
        fitness_map(lambda p: p[:, 0], np.eye(4), step_mm=0.0)
    with pytest.raises(ValueError, match="fitness_fn: expected 9 values"):
        fitness_map(lambda p: p[:2, 0], np.eye(4), half_range_mm=1.0, step_mm=1.0)


def test_fitness_map_and_ga_figures_build() -> None:
    x_mm, y_mm, F = fitness_map(lambda p: -np.abs(p[:, 0]) - np.abs(p[:, 1]), np.eye(4),
                                half_range_mm=10.0, step_mm=2.0)
    fig = fitness_map_figure(x_mm, y_mm, F, true_xy=(0.0, 0.0))
    assert len(fig.axes) == 3  # heat map, colour bar, surface
    assert len(fitness_map_figure(x_mm, y_mm, F, surface=False).axes) == 2
    with pytest.raises(ValueError, match="fitness: expected shape"):
        fitness_map_figure(x_mm, y_mm[:-1], F)
    ga = ga_evolution_figure(np.linspace(1, 5, 30), np.linspace(0, 3, 30))
    lines = ga.axes[0].get_lines()
    assert [ln.get_label() for ln in lines] == ["best", "population mean"]
    np.testing.assert_array_equal(lines[0].get_xdata(), np.arange(30))
    with pytest.raises(ValueError, match="equal non-zero lengths"):
        ga_evolution_figure([1, 2], [1])


def test_write_report_writes_the_report_and_figures_reproducibly(tmp_path: Path) -> None:
    records = _records()
    fmap = fitness_map(lambda p: -np.hypot(p[:, 0], p[:, 1]), np.eye(4), 8.0, 2.0)
    kw = {"fitness_map": (*fmap, (0.0, 0.0)),
          "ga_history": (np.linspace(1, 5, 20), np.linspace(0, 3, 20))}
    path = write_report(tmp_path / "a", records, SUMMARY, **kw)
    assert path == tmp_path / "a" / "report.md"
    names = sorted(p.name for p in path.parent.iterdir())
    assert names == ["fitness_map.png", "ga_evolution.png", "hist_No.1.png", "hist_No.3.png",
                     "hist_all.png", "report.md"]
    text = path.read_text(encoding="utf-8")
    for needle in ("abc1234", "| seed | 7 |", "| trials | 50 (", "No.1, No.3", "12.3 s",
                   "Table 1: garment No.3", "x mm (ours / paper)", " / 0.449 ", " / 5.94 ",
                   "## Table 1: all garments", "| **all** | 50 |", "Fig. 11", "Figs. 12-13",
                   "Figs. 14-16", "Fig. 6", "](hist_No.3.png)", "](hist_No.1.png)",
                   "](fitness_map.png)", "](ga_evolution.png)", '"wall_seconds": 12.345'):
        assert needle in text, needle
    assert "found trials only" in text  # No.3 has trials that were not found
    first = {name: (path.parent / name).read_bytes() for name in names}
    assert write_report(tmp_path / "a", records, SUMMARY, **kw) == path  # overwrites in place
    for name in names:
        assert (path.parent / name).read_bytes() == first[name], name
    assert not list(path.parent.glob(".*"))  # no temporary files left


def test_write_report_reads_a_records_file_and_handles_a_missing_focus(tmp_path: Path) -> None:
    records = make_records([0.5, -0.5, 1.5], 0.1, -2.0, 0.3, garment="No.7")
    csv = tmp_path / "records.csv"
    append_records(csv, [{c: records[c][i] for c in records} for i in range(3)])
    assert read_records(csv)["garment"].tolist() == ["No.7"] * 3
    path = write_report(tmp_path / "out", csv, {})
    text = path.read_text(encoding="utf-8")
    assert "No trials of garment No.3" in text and "| 0.449 | 0.136 | -3.46 | 0.379 |" in text
    assert sorted(p.name for p in path.parent.iterdir()) == ["hist_No.7.png", "hist_all.png",
                                                             "report.md"]


def test_write_report_without_records_is_an_input_error(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="^records: no records$"):
        write_report(tmp_path / "out", make_records([], [], [], []), SUMMARY)
    csv = tmp_path / "records.csv"
    append_records(csv, [])
    with pytest.raises(InputError, match="records.csv: no records"):
        write_report(tmp_path / "out", csv, SUMMARY)
    assert not (tmp_path / "out").exists()
