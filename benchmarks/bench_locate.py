"""Benchmark: ``locate`` (the paper's method and the default) against a SIFT feature-matching peer.

Every method runs on the very same seeded stereo scenes, those of the accuracy study
(:func:`photomodel.experiments.trial_inputs`: trial ids ``<condition>_<garment>_<index:04d>``,
the scenes ``photomodel simulate --seed`` writes, the photo-models built from the same model
photos). Per trial and method: the pose errors of :func:`photomodel.experiments.trial_record`
(x, y, z in camera 1's frame, in-plane angle theta), the 3-D position error, the full 3-D
rotation error (angle of ``R_est^T R_true``) and the time.

Methods
-------
``default``  ``photomodel.locate.locate(model, rig, right, left, rng=...)``
``paper``    the same with ``**photomodel.locate.PAPER_METHOD`` (slow: ``--paper-trials``)
``peer``     :func:`peer_sift.sift_locate` (SIFT, ratio test, PnP-RANSAC, joint stereo
             refinement); always run. Its model features are computed once per model and
             cached, outside the timed part; its time per stereo pair includes SIFT on both
             scene images.
The search seed of a trial is ``photomodel.sim.scene_rng(seed, "search", trial_id)``.

Success: the method reports the garment found (``LocateResult.found``; the peer's ``ok``) AND
the 3-D position error is below 10 mm AND the 3-D rotation error below 5 deg.

Timing
------
``seconds_pool``: every trial, in a pool of ``--workers`` processes with numba and OpenCV held
to one thread each (so workers do not compete). ``seconds_2threads``: a separate pass in the
main process after the pool has finished, numba and OpenCV at their default threads (2 on the
reference machine), on the first ``--timing-trials`` trial(s) of every garment in every
condition, for ``--timing-methods``; the time ratios peer / default come from this pass. Each
process warms numba's JIT up (one ``locate`` of each method) before timing. Before the timing
pass, and in each pool worker before its first trial, every model meets its rig once (one
``locate`` per garment and lens; in the timing pass timed apart as
``default_model_preparation``: the first stereo pair prepares the model,
:func:`photomodel.locate.prepare_model`, whose samples and scan kernels later pairs reuse), as
the peer's model features are computed once and not timed.

Output: ``--out`` (JSON: meta, settings, per condition and method statistics, ratios, overall,
targets) and ``locate_trials.csv`` beside it (one row per trial, method and pass, so every
table can be recomputed). Seeded and deterministic apart from the times.

Run (full, long): ``.venv/bin/python benchmarks/bench_locate.py``
Smoke: ``.venv/bin/python benchmarks/bench_locate.py --trials 1 --paper-trials 0
--conditions paper,dim --garments No.1,No.10 --out build/bench-smoke/locate.json``
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import sys
import time
from collections import defaultdict
from collections.abc import Iterable, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from multiprocessing import get_context
from pathlib import Path
from typing import Any

import numpy as np
from _meta import metadata
from peer_sift import ModelFeatures, model_features, sift_locate

from photomodel.experiments import (
    ExperimentConfig,
    Trial,
    trial_inputs,
    trial_locator,
    trial_record,
)
from photomodel.geometry import in_plane_angle_rad
from photomodel.locate import PAPER_METHOD, LocateResult, PaperMethod, locate
from photomodel.model import PhotoModel
from photomodel.sim import garment_names, parse_conditions, scene_rng

DEFAULT_CONDITIONS = (
    "paper", "dim", "bright", "warm-light", "cool-light", "noise", "blur", "vignetting", "wood",
    "conveyor", "green", "tilt", "wrinkles", "distractors", "gripper", "overlap",
    "no-distortion", "wide-lens")
METHODS = ("paper", "default", "peer")
SUCCESS_POSITION_MM = 10.0
SUCCESS_ROTATION_DEG = 5.0
TARGETS = {
    "success_rate_min": 0.99,
    "per_garment_std_max": {"x_mm": 0.25, "y_mm": 0.25, "z_mm": 0.5, "theta_deg": 0.05},
    "abs_mean_max_mm": 1.0,
    "median_seconds_max": 0.040,
    "peer_over_default_time_min": 3.0,
}
AXES = {"x_mm": "err_x_mm", "y_mm": "err_y_mm", "z_mm": "err_z_mm", "theta_deg": "err_theta_deg"}
EXTRA_COLUMNS = ("method", "pass", "err_pos_mm", "err_rot_deg", "success", "inliers", "reason")


# ----------------------------------------------------------------------------- trials

def _configs(garments: Sequence[str], conditions: Sequence[str], trials: int,
             seed: int) -> dict[str, ExperimentConfig]:
    """One experiment config per condition; conditions sharing a lens share a config (and so
    the cached model and rig)."""
    by_lens: dict[str, list[str]] = defaultdict(list)
    for cond in conditions:
        by_lens[parse_conditions(cond).lens].append(cond)
    out = {}
    for conds in by_lens.values():
        config = ExperimentConfig(garments=tuple(garments), conditions=tuple(conds),
                                  trials=trials, seed=seed)
        out.update({c: config for c in conds})
    return out


def _rotation_error_deg(R_est: np.ndarray, R_true: np.ndarray) -> float:
    """Angle of ``R_est^T R_true``, degrees."""
    c = (np.trace(R_est.T @ R_true) - 1.0) / 2.0
    return float(np.degrees(np.arccos(np.clip(c, -1.0, 1.0))))


def _wrap_deg(angle: float) -> float:
    return float(-((-angle + 180.0) % 360.0 - 180.0))


def _peer_record(trial: Trial, T_est: np.ndarray | None, found: bool, seconds: float,
                 T_true: np.ndarray, visible: float, reason: str) -> dict[str, Any]:
    """The columns of :func:`trial_record` for the peer, errors computed the same way."""
    nan = float("nan")
    th_true = float(np.degrees(in_plane_angle_rad(T_true[:3, :3])))
    rec: dict[str, Any] = {
        "trial_id": trial.trial_id, "garment": trial.garment, "condition": trial.condition,
        "index": trial.index, "found": int(found), "score": nan, "fitness": nan,
        "evaluations": 0, "generations": 0, "seconds": seconds,
        "true_x_mm": T_true[0, 3], "true_y_mm": T_true[1, 3], "true_z_mm": T_true[2, 3],
        "true_theta_deg": th_true, "visible_fraction": float(visible), "stop_reason": reason}
    if T_est is None:
        rec.update({k: nan for k in ("est_x_mm", "est_y_mm", "est_z_mm", "est_theta_deg",
                                     "err_x_mm", "err_y_mm", "err_z_mm", "err_theta_deg",
                                     "err_xy_mm", "err_tilt_deg")})
        return rec
    th_est = float(np.degrees(in_plane_angle_rad(T_est[:3, :3])))
    err = T_est[:3, 3] - T_true[:3, 3]
    cos_tilt = float(np.clip(T_est[:3, 2] @ T_true[:3, 2], -1.0, 1.0))
    rec.update({
        "est_x_mm": T_est[0, 3], "est_y_mm": T_est[1, 3], "est_z_mm": T_est[2, 3],
        "est_theta_deg": th_est, "err_x_mm": err[0], "err_y_mm": err[1], "err_z_mm": err[2],
        "err_theta_deg": _wrap_deg(th_est - th_true), "err_xy_mm": float(np.hypot(*err[:2])),
        "err_tilt_deg": float(np.degrees(np.arccos(cos_tilt)))})
    return rec


def _finish(rec: dict[str, Any], method: str, pass_name: str, T_est: np.ndarray | None,
            T_true: np.ndarray, inliers: float, reason: str) -> dict[str, Any]:
    if T_est is None:
        pos, rot = float("nan"), float("nan")
    else:
        pos = float(np.linalg.norm(T_est[:3, 3] - T_true[:3, 3]))
        rot = _rotation_error_deg(T_est[:3, :3], T_true[:3, :3])
    success = bool(rec["found"]) and pos < SUCCESS_POSITION_MM and rot < SUCCESS_ROTATION_DEG
    rec.update({"method": method, "pass": pass_name, "err_pos_mm": pos, "err_rot_deg": rot,
                "success": int(success), "inliers": inliers, "reason": reason})
    return rec


_FEATURES: dict[tuple[int, str], ModelFeatures] = {}


def _features(model: PhotoModel, seed: int, garment: str) -> ModelFeatures:
    """The peer's model features, computed once per model (per process)."""
    key = (seed, garment)
    if key not in _FEATURES:
        _FEATURES[key] = model_features(model)
    return _FEATURES[key]


def _run_methods(config: ExperimentConfig, trial: Trial, methods: Sequence[str],
                 pass_name: str) -> list[dict[str, Any]]:
    """Every method in ``methods`` on one trial's scene; one row each."""
    model, rig, right, left, T_true, visible = trial_inputs(config, trial)
    rows = []
    for method in methods:
        if method == "peer":
            feats = _features(model, config.seed, trial.garment)
            res = sift_locate(model, rig, right, left, features=feats)
            rec = _peer_record(trial, res.T_cam1_model, res.ok, res.seconds, T_true, visible,
                               res.reason)
            rows.append(_finish(rec, method, pass_name, res.T_cam1_model, T_true,
                                res.inliers, res.reason))
            continue
        rng = scene_rng(config.seed, "search", trial.trial_id)
        result: LocateResult = (
            locate(model, rig, right, left, rng=rng, method=PAPER_METHOD) if method == "paper"
            else trial_locator(config, trial.garment)(right, left, rng=rng))
        rec = trial_record(trial, result, T_true, visible)
        rows.append(_finish(rec, method, pass_name, result.T_cam1_model, T_true,
                            float("nan"), str(result.search.stop_reason)))
    return rows


def _warm_up(config: ExperimentConfig, trial: Trial, methods: Sequence[str]) -> None:
    """Compile numba's kernels (and fill the caches) before anything is timed."""
    from photomodel.search import GAConfig

    model, rig, right, left, _, _ = trial_inputs(config, trial)
    for method in methods:
        if method == "peer":
            sift_locate(model, rig, right, left, features=_features(model, config.seed,
                                                                    trial.garment))
        elif method == "paper":
            short = PaperMethod(ga=GAConfig.paper(max_generations=2))
            locate(model, rig, right, left, rng=0, method=short)
        else:
            trial_locator(config, trial.garment)(right, left, rng=0)


def _prepare_models(configs: dict[str, ExperimentConfig], conditions: Sequence[str],
                    garments: Sequence[str]) -> list[float]:
    """The :class:`~photomodel.Locator` of every garment's model with every rig of the
    timing pass (it prepares the model: per-level samples and scan kernels) and its first
    ``locate``. Returns the times (s) of both together."""
    seconds = []
    seen: set[int] = set()
    for cond in conditions:
        config = configs[cond]
        if id(config) in seen:
            continue
        seen.add(id(config))
        for g in garments:
            model, rig, right, left, _, _ = trial_inputs(config, Trial(f"{cond}_{g}_0000", g,
                                                                      cond, 0))
            t = time.perf_counter()
            trial_locator(config, g)(right, left, rng=0)
            seconds.append(time.perf_counter() - t)
    return seconds


def _init_worker(config: ExperimentConfig, trial: Trial, methods: Sequence[str],
                 configs: dict[str, ExperimentConfig], conditions: Sequence[str],
                 garments: Sequence[str]) -> None:
    """Pool worker: one numba and one OpenCV thread, then a warm-up and, with the default
    method, every model prepared for its rigs (as before the timing pass).

    As ``photomodel.experiments._trials.limit_threads`` but without setting
    ``NUMBA_NUM_THREADS``: this module has imported numba already (the spawned worker imports
    it as ``__mp_main__``), and changing that variable after numba's import makes its next JIT
    compilation raise ("Cannot set NUMBA_NUM_THREADS ... once the threads have been launched").
    ``set_num_threads(1)`` alone holds the parallel kernels to one thread.
    """
    import cv2
    import numba

    numba.set_num_threads(1)
    cv2.setNumThreads(1)
    _warm_up(config, trial, methods)
    if "default" in methods:
        _prepare_models(configs, conditions, garments)


def _task(config: ExperimentConfig, trial: Trial, methods: Sequence[str]) -> list[dict]:
    return _run_methods(config, trial, methods, "pool")


# ----------------------------------------------------------------------------- statistics

def _num(rows: Iterable[dict[str, Any]], key: str) -> np.ndarray:
    return np.array([float(r[key]) for r in rows], dtype=np.float64)


def _clean(x: float) -> float | None:
    return None if x is None or not math.isfinite(x) else float(x)


def _axis_stats(rows: Sequence[dict[str, Any]]) -> tuple[dict, dict]:
    """(mean, std) per axis over rows with a pose; std needs two rows (ddof 1)."""
    mean, std = {}, {}
    for name, col in AXES.items():
        v = _num(rows, col)
        v = v[np.isfinite(v)]
        mean[name] = _clean(float(v.mean())) if len(v) else None
        std[name] = _clean(float(v.std(ddof=1))) if len(v) >= 2 else None
    return mean, std


def _seconds(rows: Sequence[dict[str, Any]]) -> dict[str, Any] | None:
    if not rows:
        return None
    t = _num(rows, "seconds")
    return {"median": float(np.median(t)), "p90": float(np.percentile(t, 90)), "n": len(t)}


def _rate(rows: Sequence[dict[str, Any]], key: str) -> float | None:
    return float(np.mean(_num(rows, key))) if rows else None


def _method_stats(rows: Sequence[dict[str, Any]], timing: Sequence[dict[str, Any]],
                  garments: Sequence[str]) -> dict[str, Any]:
    good = [r for r in rows if r["success"]]
    mean, std = _axis_stats(rows)
    mean_s, std_s = _axis_stats(good)
    per_garment = {}
    for g in garments:
        rg = [r for r in rows if r["garment"] == g]
        if not rg:
            continue
        mg, sg = _axis_stats([r for r in rg if r["success"]])
        per_garment[g] = {"trials": len(rg), "success_rate": _rate(rg, "success"),
                          "mean": mg, "std": sg}
    pool = _seconds(rows)
    return {
        "trials": len(rows),
        "success_rate": _rate(rows, "success"),
        "found_rate": _rate(rows, "found"),
        "posed": int(np.isfinite(_num(rows, "err_x_mm")).sum()),
        "mean": mean, "std": std, "mean_success": mean_s, "std_success": std_s,
        "per_garment": per_garment,
        "seconds_median": pool["median"] if pool else None,
        "seconds_p90": pool["p90"] if pool else None,
        "seconds_pool": pool,
        "seconds_2threads": _seconds(timing),
    }


def _ratio(num: dict[str, Any] | None, den: dict[str, Any] | None) -> float | None:
    if not num or not den or not den["median"]:
        return None
    return float(num["median"] / den["median"])


def _ratios(stats: dict[str, dict[str, Any]]) -> dict[str, float | None]:
    peer, default, paper = stats.get("peer"), stats.get("default"), stats.get("paper")
    out: dict[str, float | None] = {}
    if peer and default:
        out["time_peer_over_default"] = _ratio(peer["seconds_2threads"],
                                               default["seconds_2threads"])
        out["time_peer_over_default_pool"] = _ratio(peer["seconds_pool"],
                                                    default["seconds_pool"])
        out["success_default_minus_peer"] = default["success_rate"] - peer["success_rate"]
    if paper and default:
        out["time_paper_over_default_pool"] = _ratio(paper["seconds_pool"],
                                                     default["seconds_pool"])
    return out


def _targets(method: str, summary: dict[str, Any]) -> dict[str, Any]:
    """The issue's targets for one method, each met / missed / None (not evaluable), with the
    figure that decides it."""
    conds = {c: s[method] for c, s in summary["conditions"].items() if method in s}
    out: dict[str, Any] = {}
    rates = {c: s["success_rate"] for c, s in conds.items() if s["success_rate"] is not None}
    if rates:
        worst = min(rates, key=lambda c: rates[c])
        out["success_every_condition"] = {
            "met": rates[worst] >= TARGETS["success_rate_min"],
            "worst": {"condition": worst, "success_rate": rates[worst]},
            "threshold": TARGETS["success_rate_min"]}
    std_worst: dict[str, Any] = {}
    mean_worst: dict[str, Any] = {}
    for c, s in conds.items():
        for g, pg in s["per_garment"].items():
            for axis, v in pg["std"].items():
                if v is not None and (axis not in std_worst or v > std_worst[axis]["value"]):
                    std_worst[axis] = {"value": v, "condition": c, "garment": g}
            for axis in ("x_mm", "y_mm", "z_mm"):
                v = pg["mean"][axis]
                if v is not None and (axis not in mean_worst
                                      or abs(v) > abs(mean_worst[axis]["value"])):
                    mean_worst[axis] = {"value": v, "condition": c, "garment": g}
    limits = TARGETS["per_garment_std_max"]
    out["per_garment_std"] = {
        "met": (all(std_worst[a]["value"] <= limits[a] for a in limits)
                if set(std_worst) == set(limits) else None),
        "worst": std_worst, "thresholds": limits,
        "note": "std over successful trials of one garment in one condition (>= 2 needed)"}
    out["abs_mean"] = {
        "met": (all(abs(m["value"]) <= TARGETS["abs_mean_max_mm"] for m in mean_worst.values())
                if len(mean_worst) == 3 else None),
        "worst": mean_worst, "threshold_mm": TARGETS["abs_mean_max_mm"],
        "note": "mean error over successful trials of one garment in one condition"}
    overall = summary["overall"].get(method, {})
    t2 = overall.get("seconds_2threads")
    tp = overall.get("seconds_pool")
    source, t = ("2threads", t2) if t2 else ("pool", tp)
    if t:
        out["median_time"] = {"met": t["median"] <= TARGETS["median_seconds_max"],
                              "seconds": t["median"], "source": source,
                              "threshold_s": TARGETS["median_seconds_max"]}
    if method != "peer":
        peer = summary["overall"].get("peer", {})
        ratio = _ratio(peer.get("seconds_2threads"), t2) or _ratio(peer.get("seconds_pool"), tp)
        per_cond = {}
        for c, s in summary["conditions"].items():
            if method in s and "peer" in s:
                r = _ratio(s["peer"]["seconds_2threads"], s[method]["seconds_2threads"])
                if r is not None:
                    per_cond[c] = r
        worst_c = min(per_cond, key=lambda c: per_cond[c]) if per_cond else None
        out["faster_than_peer"] = {
            "met": None if ratio is None else ratio >= TARGETS["peer_over_default_time_min"],
            "ratio_peer_over_method": ratio, "source": source,
            "worst_condition": (None if worst_c is None
                                else {"condition": worst_c, "ratio": per_cond[worst_c]}),
            "threshold": TARGETS["peer_over_default_time_min"]}
    return out


def summarise(rows: Sequence[dict[str, Any]], conditions: Sequence[str],
              garments: Sequence[str], methods: Sequence[str]) -> dict[str, Any]:
    """Conditions, overall and targets of the JSON from the per-trial rows."""
    pool = [r for r in rows if r["pass"] == "pool"]
    timing = [r for r in rows if r["pass"] == "timing"]
    out: dict[str, Any] = {"conditions": {}, "overall": {}}
    for cond in conditions:
        stats = {}
        for m in methods:
            rm = [r for r in pool if r["condition"] == cond and r["method"] == m]
            if rm:
                tm = [r for r in timing if r["condition"] == cond and r["method"] == m]
                stats[m] = _method_stats(rm, tm, garments)
        stats["ratios"] = _ratios(stats)
        out["conditions"][cond] = stats
    for m in methods:
        rm = [r for r in pool if r["method"] == m]
        if not rm:
            continue
        rates = {c: s[m]["success_rate"] for c, s in out["conditions"].items() if m in s}
        out["overall"][m] = {
            "trials": len(rm), "success_rate": _rate(rm, "success"),
            "found_rate": _rate(rm, "found"),
            "worst_condition": min(rates, key=lambda c: rates[c]),
            "worst_condition_success_rate": min(rates.values()),
            "seconds_pool": _seconds(rm),
            "seconds_2threads": _seconds([r for r in timing if r["method"] == m])}
    out["overall"]["ratios"] = _ratios(out["overall"])
    out["targets"] = {m: _targets(m, out) for m in methods if m in out["overall"]}
    return out


# ----------------------------------------------------------------------------- output

def _json_safe(x: Any) -> Any:
    if isinstance(x, dict):
        return {k: _json_safe(v) for k, v in x.items()}
    if isinstance(x, list | tuple):
        return [_json_safe(v) for v in x]
    if isinstance(x, np.generic):
        x = x.item()
    if isinstance(x, float) and not math.isfinite(x):
        return None
    return x


def _write_csv(path: Path, rows: Sequence[dict[str, Any]]) -> None:
    columns = list(EXTRA_COLUMNS[:2]) + [k for k in rows[0] if k not in EXTRA_COLUMNS[:2]]
    with path.open("w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=columns, extrasaction="ignore")
        writer.writeheader()
        for r in rows:
            writer.writerow({k: (repr(float(v)) if isinstance(v, float | np.floating) else v)
                             for k, v in r.items()})


def _sort_rows(rows: list[dict[str, Any]], conditions: Sequence[str],
               garments: Sequence[str]) -> list[dict[str, Any]]:
    passes = ("pool", "timing")
    return sorted(rows, key=lambda r: (passes.index(r["pass"]), conditions.index(r["condition"]),
                                       garments.index(r["garment"]), r["index"],
                                       METHODS.index(r["method"])))


def _log(msg: str) -> None:
    print(msg, file=sys.stderr, flush=True)


def _condition_line(cond: str, rows: Sequence[dict[str, Any]], methods: Sequence[str]) -> str:
    parts = []
    for m in methods:
        rm = [r for r in rows if r["method"] == m]
        if rm:
            parts.append(f"{m} {100 * _rate(rm, 'success'):.0f}% "
                         f"{1e3 * float(np.median(_num(rm, 'seconds'))):.0f} ms")
    return f"{cond}: " + ", ".join(parts)


# ----------------------------------------------------------------------------- main

def _csv_list(text: str) -> list[str]:
    return [s.strip() for s in text.split(",") if s.strip()]


def main(argv: Sequence[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--conditions", default=",".join(DEFAULT_CONDITIONS),
                        help="comma-separated simulated conditions")
    parser.add_argument("--garments", default="all",
                        help="comma-separated catalogue garments, or 'all'")
    parser.add_argument("--trials", type=int, default=5,
                        help="trials per garment and condition (default and peer)")
    parser.add_argument("--paper-trials", type=int, default=1,
                        help="of those, how many also run the paper's method (0: none)")
    parser.add_argument("--methods", default="paper,default",
                        help="locate methods: paper, default (the peer always runs)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", type=Path, default=Path("benchmarks/results/locate.json"))
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--timing-trials", type=int, default=1,
                        help="trials per garment and condition in the 2-thread timing pass")
    parser.add_argument("--timing-methods", default="default,peer",
                        help="methods of the timing pass")
    args = parser.parse_args(argv)

    garments = list(garment_names()) if args.garments == "all" else _csv_list(args.garments)
    unknown = sorted(set(garments) - set(garment_names()))
    if unknown:
        parser.error(f"--garments: unknown {', '.join(unknown)}")
    conditions = _csv_list(args.conditions)
    for cond in conditions:
        try:
            parse_conditions(cond)
        except ValueError as exc:
            parser.error(f"--conditions: {exc}")
    locate_methods = [m for m in ("paper", "default") if m in _csv_list(args.methods)]
    if set(_csv_list(args.methods)) - set(METHODS):
        parser.error(f"--methods: expected names from {', '.join(METHODS)}")
    if args.paper_trials == 0 and "paper" in locate_methods:
        locate_methods.remove("paper")
    methods = [m for m in METHODS if m in locate_methods or m == "peer"]
    timing_methods = [m for m in METHODS if m in _csv_list(args.timing_methods)
                      and m in methods]
    if args.trials < 1 or args.paper_trials < 0 or args.workers < 1 or args.timing_trials < 0:
        parser.error("--trials and --workers must be >= 1, --paper-trials and "
                     "--timing-trials >= 0")

    n_trials = max(args.trials, args.paper_trials if "paper" in methods else 0)
    configs = _configs(garments, conditions, n_trials, args.seed)
    tasks = []
    for cond in conditions:
        for g in garments:
            for k in range(n_trials):
                ms = [m for m in methods if (m == "paper" and k < args.paper_trials)
                      or (m != "paper" and k < args.trials)]
                tasks.append((configs[cond], Trial(f"{cond}_{g}_{k:04d}", g, cond, k), ms))
    first = tasks[0]
    t_start = time.perf_counter()
    _log(f"bench_locate: {len(tasks)} scenes, methods {', '.join(methods)}, "
         f"{args.workers} workers")

    rows: list[dict[str, Any]] = []
    left = defaultdict(int)
    for _, trial, _ in tasks:
        left[trial.condition] += 1
    finished = 0
    with ProcessPoolExecutor(max_workers=args.workers, mp_context=get_context("spawn"),
                             initializer=_init_worker,
                             initargs=(first[0], first[1], methods, configs, conditions,
                                       garments)) as pool:
        futures = {pool.submit(_task, *t): t[1].condition for t in tasks}
        for fut in as_completed(futures):
            rows.extend(fut.result())
            cond = futures[fut]
            left[cond] -= 1
            if left[cond] == 0:
                finished += 1
                done = [r for r in rows if r["condition"] == cond]
                _log(f"[{finished}/{len(conditions)}] {_condition_line(cond, done, methods)} "
                     f"({time.perf_counter() - t_start:.0f} s)")

    import cv2
    import numba

    timing_threads = {"numba": numba.get_num_threads(), "opencv": cv2.getNumThreads()}
    prepare_seconds: list[float] = []
    if args.timing_trials and timing_methods:
        _log(f"timing pass: {', '.join(timing_methods)}, numba {timing_threads['numba']} "
             f"threads, OpenCV {timing_threads['opencv']}")
        _warm_up(first[0], first[1], timing_methods)
        if "default" in timing_methods:
            prepare_seconds = _prepare_models(configs, conditions, garments)
        for cond in conditions:
            for g in garments:
                for k in range(min(args.timing_trials, args.trials)):
                    trial = Trial(f"{cond}_{g}_{k:04d}", g, cond, k)
                    rows.extend(_run_methods(configs[cond], trial, timing_methods, "timing"))
            done = [r for r in rows if r["condition"] == cond and r["pass"] == "timing"]
            _log(f"timing {_condition_line(cond, done, timing_methods)}")

    rows = _sort_rows(rows, conditions, garments)
    feature_seconds = [f.seconds for f in _FEATURES.values()]
    settings = {
        "garments": garments, "conditions": conditions, "trials": args.trials,
        "paper_trials": args.paper_trials if "paper" in methods else 0,
        "methods": methods, "workers": args.workers,
        "timing_trials": args.timing_trials, "timing_methods": timing_methods,
        "success": {"position_error_3d_mm_below": SUCCESS_POSITION_MM,
                    "rotation_error_3d_deg_below": SUCCESS_ROTATION_DEG,
                    "and_found": True},
        "search_rng": "photomodel.sim.scene_rng(seed, 'search', trial_id)",
        "threads": {"pool": {"numba": 1, "opencv": 1}, "timing_pass": timing_threads},
        "peer": {"features": "SIFT (cv2.SIFT_create), brute-force L2, ratio 0.75",
                 "pose": "solvePnPRansac (camera 1, else camera 2), joint soft_l1 refinement",
                 "model_features": "computed once per model and cached, not timed",
                 "model_features_seconds_median": (float(np.median(feature_seconds))
                                                   if feature_seconds else None)},
        "default_model_preparation": {
            "note": ("before the timing pass, one locate per model and rig, timed apart from "
                     "the table (its first stereo pair: the model's per-level samples, blurred "
                     "colours and scan kernels are built and kept), as the peer's model "
                     "features are computed once outside the timed part"),
            "first_pair_seconds_median": (float(np.median(prepare_seconds))
                                          if prepare_seconds else None),
            "first_pair_seconds": prepare_seconds},
        "timing_note": ("seconds_pool: every trial, pool workers with one numba/OpenCV thread; "
                        "seconds_2threads: main process after the pool, default threads, first "
                        f"{args.timing_trials} trial(s) of every garment and condition; "
                        "seconds_median/p90 are the pool figures"),
        "wall_seconds": time.perf_counter() - t_start,
    }
    result = {"meta": metadata("locate", args.seed), "settings": settings,
              **summarise(rows, conditions, garments, methods)}
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(_json_safe(result), indent=1) + "\n")
    csv_path = args.out.with_name("locate_trials.csv")
    _write_csv(csv_path, rows)
    _log(f"wrote {args.out} and {csv_path} ({time.perf_counter() - t_start:.0f} s)")


if __name__ == "__main__":
    main()
