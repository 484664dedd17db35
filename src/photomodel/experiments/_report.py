"""Figures and the Markdown report of an experiment: the paper's Table 1 and Figs. 6, 11-16.

Figures are built on ``matplotlib.figure.Figure`` with the Agg canvas (no pyplot, so no global
backend switch and no open-figure registry) under matplotlib's default style, whatever the
user's ``matplotlibrc`` says. PNGs are written without the "Software" metadata entry, so the
same input gives the same bytes. Every file is written atomically
(:func:`photomodel._files.write_atomic`).

Figures and their counterparts in the paper:

* :func:`error_histograms`: Figs. 12-13 (No.3: x, y) and 14-16 (No.1-No.12: x, y, theta);
  z is added.
* :func:`fitness_map_figure` (data from :func:`fitness_map`): Fig. 11, fitness over the x-y
  plane around the true pose.
* :func:`ga_evolution_figure`: Fig. 6, best and mean fitness per generation.
"""

from __future__ import annotations

import io
import json
import math
import os
import re
from collections.abc import Callable, Iterator, Mapping
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import matplotlib.style
import numpy as np
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.ticker import MaxNLocator
from numpy.typing import ArrayLike, NDArray

from photomodel._files import write_atomic
from photomodel.errors import InputError
from photomodel.experiments._records import read_records
from photomodel.experiments._stats import (
    PAPER_TABLE1,
    ErrorTable,
    _check_records,
    error_table,
    error_tables,
    garment_order,
    garment_summary_markdown,
    table1_markdown,
)
from photomodel.geometry import eps_from_rotation

__all__ = [
    "error_histograms",
    "fitness_map",
    "fitness_map_figure",
    "ga_evolution_figure",
    "write_report",
]

FitnessFn = Callable[[NDArray[np.float64]], ArrayLike]
"""Fitness of pose vectors (N, 6) = (x, y, z mm, eps1, eps2, eps3) -> (N,)."""

HIST_AXES: tuple[tuple[str, str], ...] = (
    ("err_x_mm", "x error [mm]"), ("err_y_mm", "y error [mm]"),
    ("err_z_mm", "z error [mm]"), ("err_theta_deg", "θ error [deg]"),
)
"""Records columns shown by :func:`error_histograms`, with their axis labels."""

_DPI = 100
_FENCE_IQR = 3.0
_MIN_BINS, _MAX_BINS = 10, 80


@contextmanager
def _style() -> Iterator[None]:
    """matplotlib's default style, so that figures do not depend on the user's rc settings."""
    with matplotlib.style.context("default"):
        yield


def _figure(width_in: float, height_in: float) -> Figure:
    fig = Figure(figsize=(width_in, height_in), dpi=_DPI, layout="constrained")
    FigureCanvasAgg(fig)
    return fig


def _save_png(fig: Figure, path: Path) -> None:
    """Save ``fig`` as a reproducible PNG (no "Software" metadata), atomically."""
    buf = io.BytesIO()
    with _style():
        fig.savefig(buf, format="png", dpi=_DPI, metadata={"Software": None})
    write_atomic(path, buf.getvalue())


# --- error histograms (Figs. 12-16) ------------------------------------------------------


def _robust_range(v: NDArray[np.float64]) -> tuple[float, float]:
    """Axis range: the data, cut at Tukey's far fences (quartiles -+ 3 IQR) if those are
    inside it, so that gross outliers do not squash the histogram; never empty."""
    lo, hi = float(v.min()), float(v.max())
    q1, q3 = np.percentile(v, [25.0, 75.0])
    iqr = float(q3 - q1)
    if iqr > 0:
        lo, hi = max(lo, float(q1) - _FENCE_IQR * iqr), min(hi, float(q3) + _FENCE_IQR * iqr)
    if hi <= lo:
        lo, hi = lo - 0.5, hi + 0.5
    return lo, hi


def _bin_edges(v: NDArray[np.float64], lo: float, hi: float, bins: int | None
               ) -> NDArray[np.float64]:
    if bins is not None:
        return np.linspace(lo, hi, bins + 1)
    shown = v[(v >= lo) & (v <= hi)]
    n = len(np.histogram_bin_edges(shown, bins="auto", range=(lo, hi))) - 1
    return np.linspace(lo, hi, min(max(n, _MIN_BINS), _MAX_BINS) + 1)


def _histogram(ax: Axes, values: NDArray[np.float64], label: str, bins: int | None) -> None:
    v = values[np.isfinite(values)]
    ax.set_xlabel(label)
    ax.set_ylabel("Frequency [times]")
    if v.size == 0:
        ax.set_title("no data")
        ax.text(0.5, 0.5, "no finite errors", transform=ax.transAxes, ha="center")
        return
    lo, hi = _robust_range(v)
    counts, edges = np.histogram(v, bins=_bin_edges(v, lo, hi, bins))
    outside = int(np.count_nonzero((v < lo) | (v > hi)))
    ax.stairs(counts, edges, fill=True, color="tab:blue", alpha=0.8)
    mean = float(v.mean())
    std = float(v.std(ddof=1)) if v.size >= 2 else math.nan
    ax.axvline(mean, color="k", lw=1.2, label=f"mean {mean:.3g}")
    if math.isfinite(std):
        for k in (-3, 3):
            ax.axvline(mean + k * std, color="tab:red", lw=1.0, ls="--",
                       label="mean ± 3σ" if k == 3 else None)
    ax.set_xlim(lo, hi)
    ax.yaxis.set_major_locator(MaxNLocator(integer=True))
    ax.set_title(f"n = {v.size}, σ = {std:.3g}; {outside} outside the axis", fontsize=10)
    ax.legend(fontsize=8, loc="upper right")


def error_histograms(records: Mapping[str, NDArray[Any]], garment: str | None = None,
                     bins: int | None = None) -> Figure:
    """Histograms of the x, y, z and θ errors (the paper's Figs. 12-16), one panel each.

    Parameters
    ----------
    records : mapping of str to ndarray (N,)
        Columns as :func:`read_records` returns them (``garment`` and the ``err_*`` ones).
    garment : str, optional
        Only this garment's trials; None takes all of them.
    bins : int, optional
        Bins over each panel's range; None chooses them from the data (numpy's "auto"
        rule on the values shown, 10 to 80 bins).

    Returns
    -------
    Figure
        A 2 x 2 grid: x, y (mm), z (mm), θ (deg). Each panel's range is the data cut at
        the quartiles -+ 3 IQR; the number of values outside it is in the panel's title.
        The mean (solid) and mean ± 3σ (dashed) are marked. Non-finite errors are left out.
    """
    if bins is not None and bins < 1:
        raise ValueError(f"bins: expected a positive count, got {bins}")
    _check_records(records)
    mask = np.ones(len(records["garment"]), dtype=bool)
    if garment is not None:
        mask = np.asarray(records["garment"]).astype(str) == garment
    title = "all garments" if garment is None else f"garment {garment}"
    with _style():
        fig = _figure(10.0, 7.0)
        axes = fig.subplots(2, 2)
        for ax, (column, label) in zip(axes.ravel(), HIST_AXES, strict=True):
            _histogram(ax, np.asarray(records[column], dtype=np.float64)[mask], label, bins)
        fig.suptitle(f"Pose error histograms, {title} ({int(mask.sum())} trials)")
    return fig


# --- fitness over the x-y plane (Fig. 11) -----------------------------------------------


def fitness_map(fitness_fn: FitnessFn, T_cam1_model_true: ArrayLike,
                half_range_mm: float = 60.0, step_mm: float = 2.0, chunk: int = 4096
                ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Fitness on an x-y grid around the true position, z and orientation held at the truth.

    Parameters
    ----------
    fitness_fn : callable
        ``fitness_fn(poses (N, 6)) -> (N,)``, poses being the paper's vectors (x, y, z mm,
        eps1, eps2, eps3), eps the vector part of the unit quaternion with w >= 0 (e.g. a
        fitness from :func:`photomodel.fitness.make_fitness`).
    T_cam1_model_true : array_like (4, 4)
        The true pose of the model in camera 1's frame, mm.
    half_range_mm : float
        The grid spans the true x and y -+ this (rounded down to whole steps), mm.
    step_mm : float
        Grid spacing, mm. The true position is a grid node.
    chunk : int
        Poses per call of ``fitness_fn`` (bounds its memory).

    Returns
    -------
    x_mm : ndarray (nx,)
        Grid x coordinates in camera 1's frame, mm, increasing.
    y_mm : ndarray (ny,)
        Grid y coordinates, mm, increasing.
    F : ndarray (ny, nx)
        ``F[i, j]`` is the fitness at ``(x_mm[j], y_mm[i])``.
    """
    T = np.asarray(T_cam1_model_true, dtype=np.float64)
    if T.shape != (4, 4):
        raise ValueError(f"T_cam1_model_true: expected shape (4, 4), got {T.shape}")
    if not step_mm > 0 or not half_range_mm >= 0:
        raise ValueError(f"step_mm, half_range_mm: expected > 0 and >= 0, got {step_mm}, "
                         f"{half_range_mm}")
    if chunk < 1:
        raise ValueError(f"chunk: expected a positive count, got {chunk}")
    m = int(math.floor(half_range_mm / step_mm + 1e-9))
    offsets = np.arange(-m, m + 1, dtype=np.float64) * step_mm
    x_mm, y_mm = T[0, 3] + offsets, T[1, 3] + offsets
    X, Y = np.meshgrid(x_mm, y_mm)
    poses = np.empty((X.size, 6))
    poses[:, 0], poses[:, 1], poses[:, 2] = X.ravel(), Y.ravel(), T[2, 3]
    poses[:, 3:] = eps_from_rotation(T[:3, :3])
    parts = []
    for start in range(0, len(poses), chunk):
        batch = poses[start:start + chunk]
        f = np.asarray(fitness_fn(batch), dtype=np.float64).reshape(-1)
        if f.shape != (len(batch),):
            raise ValueError(f"fitness_fn: expected {len(batch)} values, got shape {f.shape}")
        parts.append(f)
    return x_mm, y_mm, np.concatenate(parts).reshape(X.shape)


def fitness_map_figure(x_mm: ArrayLike, y_mm: ArrayLike, fitness: ArrayLike,
                       true_xy: ArrayLike | None = None, surface: bool = True) -> Figure:
    """Fitness over the x-y plane (the paper's Fig. 11): a heat map and a 3D surface.

    Parameters
    ----------
    x_mm : array_like (nx,)
        Grid x coordinates in camera 1's frame, mm.
    y_mm : array_like (ny,)
        Grid y coordinates, mm.
    fitness : array_like (ny, nx)
        ``fitness[i, j]`` at ``(x_mm[j], y_mm[i])``, as :func:`fitness_map` returns it.
    true_xy : array_like (2,), optional
        The true position, mm, marked with a red cross; the grid's maximum is marked "+".
    surface : bool
        Add the 3D surface seen from the side, as the paper shows it.

    Returns
    -------
    Figure
        The heat map's y axis points down, as camera 1's y does.
    """
    x = np.asarray(x_mm, dtype=np.float64).reshape(-1)
    y = np.asarray(y_mm, dtype=np.float64).reshape(-1)
    F = np.asarray(fitness, dtype=np.float64)
    if F.shape != (len(y), len(x)):
        raise ValueError(f"fitness: expected shape (len(y_mm), len(x_mm)) = "
                         f"{(len(y), len(x))}, got {F.shape}")
    with _style():
        fig = _figure(12.0 if surface else 6.5, 5.0)
        ax = fig.add_subplot(1, 2 if surface else 1, 1)
        mesh = ax.pcolormesh(x, y, F, shading="nearest", cmap="viridis")
        fig.colorbar(mesh, ax=ax, label="fitness F")
        if np.isfinite(F).any():
            i, j = np.unravel_index(np.nanargmax(F), F.shape)
            ax.plot(x[j], y[i], "w+", ms=12, mew=2, label=f"maximum ({x[j]:.0f}, {y[i]:.0f})")
        if true_xy is not None:
            tx, ty = np.asarray(true_xy, dtype=np.float64).reshape(2)
            ax.plot(tx, ty, "rx", ms=10, mew=2, label=f"truth ({tx:.0f}, {ty:.0f})")
        ax.set_xlabel("x [mm] (camera 1)")
        ax.set_ylabel("y [mm] (camera 1)")
        ax.set_aspect("equal")
        ax.invert_yaxis()
        ax.legend(fontsize=8, loc="upper right")
        ax.set_title("Fitness over x-y (z, orientation at the truth)")
        if surface:
            ax3 = fig.add_subplot(1, 2, 2, projection="3d")
            X, Y = np.meshgrid(x, y)
            ax3.plot_surface(X, Y, F, cmap="viridis", linewidth=0, antialiased=False)
            ax3.view_init(elev=12.0, azim=-60.0)
            ax3.set_xlabel("x [mm]")
            ax3.set_ylabel("y [mm]")
            ax3.set_zlabel("F")
            ax3.set_title("Side view")
    return fig


# --- GA evolution (Fig. 6) --------------------------------------------------------------


def ga_evolution_figure(best_history: ArrayLike, mean_history: ArrayLike) -> Figure:
    """Best and mean fitness of the population per generation (the paper's Fig. 6).

    Parameters
    ----------
    best_history, mean_history : array_like (G,)
        Best and mean fitness of generations 0 (the initial population) to G - 1.
    """
    best = np.asarray(best_history, dtype=np.float64).reshape(-1)
    mean = np.asarray(mean_history, dtype=np.float64).reshape(-1)
    if best.shape != mean.shape or best.size == 0:
        raise ValueError(f"best_history, mean_history: expected equal non-zero lengths, got "
                         f"{best.size} and {mean.size}")
    gen = np.arange(best.size)
    with _style():
        fig = _figure(7.0, 4.5)
        ax = fig.add_subplot()
        ax.plot(gen, best, color="tab:red", lw=1.8, label="best")
        ax.plot(gen, mean, color="tab:blue", lw=1.2, label="population mean")
        ax.set_xlabel("Generation")
        ax.set_ylabel("Fitness F")
        ax.set_title("GA evolution")
        ax.grid(True, alpha=0.3)
        ax.legend()
    return fig


# --- the report -------------------------------------------------------------------------


def _file_stem(name: str) -> str:
    """A garment name made safe for a file name ("No.3" stays "No.3")."""
    return re.sub(r"[^A-Za-z0-9._-]+", "_", name).strip("._") or "unnamed"


def _cell(value: Any) -> str:
    """A value for a Markdown table cell: mappings as "k v, ...", pipes escaped."""
    if isinstance(value, Mapping):
        text = ", ".join(f"{k} {v}" for k, v in value.items())
    elif isinstance(value, list | tuple):
        text = ", ".join(str(v) for v in value)
    else:
        text = str(value)
    return text.replace("|", "\\|").replace("\n", " ")


def _lookup(summary: Mapping[str, Any], key: str) -> Any:
    """``summary[key]``, else ``summary["settings"][key]``, else None."""
    if key in summary:
        return summary[key]
    settings = summary.get("settings")
    if isinstance(settings, Mapping) and key in settings:
        return settings[key]
    return None


def _settings_section(summary: Mapping[str, Any], records: Mapping[str, NDArray[Any]],
                      total: ErrorTable) -> list[str]:
    wall = _lookup(summary, "wall_seconds")
    rows: list[tuple[str, Any]] = [
        ("commit", _lookup(summary, "commit")),
        ("seed", _lookup(summary, "seed")),
        ("trials", f"{total.trials} ({total.found} found)"),
        ("garments", garment_order(records["garment"])),
        ("conditions", garment_order(records["condition"])
         if "condition" in records else None),
        ("wall time", f"{float(wall):.1f} s" if isinstance(wall, int | float) else wall),
        ("machine", _lookup(summary, "machine")),
        ("versions", _lookup(summary, "versions")),
    ]
    lines = ["## Settings", "", "| Setting | Value |", "|---|---|"]
    lines += [f"| {k} | {_cell(v)} |" for k, v in rows if v is not None]
    lines += ["", "The whole `summary.json`:", "", "```json",
              json.dumps(summary, indent=2, sort_keys=True, default=str, ensure_ascii=False),
              "```", ""]
    return lines


def _table_sections(records: Mapping[str, NDArray[Any]], tables: Mapping[str, ErrorTable],
                    focus: str) -> list[str]:
    lines = [f"## Table 1: garment {focus}, ours beside the paper's", ""]
    if focus in tables:
        lines += [table1_markdown(tables[focus], PAPER_TABLE1)]
        t = tables[focus]
        if t.found is not None and t.found < (t.trials or 0):
            lines += [f"The same over the {t.found} found trials only:", "",
                      table1_markdown(error_table(records, focus, found_only=True),
                                      PAPER_TABLE1)]
    else:
        lines += [f"No trials of garment {focus} in these records; the paper's table:", "",
                  table1_markdown(PAPER_TABLE1, None)]
    lines += ["## Table 1: all garments", "",
              "All trials of all garments pooled (the paper gives no such table; its claim "
              "is that mean ± 3σ stays within 10 mm in x-y and 10 deg in θ).", "",
              table1_markdown(tables["all"], None),
              "## Per garment", "",
              "Errors are estimate minus truth in camera 1's frame, mm and deg; "
              "σ is the sample standard deviation; all trials count, found or not.", "",
              garment_summary_markdown(tables)]
    return lines


def _figure_line(file: str, caption: str) -> list[str]:
    return [f"![{caption}]({file})", "", f"*{caption}*", ""]


def write_report(out_dir: str | os.PathLike[str],
                 records: Mapping[str, NDArray[Any]] | str | os.PathLike[str],
                 summary: Mapping[str, Any], *,
                 fitness_map: tuple[ArrayLike, ArrayLike, ArrayLike, ArrayLike | None]
                 | None = None,
                 ga_history: tuple[ArrayLike, ArrayLike] | None = None,
                 focus_garment: str = "No.3") -> Path:
    """Write ``report.md`` and its figures (PNG) into ``out_dir``.

    Parameters
    ----------
    out_dir : path-like
        Folder of the report (created if missing).
    records : mapping of str to ndarray (N,), or path-like
        The experiment's columns, or the ``records.csv`` to read them from.
    summary : mapping
        The experiment's ``summary.json``; printed as settings (commit, seed, wall time,
        machine, versions, looked up at the top level or under ``"settings"``) and in full.
    fitness_map : tuple (x_mm (nx,), y_mm (ny,), F (ny, nx), true_xy (2,) or None), optional
        Adds ``fitness_map.png`` (the paper's Fig. 11).
    ga_history : tuple (best (G,), mean (G,)), optional
        Adds ``ga_evolution.png`` (the paper's Fig. 6).
    focus_garment : str
        The garment whose Table 1 is set beside the paper's (the paper's No.3).

    Returns
    -------
    Path
        ``out_dir / "report.md"``. Also written: ``hist_all.png`` and ``hist_<garment>.png``
        per garment. Every file is written atomically; the same input gives the same bytes.

    Raises
    ------
    InputError
        No records, a missing column, an unreadable records file, or an ``out_dir`` that
        cannot be created.
    """
    source = "records"
    if isinstance(records, str | os.PathLike):
        source = str(records)
        records = read_records(records)
    if _check_records(records) == 0:
        raise InputError(source, "no records")
    out = Path(out_dir)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError(out, f"cannot create the report folder ({exc.strerror})") from None

    tables = error_tables(records)
    garments = [g for g in tables if g != "all"]
    lines = ["# Photo-model recognition accuracy: experiment report", "",
             "Reproduces the accuracy study of *Accuracy on Photo-Model-Based Clothes "
             "Recognition* (secs. 3-4): Table 1 and Figs. 6, 11-16.", ""]
    lines += _settings_section(summary, records, tables["all"])
    lines += _table_sections(records, tables, focus_garment)
    lines += ["## Figures", ""]

    if fitness_map is not None:
        fx, fy, fF, ftrue = fitness_map
        _save_png(fitness_map_figure(fx, fy, fF, ftrue), out / "fitness_map.png")
        lines += _figure_line("fitness_map.png", "Fitness over the x-y plane around the true "
                              "position, z and orientation at the truth (paper Fig. 11)")
    if focus_garment in garments:
        lines += _figure_line(f"hist_{_file_stem(focus_garment)}.png",
                              f"Error histograms of garment {focus_garment} (paper Figs. 12-13 "
                              "for No.3: x and y; z and θ added)")
    _save_png(error_histograms(records), out / "hist_all.png")
    lines += _figure_line("hist_all.png", "Error histograms of all garments (paper Figs. "
                          "14-16: x, y and θ for No.1-No.12; z added)")
    if ga_history is not None:
        best, mean = ga_history
        _save_png(ga_evolution_figure(best, mean), out / "ga_evolution.png")
        lines += _figure_line("ga_evolution.png", "Best and mean fitness per GA generation "
                              "(paper Fig. 6)")

    others = [g for g in garments if g != focus_garment]
    if others:
        lines += ["### Per-garment histograms", ""]
    for g in garments:
        file = f"hist_{_file_stem(g)}.png"
        _save_png(error_histograms(records, g), out / file)
        if g != focus_garment:
            lines += _figure_line(file, f"Error histograms of garment {g}")

    path = out / "report.md"
    write_atomic(path, ("\n".join(lines).rstrip("\n") + "\n").encode("utf-8"))
    return path
