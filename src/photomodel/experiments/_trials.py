"""One recognition trial of an experiment: a scene, its photo-model, ``locate``, the errors.

A trial is a pure function of the experiment's settings and its id: the scene is the one
``photomodel simulate`` writes for the same seed, condition, garment and index (so a dataset
simulated with that seed holds the very same images), the photo-model is built from the same
model photos, and the search is seeded from the trial id. So the records do not depend on which
process, machine or executor ran a trial, or in which order (only ``seconds`` does).
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path
from typing import Any

import numpy as np

from photomodel.camera import StereoRig, load_camera, load_distance_mm, load_stereo
from photomodel.geometry import in_plane_angle_rad
from photomodel.image import read_color_image
from photomodel.locate import LocateResult, Locator, Method, PaperMethod
from photomodel.model import DEFAULT_STATION_DISTANCE_MM, PhotoModel, build_photo_model
from photomodel.search import GAConfig

__all__ = [
    "ExperimentConfig",
    "Trial",
    "limit_threads",
    "plan_trials",
    "run_trial",
    "trial_inputs",
    "trial_locator",
    "trial_record",
]


@dataclass(frozen=True)
class ExperimentConfig:
    """Settings of an experiment (fixed for a run; stored in its summary).

    Parameters
    ----------
    garments : tuple of str
        Catalogue garments (simulated) or model names (dataset).
    conditions : tuple of str
        Simulated conditions (:data:`photomodel.sim.CONDITIONS`, ``+``-joined).
    trials : int
        Trials per garment and condition (the paper: 1000).
    seed : int
        Seed of the scenes (as ``photomodel simulate --seed``) and of the searches.
    fitness : str
        Fitness preset for ``locate``.
    optimizer : str
        ``"ga"`` or ``"full"``.
    refine : bool
        Local refinement after the global search.
    paper : bool
        The paper's method as read here (paper fitness, plain binary GA, no refinement);
        overrides ``fitness`` and ``refine``.
    max_generations : int, optional
        Cap on the GA's generations per run (default: the GA's own); for quick runs.
    dataset : str, optional
        A dataset directory (layout in docs/contracts.md) to evaluate instead of simulating:
        every scene of its ``truth.json`` with a model is a trial (``garments``/``conditions``/
        ``trials`` then filter nothing).
    """

    garments: tuple[str, ...] = ()
    conditions: tuple[str, ...] = ("paper",)
    trials: int = 1000
    seed: int = 0
    fitness: str = "soft"
    optimizer: str = "ga"
    refine: bool = True
    paper: bool = False
    max_generations: int | None = None
    dataset: str | None = None

    def __post_init__(self) -> None:
        if self.trials < 0:
            raise ValueError(f"trials: expected a count >= 0, got {self.trials}")
        if not 0 <= self.seed <= 2**32 - 1:
            raise ValueError(f"seed: expected an integer from 0 to {2**32 - 1}, got {self.seed}")
        if self.max_generations is not None and self.max_generations < 1:
            raise ValueError(f"max_generations: expected a count >= 1, got "
                             f"{self.max_generations}")

    def to_json_dict(self) -> dict[str, Any]:
        return {k: (list(v) if isinstance(v, tuple) else v) for k, v in self.__dict__.items()}


@dataclass(frozen=True, order=True)
class Trial:
    """One recognition: scene ``index`` of ``garment`` under ``condition``."""

    trial_id: str
    garment: str = field(compare=False)
    condition: str = field(compare=False)
    index: int = field(compare=False)


def plan_trials(config: ExperimentConfig) -> list[Trial]:
    """Every trial of the experiment, in a fixed order.

    Simulated: ``trials`` per garment and condition, ids ``<condition>_<garment>_<index:04d>``.
    Dataset: every scene of ``truth.json`` whose ``model`` is not null, ids = scene ids.
    """
    if config.dataset is not None:
        truth = _truth(config.dataset)
        return [Trial(sid, facts["model"], str(facts.get("condition", "")), _index(sid, k))
                for k, (sid, facts) in enumerate(truth.items()) if facts.get("model")]
    return [Trial(f"{cond}_{g}_{k:04d}", g, cond, k)
            for cond in config.conditions for g in config.garments for k in range(config.trials)]


def _index(scene_id: str, position: int) -> int:
    """The index a scene id ends with (``paper_No.3_0007`` -> 7), else its position."""
    tail = scene_id.rsplit("_", 1)[-1]
    return int(tail) if tail.isdigit() else position


@lru_cache(maxsize=4)
def _truth(dataset: str) -> dict[str, Any]:
    from photomodel.errors import InputError

    path = Path(dataset) / "truth.json"
    try:
        return json.loads(path.read_text())
    except FileNotFoundError:
        raise InputError(path, "not found (is this a dataset directory?)") from None
    except (OSError, ValueError) as exc:
        raise InputError(path, f"cannot read: {exc}") from None


@lru_cache(maxsize=64)
def _model(config: ExperimentConfig, garment: str) -> PhotoModel:
    """The garment's photo-model, built from its model photos (simulated or the dataset's);
    kept for 64 (config, garment) pairs (the locate benchmark's three lenses give 36)."""
    if config.dataset is None:
        from photomodel.sim import station_model

        return station_model(garment, config.seed)
    root = Path(config.dataset)
    camera = load_camera(root / "model_camera.yaml")
    distance = load_distance_mm(root / "model_camera.yaml") or DEFAULT_STATION_DISTANCE_MM
    photo = read_color_image(root / "models" / garment / "photo.bmp")
    background = read_color_image(root / "models" / garment / "background.bmp")
    return build_photo_model(photo, background, camera, distance, name=garment).model


@lru_cache(maxsize=4)
def _rig(config: ExperimentConfig) -> StereoRig:
    if config.dataset is not None:
        return load_stereo(Path(config.dataset) / "stereo.yaml")
    from photomodel.sim import hand_stereo_rig, parse_conditions

    lenses = {parse_conditions(c).lens for c in config.conditions}
    if len(lenses) != 1:
        raise ValueError("conditions ask for different lenses; run them as separate experiments")
    return hand_stereo_rig(lens=lenses.pop())


def trial_inputs(config: ExperimentConfig, trial: Trial) -> tuple[
        PhotoModel, StereoRig, np.ndarray, np.ndarray, np.ndarray, float]:
    """(model, rig, right, left, T_cam1_model true (4, 4), visible fraction) of a trial."""
    model, rig = _model(config, trial.garment), _rig(config)
    if config.dataset is not None:
        scene = Path(config.dataset) / "scenes" / trial.trial_id
        facts = _truth(config.dataset)[trial.trial_id]
        right = read_color_image(scene / "right.png")
        left = read_color_image(scene / "left.png")
        visible = facts.get("visible_fraction") or [1.0]
        return model, rig, right, left, np.asarray(facts["T_cam1_model"], float), visible[0]
    from photomodel.sim import catalogue_garment, parse_conditions, scene_rng, simulate_scene

    shot = simulate_scene(catalogue_garment(trial.garment), rig,
                          parse_conditions(trial.condition),
                          scene_rng(config.seed, trial.condition, trial.garment, trial.index))
    assert shot.T_cam1_model is not None
    return (model, rig, shot.right_bgr, shot.left_bgr, shot.T_cam1_model,
            shot.info["visible_fraction"][0])


def _wrap_deg(angle: float) -> float:
    return float(-((-angle + 180.0) % 360.0 - 180.0))


def run_trial(config: ExperimentConfig, trial: Trial) -> dict[str, Any]:
    """Run one trial; returns its record (the columns of ``records.csv``)."""
    model, rig, right, left, T_true, visible = trial_inputs(config, trial)
    result = _locate(config, trial, model, rig, right, left)
    return trial_record(trial, result, T_true, visible)


def _locate(config: ExperimentConfig, trial: Trial, model: PhotoModel, rig: StereoRig,
            right: np.ndarray, left: np.ndarray) -> LocateResult:
    from photomodel.sim import scene_rng

    rng = scene_rng(config.seed, "search", trial.trial_id)
    locator = trial_locator(config, trial.garment)
    if locator.model is not model:   # not the experiment's own model
        locator = Locator(model, rig, method=_method(config))
    return locator(right, left, rng=rng)


def _method(config: ExperimentConfig) -> Method:
    """The experiment's way of locating: the default method, or a :class:`PaperMethod`."""
    if config.fitness == "soft" and not config.paper:
        return "default"
    cap = {} if config.max_generations is None else {"max_generations": config.max_generations}
    ga = GAConfig.paper(**cap) if config.paper else GAConfig(**cap)  # type: ignore[arg-type]
    return PaperMethod(fitness="paper" if config.paper else config.fitness,
                       optimizer=config.optimizer,  # type: ignore[arg-type]
                       refine=config.refine and not config.paper, ga=ga)


@lru_cache(maxsize=64)
def trial_locator(config: ExperimentConfig, garment: str) -> Locator:
    """A :class:`~photomodel.Locator` of the garment's model (:func:`trial_inputs`'s) with
    the experiment's rig and method, kept for its next trials."""
    return Locator(_model(config, garment), _rig(config), method=_method(config))


def trial_record(trial: Trial, result: LocateResult, T_true: np.ndarray,
                 visible: float) -> dict[str, Any]:
    """The record of a finished trial: pose, truth, errors, search figures."""
    T_est = result.T_cam1_model
    th_true = float(np.degrees(in_plane_angle_rad(T_true[:3, :3])))
    th_est = float(np.degrees(in_plane_angle_rad(T_est[:3, :3])))
    err = T_est[:3, 3] - T_true[:3, 3]
    cos_tilt = float(np.clip(T_est[:3, 2] @ T_true[:3, 2], -1.0, 1.0))
    return {
        "trial_id": trial.trial_id, "garment": trial.garment, "condition": trial.condition,
        "index": trial.index, "found": int(result.found), "score": result.score,
        "fitness": result.fitness, "evaluations": result.search.evaluations,
        "generations": result.search.iterations, "seconds": result.seconds,
        "true_x_mm": T_true[0, 3], "true_y_mm": T_true[1, 3], "true_z_mm": T_true[2, 3],
        "true_theta_deg": th_true,
        "est_x_mm": T_est[0, 3], "est_y_mm": T_est[1, 3], "est_z_mm": T_est[2, 3],
        "est_theta_deg": th_est,
        "err_x_mm": err[0], "err_y_mm": err[1], "err_z_mm": err[2],
        "err_theta_deg": _wrap_deg(th_est - th_true), "err_xy_mm": float(np.hypot(*err[:2])),
        "err_tilt_deg": float(np.degrees(np.arccos(cos_tilt))),
        "visible_fraction": float(visible), "stop_reason": result.search.stop_reason,
    }


def limit_threads() -> None:
    """Worker initialiser: one numba thread per process (processes give the parallelism)."""
    import sys

    if "numba" not in sys.modules:  # once numba's threads run, the variable must not change
        os.environ.setdefault("NUMBA_NUM_THREADS", "1")
    import numba

    numba.set_num_threads(1)
