"""Benchmark: ``identify`` with a library of the 12 catalogue models against one ``locate``.

The scenes are those of the accuracy study and of ``photomodel simulate --seed``
(:func:`photomodel.experiments.trial_inputs`, trial ids ``<condition>_<garment>_<index:04d>``),
the models built from the same model photos. Per scene, in the same process and run, in
alternating order (so a slow phase of the shared machine hits both alike):

``locate``    ``photomodel.Locator(true_model, rig)(right, left, rng=...)`` (default
              ``soft`` method), what a cell that knows the garment runs;
``identify``  ``photomodel.Identifier(all_12_models, rig)(right, left, rng=...)``,
              features included.

Reported: median seconds of each, the ratio of the medians and the median of the per-scene
ratios (target: at most 4), whether identify named the true model, and how many models it
searched. numba warms up (one call of each) before timing. Threads: whatever the environment
gives (the reference runs use ``NUMBA_NUM_THREADS=1 nice -n 10``, since the 2 cores are
shared); the ratio is taken in the same run, so it stays fair.

Run: ``NUMBA_NUM_THREADS=1 nice -n 10 .venv/bin/python benchmarks/bench_identify.py``
Smoke: ``.venv/bin/python benchmarks/bench_identify.py --scenes 1 --garments No.3,No.5
--out build/bench-smoke/identify.json``
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
from _meta import metadata

from photomodel.experiments import ExperimentConfig, Trial, trial_inputs, trial_locator
from photomodel.experiments._trials import _model
from photomodel.identify import Identifier
from photomodel.sim import garment_names, scene_rng

TARGET_RATIO_MAX = 4.0


def run(garments: list[str], conditions: list[str], scenes: int, seed: int) -> dict[str, Any]:
    config = ExperimentConfig(garments=tuple(garments), conditions=tuple(conditions),
                              trials=scenes, seed=seed)
    library = [_model(config, g) for g in garment_names()]
    first = Trial(f"{conditions[0]}_{garments[0]}_0000", garments[0], conditions[0], 0)
    model, rig, right, left, _, _ = trial_inputs(config, first)
    trial_locator(config, garments[0])(right, left, rng=0)  # JIT warm-up
    identifier = Identifier(library, rig)
    identifier(right, left, rng=0)
    rows = []
    k = 0
    for cond in conditions:
        for g in garments:
            for i in range(scenes):
                trial = Trial(f"{cond}_{g}_{i:04d}", g, cond, i)
                model, rig, right, left, T_true, _ = trial_inputs(config, trial)
                rng_l = scene_rng(seed, "search", trial.trial_id)
                rng_i = scene_rng(seed, "identify", trial.trial_id)
                order = ("locate", "identify") if k % 2 == 0 else ("identify", "locate")
                k += 1
                times: dict[str, float] = {}
                res_i = None
                for what in order:
                    t0 = time.perf_counter()
                    if what == "locate":
                        trial_locator(config, g)(right, left, rng=rng_l)
                    else:
                        res_i = identifier(right, left, rng=rng_i)
                    times[what] = time.perf_counter() - t0
                assert res_i is not None
                rows.append({
                    "trial_id": trial.trial_id, "locate_s": times["locate"],
                    "identify_s": times["identify"],
                    "ratio": times["identify"] / times["locate"],
                    "identified": res_i.model, "correct": res_i.model == g,
                    "searched": sum(c.result is not None for c in res_i.candidates)})
                print(f"{trial.trial_id}: locate {times['locate']:.2f} s, identify "
                      f"{times['identify']:.2f} s ({rows[-1]['ratio']:.2f}x) -> "
                      f"{res_i.model}", file=sys.stderr, flush=True)
    loc = np.array([r["locate_s"] for r in rows])
    ide = np.array([r["identify_s"] for r in rows])
    ratios = np.array([r["ratio"] for r in rows])
    return {
        "scenes": len(rows),
        "library_models": len(library),
        "locate_median_s": float(np.median(loc)),
        "identify_median_s": float(np.median(ide)),
        "locate_mean_s": float(np.mean(loc)),
        "identify_mean_s": float(np.mean(ide)),
        "ratio_of_medians": float(np.median(ide) / np.median(loc)),
        "ratio_of_means": float(np.mean(ide) / np.mean(loc)),
        "median_ratio": float(np.median(ratios)),
        "ratio_p90": float(np.quantile(ratios, 0.9)),
        "identified_correctly": float(np.mean([r["correct"] for r in rows])),
        "models_searched_median": float(np.median([r["searched"] for r in rows])),
        "rows": rows,
    }


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--garments", default=",".join(garment_names()))
    p.add_argument("--conditions", default="paper")
    p.add_argument("--scenes", type=int, default=2, help="scenes per garment and condition")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--out", type=Path,
                   default=Path(__file__).parent / "results" / "identify.json")
    args = p.parse_args(argv)
    garments = [g for g in args.garments.split(",") if g]
    conditions = [c for c in args.conditions.split(",") if c]
    t0 = time.perf_counter()
    result = run(garments, conditions, args.scenes, args.seed)
    out = {**metadata("identify", args.seed),
           "settings": {"garments": garments, "conditions": conditions, "scenes": args.scenes,
                        "numba_threads": os.environ.get("NUMBA_NUM_THREADS", "default")},
           "target_ratio_max": TARGET_RATIO_MAX, **result,
           "wall_seconds": time.perf_counter() - t0}
    args.out.parent.mkdir(parents=True, exist_ok=True)
    tmp = args.out.with_name(f".{args.out.name}.tmp")
    tmp.write_text(json.dumps(out, indent=1) + "\n")
    os.replace(tmp, args.out)
    print(f"{args.out}: identify / locate = {result['ratio_of_medians']:.2f} (medians), "
          f"{result['median_ratio']:.2f} (median per scene); identified "
          f"{100 * result['identified_correctly']:.0f} %")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
