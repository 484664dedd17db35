"""Benchmark: where a stereo pair's ``locate`` time goes, stage by stage, against the peer.

For each seeded scene (the accuracy study's scenes, trial ids
``<condition>_<garment>_<index:04d>``, as ``bench_locate.py`` builds them) it runs the default
``locate`` once with stage timers and the SIFT peer once, and records per scene: the total time,
each stage's time and calls, the pose, fitness and score. The summary gives each stage's mean
milliseconds and calls a scene and its share of the total, the median / mean / 90th-percentile
time a pair, and the peer's median in the same run (the ratio the issue's target is about).

Stages (the first timed function on the call stack counts; what it calls is its own):
``features`` (``StereoFeatures``: both images' feature pyramids), ``coarse scan`` / ``level-3
scan`` (``scan_flat_poses`` by its level, with the re-ranking of its peaks), ``relit scan``,
``GA``, ``evolution strategy`` (levels 3 and 2, ``_refine_at``), ``shift sweeps``,
``blur candidates`` (``_sharpest_fit``), ``Gauss-Newton L1`` / ``L0``, ``flat restart`` and
``score`` (``score_terms``: the patch-slack score); ``other`` is the rest (the Python around
them). The timers wrap the library's functions from here; the library itself is unchanged.

``--compare OLD.json`` reads an earlier run of the same scenes (another commit, in another
process: numba's kernels of two versions cannot share one) and adds the per-scene time ratio
and how far each pose moved. The machine drifts by 10-20 % between runs of a few minutes:
run the two versions in turn, more than once.

Run: ``.venv/bin/python benchmarks/bench_stages.py --out build/stages.json``
(192 scenes of 16 conditions, trial 2: about a minute on two cores after the scenes are
simulated). Smoke: ``--conditions paper --garments No.1,No.6``.
"""

from __future__ import annotations

import argparse
import functools
import json
import sys
import time
from collections import defaultdict
from collections.abc import Callable, Sequence
from pathlib import Path
from types import ModuleType
from typing import Any

import numpy as np
from _meta import metadata
from peer_sift import model_features, sift_locate

import photomodel.locate._locate as locate_module
import photomodel.locate._locator as locator_module
import photomodel.search._pyramid as pyramid_module
from photomodel.experiments import ExperimentConfig, Trial, trial_inputs, trial_locator
from photomodel.fitness import ScanConfig
from photomodel.sim import garment_names, scene_rng

CONDITIONS = (
    "paper", "dim", "bright", "warm-light", "cool-light", "noise", "blur", "vignetting", "wood",
    "conveyor", "green", "tilt", "wrinkles", "distractors", "gripper", "overlap")
"""The benchmark's conditions with the default lens (one rig, one model preparation)."""


class StageTimers:
    """Wall-clock time and calls of named stages, outermost stage only."""

    def __init__(self) -> None:
        self.seconds: dict[str, float] = defaultdict(float)
        self.calls: dict[str, int] = defaultdict(int)
        self._depth = 0
        self._wrapped: list[tuple[ModuleType, str, Any]] = []

    def reset(self) -> None:
        self.seconds.clear()
        self.calls.clear()

    def wrap(self, module: ModuleType, name: str,
             label: str | Callable[..., str]) -> None:
        """Time ``module.name`` (as the module calls it) under ``label`` (or ``label(*args,
        **kwargs)``)."""
        inner = getattr(module, name)
        self._wrapped.append((module, name, inner))

        def run(call: Callable[..., Any], *args: Any, **kwargs: Any) -> Any:
            if self._depth:
                return call(*args, **kwargs)
            self._depth += 1
            t0 = time.perf_counter()
            try:
                return call(*args, **kwargs)
            finally:
                key = label if isinstance(label, str) else label(*args, **kwargs)
                self.seconds[key] += time.perf_counter() - t0
                self.calls[key] += 1
                self._depth -= 1

        if isinstance(inner, type):     # a class: its construction, its class methods kept
            setattr(module, name, type(inner.__name__, (inner,), {
                "__init__": lambda obj, *a, **k: run(super(type(obj), obj).__init__, *a,
                                                     **k)}))
            return

        @functools.wraps(inner)
        def timed(*args: Any, **kwargs: Any) -> Any:
            return run(inner, *args, **kwargs)

        setattr(module, name, timed)

    def uninstall(self) -> None:
        """Put the wrapped functions back."""
        while self._wrapped:
            module, name, inner = self._wrapped.pop()
            setattr(module, name, inner)


def _scan_label(model: Any, features: Any, lower: Any, upper: Any,
                config: ScanConfig | None = None) -> str:
    level = (config or ScanConfig()).level
    return "coarse scan" if level == 4 else f"level-{level} scan"


def _gauss_newton_label(objective: Any, x: Any, space: Any, level: int, *args: Any,
                        **kwargs: Any) -> str:
    return f"Gauss-Newton L{level}"


def install_timers() -> StageTimers:
    """Stage timers around the functions ``locate`` calls (see the module docstring)."""
    timers = StageTimers()
    timers.wrap(locator_module, "StereoFeatures", "features")   # a Locator makes them
    timers.wrap(locate_module, "scan_flat_poses", _scan_label)
    timers.wrap(locate_module, "relight_scan", "relit scan")
    timers.wrap(locate_module, "score_terms", "score")
    timers.wrap(pyramid_module, "run_search", "GA")
    timers.wrap(pyramid_module, "_refine_at", "evolution strategy")
    timers.wrap(pyramid_module, "_shift_sweep", "shift sweeps")
    timers.wrap(pyramid_module, "_sharpest_fit", "blur candidates")
    timers.wrap(pyramid_module, "gauss_newton_refine", _gauss_newton_label)
    timers.wrap(pyramid_module, "_flat_restart", "flat restart")
    return timers


def _scenes(conditions: Sequence[str], garments: Sequence[str], index: int, seed: int
            ) -> tuple[ExperimentConfig, list[tuple[Trial, Any, Any, Any, Any, Any]]]:
    config = ExperimentConfig(garments=tuple(garments), conditions=tuple(conditions),
                              trials=index + 1, seed=seed)
    scenes = []
    for cond in conditions:
        for g in garments:
            trial = Trial(f"{cond}_{g}_{index:04d}", g, cond, index)
            scenes.append((trial, *trial_inputs(config, trial)[:5]))
    return config, scenes


def run(conditions: Sequence[str], garments: Sequence[str], index: int, seed: int,
        peer: bool = True) -> dict[str, Any]:
    """Every scene once with stage timers (and the peer once); the JSON's ``scenes`` and
    ``summary``."""
    config, scenes = _scenes(conditions, garments, index, seed)
    timers = install_timers()
    try:
        rows = _timed_scenes(config, scenes, garments, seed, timers, peer)
    finally:
        timers.uninstall()
    return {"scenes": rows, "summary": summarise(rows)}


def _timed_scenes(config: ExperimentConfig, scenes: Sequence[tuple[Any, ...]],
                  garments: Sequence[str], seed: int, timers: StageTimers, peer: bool
                  ) -> list[dict[str, Any]]:
    features = {}
    for g in garments:   # warm-up: numba's kernels, each model's first stereo pair, the peer
        model, rig, right, left, _, _ = trial_inputs(config, Trial(f"paper_{g}_0000", g,
                                                                  "paper", 0))
        trial_locator(config, g)(right, left, rng=0)
        if peer:
            features[g] = model_features(model)
            sift_locate(model, rig, right, left, features=features[g])
    rows = []
    for trial, model, rig, right, left, T_true in scenes:
        timers.reset()
        t0 = time.perf_counter()
        result = trial_locator(config, trial.garment)(
            right, left, rng=scene_rng(seed, "search", trial.trial_id))
        seconds = time.perf_counter() - t0
        peer_seconds = None
        if peer:
            t1 = time.perf_counter()
            sift_locate(model, rig, right, left, features=features[trial.garment])
            peer_seconds = time.perf_counter() - t1
        T = result.T_cam1_model
        rows.append({
            "trial_id": trial.trial_id, "seconds": seconds, "peer_seconds": peer_seconds,
            "stages": {k: [v, timers.calls[k]] for k, v in timers.seconds.items()},
            "found": bool(result.found), "fitness": float(result.fitness),
            "score": float(result.score), "T_cam1_model": np.asarray(T).tolist(),
            "err_pos_mm": float(np.linalg.norm(T[:3, 3] - T_true[:3, 3]))})
    return rows


def summarise(rows: Sequence[dict[str, Any]]) -> dict[str, Any]:
    """Per-stage mean ms and calls a scene and share of the total; the time a pair."""
    n = len(rows)
    total = np.array([r["seconds"] for r in rows])
    stages: dict[str, list[float]] = defaultdict(lambda: [0.0, 0.0])
    for r in rows:
        for k, (s, calls) in r["stages"].items():
            stages[k][0] += s
            stages[k][1] += calls
    summary: dict[str, Any] = {
        "scenes": n, "found": int(sum(r["found"] for r in rows)),
        "seconds": {"median": float(np.median(total)), "mean": float(total.mean()),
                    "p90": float(np.percentile(total, 90))},
        "stages": {k: {"ms_per_scene": 1e3 * s / n, "calls_per_scene": c / n,
                       "share": s / total.sum()}
                   for k, (s, c) in sorted(stages.items(), key=lambda kv: -kv[1][0])}}
    other = total.sum() - sum(s for s, _ in stages.values())
    summary["stages"]["other"] = {"ms_per_scene": 1e3 * other / n, "calls_per_scene": None,
                                  "share": other / total.sum()}
    peer = [r["peer_seconds"] for r in rows if r["peer_seconds"] is not None]
    if peer:
        summary["peer_seconds_median"] = float(np.median(peer))
        summary["time_peer_over_default"] = float(np.median(peer) / np.median(total))
    return summary


def compare(new: Sequence[dict[str, Any]], old: Sequence[dict[str, Any]]) -> dict[str, Any]:
    """Per-scene time ratio new / old and how far the poses moved, on the scenes of both."""
    before = {r["trial_id"]: r for r in old}
    pairs = [(r, before[r["trial_id"]]) for r in new if r["trial_id"] in before]
    if not pairs:
        raise ValueError("compare: no scene in common")
    ratio = np.array([a["seconds"] / b["seconds"] for a, b in pairs])
    moved = np.array([np.linalg.norm(np.subtract(a["T_cam1_model"], b["T_cam1_model"])[:3, 3])
                      for a, b in pairs])
    return {"scenes": len(pairs), "per_scene_ratio_median": float(np.median(ratio)),
            "ratio_of_medians": float(np.median([a["seconds"] for a, _ in pairs])
                                      / np.median([b["seconds"] for _, b in pairs])),
            "pose_moved_max_mm": float(moved.max()),
            "poses_moved_over_0.05_mm": int(np.count_nonzero(moved > 0.05)),
            "fitness_changed_max": float(max(abs(a["fitness"] - b["fitness"])
                                             for a, b in pairs)),
            "found": [int(sum(b["found"] for _, b in pairs)),
                      int(sum(a["found"] for a, _ in pairs))]}


def _csv_list(text: str) -> list[str]:
    return [t.strip() for t in text.split(",") if t.strip()]


def main(argv: Sequence[str] | None = None) -> dict[str, Any]:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--conditions", default=",".join(CONDITIONS))
    ap.add_argument("--garments", default="all")
    ap.add_argument("--trial-index", type=int, default=2)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--no-peer", action="store_true", help="skip the SIFT peer")
    ap.add_argument("--compare", type=Path, help="an earlier run's JSON of the same scenes")
    ap.add_argument("--out", type=Path, default=Path("build/stages.json"))
    args = ap.parse_args(argv)
    garments = garment_names() if args.garments == "all" else _csv_list(args.garments)
    conditions = _csv_list(args.conditions)
    result = run(conditions, garments, args.trial_index, args.seed, peer=not args.no_peer)
    out = {**metadata("stages", args.seed),
           "settings": {"conditions": conditions, "garments": garments,
                        "trial_index": args.trial_index},
           **result}
    if args.compare is not None:
        out["compare"] = {"old": str(args.compare),
                          **compare(result["scenes"],
                                    json.loads(args.compare.read_text())["scenes"])}
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(out, indent=1))
    s = result["summary"]
    print(f"{s['scenes']} scenes, {s['found']} found; median {1e3 * s['seconds']['median']:.1f}"
          f" ms, mean {1e3 * s['seconds']['mean']:.1f} ms a pair", file=sys.stderr)
    for k, v in s["stages"].items():
        calls = "" if v["calls_per_scene"] is None else f"{v['calls_per_scene']:5.2f} calls"
        print(f"  {k:20s} {v['ms_per_scene']:6.2f} ms  {100 * v['share']:4.1f} %  {calls}",
              file=sys.stderr)
    if "time_peer_over_default" in s:
        print(f"peer median {1e3 * s['peer_seconds_median']:.1f} ms: peer / default "
              f"{s['time_peer_over_default']:.2f}", file=sys.stderr)
    if "compare" in out:
        print(f"against {args.compare}: {json.dumps(out['compare'])}", file=sys.stderr)
    return out


if __name__ == "__main__":
    main()
