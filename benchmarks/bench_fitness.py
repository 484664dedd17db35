"""Benchmark: fitness of a 60-pose population (numba kernel vs numpy reference) and one
``locate`` per stereo pair, on seeded rendered scenes. Writes JSON with the commit and the
library versions.

Run: ``.venv/bin/python benchmarks/bench_fitness.py [--out benchmarks/results/fitness.json]``
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
from _meta import metadata, timed

from photomodel.fitness import make_fitness
from photomodel.locate import Locator
from photomodel.model import build_photo_model
from photomodel.search import SearchSpace
from photomodel.sim import (
    MODEL_DISTANCE_MM,
    hand_stereo_rig,
    make_garment,
    model_station_camera,
    random_stereo_scene,
    render_model_photos,
)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--out", type=Path, default=Path("benchmarks/results/fitness.json"))
    parser.add_argument("--scenes", type=int, default=5)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()

    garment = make_garment("tshirt", "plaid", (200.0, 160.0), rng=args.seed)
    camera = model_station_camera()
    photo, background = render_model_photos(garment, camera, rng=args.seed + 1)
    model = build_photo_model(photo, background, camera, MODEL_DISTANCE_MM).model
    rig = hand_stereo_rig()
    space = SearchSpace.from_ranges()
    population = space.lower + space.span * np.random.default_rng(args.seed).random((60, 6))

    scene = random_stereo_scene(garment, rig, rng=args.seed + 2)
    fast = make_fitness("balanced", model, rig, scene.right_bgr, scene.left_bgr)
    ref = make_fitness("balanced", model, rig, scene.right_bgr, scene.left_bgr, backend="numpy")
    fast(population)  # compile / load the cached kernel
    t_fast = timed(lambda: fast(population), 50)
    t_ref = timed(lambda: ref(population), 10)

    t_locate = []
    locator = Locator(model, rig)
    for k in range(args.scenes):
        sc = random_stereo_scene(garment, rig, rng=args.seed + 100 + k)
        res = locator(sc.right_bgr, sc.left_bgr, rng=k)
        t_locate.append(res.seconds)

    result = {
        **metadata("fitness", args.seed),
        "model_points": {"S_in": model.n_in, "S_out": model.n_out},
        "population_fitness_ms": {
            "numba_median": 1e3 * float(np.median(t_fast)),
            "numpy_median": 1e3 * float(np.median(t_ref)),
            "speedup_numba_over_numpy": float(np.median(t_ref) / np.median(t_fast)),
        },
        "locate_s": {"median": float(np.median(t_locate)),
                     "p90": float(np.percentile(t_locate, 90)), "n": len(t_locate)},
    }
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(result, indent=2))
    print(json.dumps(result, indent=2))


if __name__ == "__main__":
    main()
