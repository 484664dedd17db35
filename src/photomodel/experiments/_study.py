"""The report of a run directory: statistics of its records, plus the two figures that need a
scene (the fitness map around the true pose, Fig. 11, and the GA's evolution, Fig. 6), which
come from re-running the focus garment's first trial (trials are deterministic)."""

from __future__ import annotations

import json
import os
from collections.abc import Callable
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from photomodel.camera import StereoRig
from photomodel.errors import InputError
from photomodel.experiments._records import read_records
from photomodel.experiments._trials import ExperimentConfig, _locate, plan_trials, trial_inputs
from photomodel.locate import LocateResult
from photomodel.model import PhotoModel

__all__ = ["write_experiment_report"]


def _config(out: Path) -> ExperimentConfig:
    path = out / "config.json"
    try:
        data = json.loads(path.read_text())
    except FileNotFoundError:
        raise InputError(path, "not found (is this an experiment directory?)") from None
    except (OSError, ValueError) as exc:
        raise InputError(path, f"cannot read: {exc}") from None
    for key in ("garments", "conditions"):
        data[key] = tuple(data.get(key) or ())
    return ExperimentConfig(**data)


def write_experiment_report(out: str | os.PathLike[str], focus: str = "No.3",
                            half_range_mm: float = 60.0, step_mm: float = 2.0) -> Path:
    """Write ``report.md`` and its figures into the run directory ``out``; returns its path.

    Parameters
    ----------
    out : path
        A run directory of :func:`run_experiment`.
    focus : str
        Garment of the detailed Table 1, histograms and figures (the paper's No.3); the first
        garment of the records when it has none.
    half_range_mm, step_mm : float
        Extent and pitch of the fitness map around the true position, mm.
    """
    from photomodel.experiments._report import fitness_map, write_report

    out = Path(out)
    config = _config(out)
    records = read_records(out / "records.csv")
    summary_path = out / "summary.json"
    summary = json.loads(summary_path.read_text()) if summary_path.exists() else {}
    garments = [str(g) for g in dict.fromkeys(records["garment"].tolist())]
    if not garments:
        raise InputError(out / "records.csv", "no records")
    focus = focus if focus in garments else garments[0]
    trial = next(t for t in plan_trials(config) if t.garment == focus)
    model, rig, right, left, T_true, _ = trial_inputs(config, trial)
    result = _locate(config, trial, model, rig, right, left)
    fit = _map_fitness(config, model, rig, right, left, result)
    x_mm, y_mm, F = fitness_map(fit, T_true, half_range_mm=half_range_mm, step_mm=step_mm)
    return write_report(out, records, summary, focus_garment=focus,
                        fitness_map=(x_mm, y_mm, F, (float(T_true[0, 3]), float(T_true[1, 3]))),
                        ga_history=(np.asarray(result.search.best_history),
                                    np.asarray(result.search.mean_history)))


def _map_fitness(config: ExperimentConfig, model: PhotoModel, rig: StereoRig,
                 right: NDArray[np.uint8], left: NDArray[np.uint8],
                 result: LocateResult) -> Callable[[NDArray[np.float64]], NDArray[np.float64]]:
    """The fitness the run's method ends on, for the map around the true pose: the ``soft``
    fitness on level 0 with the camera blur the search estimated, else the named preset."""
    from photomodel.fitness import SoftFitness, StereoFeatures, make_fitness

    if config.paper or config.fitness != "soft":
        return make_fitness("paper" if config.paper else config.fitness, model, rig, right, left)
    # A soft run's search is the pyramid, which always estimates the camera blur.
    assert result.optics_blur_mm is not None
    return SoftFitness(model, StereoFeatures(rig, right, left), 0,
                       optics_blur_mm=result.optics_blur_mm)
