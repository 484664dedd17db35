"""The simulated cell end to end: model station, hand cameras on the PA10, locate, plan, check.

Set-up (frames as docs/contracts.md; lengths in mm):

- The arm's base stands on the floor of the cell; the work table's top (``table``) lies at
  :attr:`CellLayout.table_centre_mm`, the box at :attr:`CellLayout.box_centre_mm`.
- The simulator's fixed geometry (:mod:`photomodel.sim`): the hand rig
  (:func:`~photomodel.sim.hand_stereo_rig`) on the hand by its true mount
  :func:`~photomodel.sim.default_hand_eye` (the middle of its baseline 110 mm off the flange
  axis along the hand's -y and 40 mm along its z); the photographing configuration ``q_photo``
  (:func:`~photomodel.sim.photo_configuration`) puts the rig's bisector perpendicular to the
  table, 685 mm above its centre, so the cameras see the table as
  :func:`~photomodel.sim.hand_table_pose` renders it.
- A hand-eye calibration is simulated first (:func:`simulated_hand_eye`): 12 hand poses around
  ``q_photo``, a fixed target observed with noise, ``cv2.calibrateHandEye``; the cycles plan
  with that estimate, the renderer uses the true mount.

One cycle: the order's garment is photographed at the model station and its photo-model built;
the arm at ``q_photo`` photographs the table with the garment among other objects (the
simulator's scene, with the truth ``T_cam1_model``); ``locate`` finds it; the plan is made from
``T_base_model = T_base_hand(q_photo) @ T_hand_cam1 @ T_cam1_model``; the grasp point is
compared with the true garment centroid ``T_base_hand(q_photo) @ X_true @ T_cam1_model_true``
applied to the model-frame grasp point.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from functools import lru_cache
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray
from scipy.spatial.transform import Rotation

from photomodel.camera import StereoRig
from photomodel.geometry import in_plane_angle_rad, invert_transform, make_transform
from photomodel.model import PhotoModel

if TYPE_CHECKING:
    from photomodel.locate import Locator, Method
from photomodel.robot import (
    ArmModel,
    CellLayout,
    PickPlan,
    PickSettings,
    UnreachableError,
    calibrate_hand_eye,
    forward_kinematics,
    grasp_pose,
    hand_eye_error,
    inverse_kinematics,
    load_arm,
    plan_pick,
)

__all__ = [
    "CellConfig",
    "CellReport",
    "CellSetup",
    "CycleOutcome",
    "make_cell",
    "run_cell",
    "run_cycle",
    "simulated_hand_eye",
]


def simulated_hand_eye(arm: ArmModel, q_photo: NDArray[np.float64],
                       T_hand_cam1: NDArray[np.float64], rng: np.random.Generator,
                       n_pairs: int = 12, noise_mm: float = 0.3,
                       noise_deg: float = 0.05) -> tuple[NDArray[np.float64], dict[str, Any]]:
    """A hand-eye calibration as a cell would run it, on simulated observations.

    The target lies on the table below the photographing pose; the hand visits ``n_pairs``
    poses (rotations up to 20 deg about random axes, shifts up to 60 mm) reached by IK; each
    target pose seen by camera 1 gets Gaussian noise (``noise_mm`` per axis, ``noise_deg``
    about a random axis).

    Returns
    -------
    T_hand_cam1_est : ndarray (4, 4)
    info : dict
        Method, pairs, residuals and the estimate's error against the true mount.
    """
    T_photo = forward_kinematics(arm, q_photo)
    T_base_target = T_photo @ T_hand_cam1 @ make_transform(np.eye(3), [0.0, 0.0, 650.0])
    hands, targets = [], []
    while len(hands) < n_pairs:
        dR = Rotation.from_rotvec(_random_rotvec(rng, np.radians(20.0)))
        T_want = T_photo @ make_transform(dR.as_matrix(), rng.uniform(-60.0, 60.0, 3))
        result = inverse_kinematics(arm, T_want, q_photo, rng=rng)
        if not result.success:
            continue
        T_hand = forward_kinematics(arm, result.q)
        T_obs = invert_transform(T_hand @ T_hand_cam1) @ T_base_target
        noise = make_transform(Rotation.from_rotvec(_random_rotvec(rng, np.radians(noise_deg)))
                               .as_matrix(), rng.normal(0.0, noise_mm, 3))
        hands.append(T_hand)
        targets.append(T_obs @ noise)
    result_he = calibrate_hand_eye(np.stack(hands), np.stack(targets))
    err_mm, err_deg = hand_eye_error(result_he.T_hand_cam1, T_hand_cam1)
    info = {"method": result_he.method, "backend": result_he.backend, "pairs": n_pairs,
            "noise_mm": noise_mm, "noise_deg": noise_deg, "residual_mm": result_he.residual_mm,
            "residual_deg": result_he.residual_deg, "error_mm": err_mm, "error_deg": err_deg}
    return result_he.T_hand_cam1, info


def _random_rotvec(rng: np.random.Generator, max_angle_rad: float) -> NDArray[np.float64]:
    """A rotation vector (3,) about a uniform random axis, angle uniform in [0, max]."""
    axis = rng.normal(size=3)
    return axis / np.linalg.norm(axis) * rng.uniform(0.0, max_angle_rad)


@dataclass(frozen=True)
class CellConfig:
    """Settings of a simulated cell run.

    Parameters
    ----------
    orders : int
        Cycles (one garment each).
    garments : tuple of str
        Catalogue garments, used in turn (default: all 12).
    condition : str
        Simulated conditions of the table shots (``+``-joined names); the default puts two
        other garments and two objects beside the target.
    seed : int
    tolerance_mm : float
        A cycle succeeds when the planned grasp point lies within this distance of the true
        one (3-D, base frame).
    link_set : str, optional
        PA10 link lengths (default: the data file's).
    hand_eye : {"calibrated", "true"}
        Plan with a simulated calibration (default) or with the true mount.
    method : {"default", "paper"}
        ``locate``'s method.
    """

    orders: int = 10
    garments: tuple[str, ...] = tuple(f"No.{k}" for k in range(1, 13))
    condition: str = "distractors"
    seed: int = 0
    tolerance_mm: float = 10.0
    link_set: str | None = None
    hand_eye: str = "calibrated"
    method: str = "default"
    layout: CellLayout = field(default_factory=CellLayout)
    pick: PickSettings = field(default_factory=PickSettings)

    def __post_init__(self) -> None:
        if self.orders < 1:
            raise ValueError(f"orders: expected a positive count, got {self.orders}")
        if not self.garments:
            raise ValueError("garments: expected at least one garment")
        if self.hand_eye not in ("calibrated", "true"):
            raise ValueError(f"hand_eye: expected 'calibrated' or 'true', got {self.hand_eye!r}")
        if self.tolerance_mm <= 0:
            raise ValueError("tolerance_mm: expected a positive distance")

    def to_json_dict(self) -> dict[str, Any]:
        d = {k: v for k, v in self.__dict__.items() if k not in ("layout", "pick")}
        d["garments"] = list(self.garments)
        d["layout"] = asdict(self.layout)
        d["pick"] = {k: v for k, v in asdict(self.pick).items() if k != "ik"}
        return d


@dataclass(frozen=True)
class CellSetup:
    """The simulated cell's fixed parts (see the module docstring)."""

    arm: ArmModel
    rig: StereoRig
    layout: CellLayout
    T_hand_cam1_true: NDArray[np.float64]
    T_hand_cam1: NDArray[np.float64]
    q_photo: NDArray[np.float64]
    hand_eye_info: dict[str, Any]
    locators: dict[tuple[str, int, str], Locator] = field(default_factory=dict, repr=False,
                                                          compare=False)

    def locator(self, garment: str, seed: int, method: Method) -> Locator:
        """The cell's :class:`~photomodel.Locator` of a garment's station model, made once
        and kept for its next cycles."""
        from photomodel.locate import Locator

        key = (garment, seed, repr(method))
        if key not in self.locators:
            self.locators[key] = Locator(_photo_model(garment, seed), self.rig, method=method)
        return self.locators[key]


def make_cell(config: CellConfig) -> CellSetup:
    """Arm, rig, mount, photographing pose and (simulated) hand-eye calibration."""
    from photomodel.sim import (
        default_hand_eye,
        hand_stereo_rig,
        parse_conditions,
        photo_configuration,
        scene_rng,
    )

    arm = load_arm("pa10-7c", config.link_set)
    rig = hand_stereo_rig(lens=parse_conditions(config.condition).lens)
    X_true = default_hand_eye(rig)
    q_photo = photo_configuration(arm, config.layout, rig, X_true)
    if config.hand_eye == "true":
        return CellSetup(arm, rig, config.layout, X_true, X_true, q_photo, {"method": "true"})
    X_est, info = simulated_hand_eye(arm, q_photo, X_true, scene_rng(config.seed, "hand-eye"))
    return CellSetup(arm, rig, config.layout, X_true, X_est, q_photo, info)


@lru_cache(maxsize=16)
def _photo_model(garment: str, seed: int) -> PhotoModel:
    from photomodel.sim import station_model

    return station_model(garment, seed)



@dataclass(frozen=True)
class CycleOutcome:
    """One cycle's record (JSON-ready) and, when planned, its plan."""

    record: dict[str, Any]
    plan: PickPlan | None
    model: PhotoModel
    T_base_model_true: NDArray[np.float64]


def run_cycle(config: CellConfig, setup: CellSetup, index: int) -> CycleOutcome:
    """Run order ``index`` (module docstring); never raises for an unreachable plan."""
    from photomodel.sim import catalogue_garment, parse_conditions, scene_rng, simulate_scene

    garment = config.garments[index % len(config.garments)]
    t0 = time.perf_counter()
    model = _photo_model(garment, config.seed)
    shot = simulate_scene(catalogue_garment(garment), setup.rig,
                          parse_conditions(config.condition),
                          scene_rng(config.seed, "cell", garment, index))
    assert shot.T_cam1_model is not None
    locator = setup.locator(garment, config.seed, config.method)  # type: ignore[arg-type]
    result = locator(shot.right_bgr, shot.left_bgr,
                     rng=scene_rng(config.seed, "cell-search", garment, index))
    T_base_hand = forward_kinematics(setup.arm, setup.q_photo)
    T_true = T_base_hand @ setup.T_hand_cam1_true @ shot.T_cam1_model
    T_est = T_base_hand @ setup.T_hand_cam1 @ result.T_cam1_model
    grasp_true = grasp_pose(T_true, config.pick.grasp_point_mm)[:3, 3]
    record: dict[str, Any] = {
        "order": index, "garment": garment, "found": bool(result.found),
        "score": float(result.score), "locate_seconds": float(result.seconds),
        "true_grasp_mm": grasp_true.tolist(),
        "true_theta_deg": float(np.degrees(in_plane_angle_rad(shot.T_cam1_model[:3, :3]))),
        "est_theta_deg": float(np.degrees(in_plane_angle_rad(result.T_cam1_model[:3, :3]))),
    }
    plan = None
    grasp_est = grasp_pose(T_est, config.pick.grasp_point_mm)[:3, 3]
    if not result.found:
        record.update(planned=False, reachable=None, within_limits=None,
                      reason=f"not found (score {result.score:.2f})")
    else:
        try:
            plan = plan_pick(setup.arm, setup.q_photo, T_est, setup.layout, config.pick,
                             rng=scene_rng(config.seed, "cell-ik", index))
        except UnreachableError as exc:
            record.update(planned=True, reachable=False, within_limits=False, reason=str(exc))
        else:
            record.update(planned=True, reachable=True, within_limits=plan.within_limits,
                          gripper_yaw_deg=plan.gripper_yaw_deg,
                          grasp_joints_deg=np.degrees(plan.waypoint("grasp").q).tolist())
            grasp_est = plan.grasp_point_mm
    err = grasp_est - grasp_true
    record.update(
        est_grasp_mm=np.asarray(grasp_est).tolist(), grasp_error_mm=err.tolist(),
        grasp_error_norm_mm=float(np.linalg.norm(err)),
        grasp_error_xy_mm=float(np.hypot(err[0], err[1])),
        within_tolerance=bool(np.linalg.norm(err) <= config.tolerance_mm),
        cycle_seconds=time.perf_counter() - t0,
    )
    return CycleOutcome(record, plan, model, T_true)


def _stats(values: list[float]) -> dict[str, float | None]:
    if not values:
        return {"mean": None, "sd": None, "median": None, "p95": None, "max": None}
    a = np.asarray(values, dtype=np.float64)
    return {"mean": float(a.mean()), "sd": float(a.std(ddof=1)) if a.size > 1 else 0.0,
            "median": float(np.median(a)), "p95": float(np.percentile(a, 95)),
            "max": float(a.max())}


@dataclass(frozen=True)
class CellReport:
    """Cycles and their summary (JSON-ready), the set-up, and the first cycle with a plan."""

    cycles: list[dict[str, Any]]
    summary: dict[str, Any]
    setup: CellSetup
    first_plan: CycleOutcome | None = None

    def to_json_dict(self) -> dict[str, Any]:
        return {"summary": self.summary, "cycles": self.cycles}


def summarise(config: CellConfig, setup: CellSetup,
              cycles: list[dict[str, Any]], seconds: float) -> dict[str, Any]:
    """Grasp-point error statistics, reachable share and success share of finished cycles.

    ``found``: cycles where ``locate`` found the garment (only those are planned);
    ``reachable_share``: plans reachable within the joint limits among them;
    ``success_share``: cycles with a reachable plan whose grasp point lies within the tolerance
    of the truth. Error statistics over all cycles (the located pose even when not found), over
    the found ones, and over the successful ones.
    """
    n = len(cycles)
    planned = [c for c in cycles if c["planned"]]
    good_plans = [c for c in planned if c["reachable"] and c["within_limits"]]
    ok = [c for c in good_plans if c["within_tolerance"]]
    return {
        "orders": n,
        "found": len(planned),
        "found_share": len(planned) / max(n, 1),
        "plans_reachable_within_limits": len(good_plans),
        "reachable_share": len(good_plans) / max(len(planned), 1),
        "picked_within_tolerance": len(ok),
        "success_share": len(ok) / max(n, 1),
        "tolerance_mm": config.tolerance_mm,
        "grasp_error_mm_all": _stats([c["grasp_error_norm_mm"] for c in cycles]),
        "grasp_error_mm_found": _stats([c["grasp_error_norm_mm"] for c in planned]),
        "grasp_error_xy_mm_found": _stats([c["grasp_error_xy_mm"] for c in planned]),
        "grasp_error_mm_within_tolerance": _stats([c["grasp_error_norm_mm"] for c in ok]),
        "hand_eye": setup.hand_eye_info,
        "q_photo_deg": np.degrees(setup.q_photo).tolist(),
        "arm": setup.arm.to_json_dict(),
        "seconds": seconds,
        "config": config.to_json_dict(),
    }


def run_cell(config: CellConfig,
             progress: Callable[[int, int, str], None] | None = None) -> CellReport:
    """Run ``config.orders`` cycles; ``progress(done, total, what)`` after each one."""
    t0 = time.perf_counter()
    setup = make_cell(config)
    cycles: list[dict[str, Any]] = []
    first: CycleOutcome | None = None
    for k in range(config.orders):
        outcome = run_cycle(config, setup, k)
        if first is None and outcome.plan is not None:
            first = outcome
        cycles.append(outcome.record)
        if progress is not None:
            r = outcome.record
            progress(k + 1, config.orders, f"{r['garment']}: {r['grasp_error_norm_mm']:.1f} mm")
    return CellReport(cycles, summarise(config, setup, cycles, time.perf_counter() - t0), setup,
                      first)
