"""Benchmark: simulating one 640 x 480 stereo pair, per condition, against the plain flat render.

Baseline (same run): :func:`photomodel.sim.render_stereo_scene`, the exact flat renderer with
blur and noise only. Each condition runs :func:`photomodel.sim.simulate_scene` (table, placement,
nuisances, both cameras, exposure) on catalogue garment No.1 for several seeds; the JSON holds
medians, 90th percentiles and ratios to the baseline's median, with the commit and versions.

Run: ``.venv/bin/python benchmarks/bench_sim.py [--out benchmarks/results/sim.json]``
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
from _meta import metadata, timed

from photomodel.sim import (
    catalogue_garment,
    hand_stereo_rig,
    model_station_camera,
    parse_conditions,
    random_stereo_scene,
    render_model_photos,
    simulate_scene,
)

CONDITIONS = ("paper", "clean", "wood", "conveyor", "tilt", "wrinkles", "distractors",
              "gripper", "overlap", "no-target", "wood+wrinkles+distractors+gripper")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--out", type=Path, default=Path("benchmarks/results/sim.json"))
    parser.add_argument("--repeats", type=int, default=7)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--garment", default="No.1")
    args = parser.parse_args()

    garment = catalogue_garment(args.garment)
    rig = hand_stereo_rig()
    seeds = iter(range(args.seed, args.seed + 10_000))

    def baseline() -> None:
        random_stereo_scene(garment, rig, next(seeds))

    baseline()  # warm the caches (pixel rays) and numba's compiled kernels
    for name in CONDITIONS:
        cond = parse_conditions(name)
        simulate_scene(garment if cond.target else None, rig, cond, 0)
    t_base = timed(baseline, args.repeats)
    med_base = float(np.median(t_base))
    per_condition = {}
    for name in CONDITIONS:
        cond = parse_conditions(name)
        target = garment if cond.target else None
        t = timed(lambda c=cond, g=target: simulate_scene(g, rig, c, next(seeds)), args.repeats)
        per_condition[name] = {"median_ms": 1e3 * float(np.median(t)),
                               "p90_ms": 1e3 * float(np.percentile(t, 90)),
                               "ratio_to_baseline": float(np.median(t) / med_base)}
    camera = model_station_camera()
    t_model = timed(lambda: render_model_photos(garment, camera, next(seeds)), args.repeats)
    result = {
        **metadata("sim", args.seed),
        "garment": args.garment,
        "repeats": args.repeats,
        "stereo_pair_baseline_flat_ms": {"median": 1e3 * med_base,
                                         "p90": 1e3 * float(np.percentile(t_base, 90))},
        "stereo_pair_ms": per_condition,
        "model_photos_ms": {"median": 1e3 * float(np.median(t_model))},
    }
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(result, indent=2) + "\n")
    print(json.dumps(result, indent=2))


if __name__ == "__main__":
    main()
