"""Photo-model building against the simulator's truth: the paper's hue rule alone against the
default build (hue rule + per-pixel comparison with the background photo).

For every catalogue garment (the paper's 12 and the plane-coloured ones) the model-station
photos are rendered (seeded) and built twice: ``hue`` = ``BuildConfig(background_compare=False)``
(the paper's average-hue rule with the mixing edge: the build before the per-pixel rule, to the
bit) and ``robust`` = the defaults. Each build records the silhouette's area, the model origin's
position on the plane (the garment's true area centroid lies at ``render_model_photos``'s
offset, (6, -4) mm), the size, the S_in / S_out counts and the share of plane colour. The truth
is the garment texture's alpha: area = sum(alpha) * mm_per_px^2.

With ``--pose-scenes N`` each model (of the garments in ``--pose-garments``) also locates
its garment in N paper scenes (``simulate_scene``, the default ``Locator``): the mean position
error (the bias a wrong model gives every pose) and the median error, mm.

Writes JSON (``--out``, default build/bench/build.json) with the meta of benchmarks/_meta.py
and prints a table.

    python benchmarks/bench_build.py [--garments all,plane-coloured] [--seed 0]
        [--pose-scenes 10] [--pose-garments plane-coloured]
"""

from __future__ import annotations

import argparse
import json
import sys
import time
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from _meta import metadata  # noqa: E402

from photomodel.errors import InputError  # noqa: E402
from photomodel.model import BuildConfig, build_photo_model  # noqa: E402
from photomodel.sim import (  # noqa: E402
    MODEL_DISTANCE_MM,
    expand_garments,
    model_station_camera,
    render_model_photos,
    scene_rng,
)
from photomodel.sim._catalogue import catalogue_garment  # noqa: E402

TRUE_OFFSET_MM = (6.0, -4.0)
"""Where :func:`render_model_photos` puts the garment's origin (its area centroid), mm."""


def measure(name: str, seed: int, pose_scenes: int = 0) -> dict[str, object]:
    """Truth and both builds of one garment (and their pose errors over ``pose_scenes``)."""
    garment = catalogue_garment(name)
    tex = garment.texture
    camera = model_station_camera()
    photo, background = render_model_photos(garment, camera, scene_rng(seed, "model", name))
    row: dict[str, object] = {"garment": name, "truth": {
        "area_mm2": float(tex.alpha.astype(np.float64).sum()) * tex.mm_per_px**2,
        "centroid_mm": list(TRUE_OFFSET_MM)}}
    for label, config in (("hue", BuildConfig(background_compare=False)),
                          ("robust", BuildConfig())):
        t0 = time.perf_counter()
        try:
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                built = build_photo_model(photo, background, camera, MODEL_DISTANCE_MM,
                                          name=name, config=config)
        except InputError as exc:
            row[label] = {"error": str(exc)}
            continue
        m, q = built.model, built.quality
        cx, cy, _ = m.meta["centroid_in_camera_mm"]
        row[label] = {
            "area_mm2": m.area_mm2,
            "area_error_pct": 100 * (m.area_mm2 / row["truth"]["area_mm2"] - 1),
            "centroid_mm": [cx, cy],
            "centroid_error_mm": float(np.hypot(cx - TRUE_OFFSET_MM[0], cy - TRUE_OFFSET_MM[1])),
            "size_mm": [float(v) for v in m.size_mm],
            "n_in": m.n_in,
            "n_out": m.n_out,
            "plane_colour_share": q.plane_colour_share if q else None,
            "warned": bool(caught),
            "seconds": time.perf_counter() - t0,
        }
        if pose_scenes:
            row[label]["pose"] = pose_errors(built.model, name, seed, pose_scenes)
    if "error" not in row["hue"] and "error" not in row["robust"]:
        a, b = row["hue"], row["robust"]
        row["robust_vs_hue"] = {
            "centroid_shift_mm": float(np.hypot(*np.subtract(b["centroid_mm"],
                                                             a["centroid_mm"]))),
            "size_change_mm": float(np.abs(np.subtract(b["size_mm"], a["size_mm"])).max()),
            "area_change_pct": 100 * (b["area_mm2"] / a["area_mm2"] - 1),
        }
    return row


def pose_errors(model, name: str, seed: int, scenes: int) -> dict[str, object]:
    """Position errors (camera 1's frame, mm) of ``model`` located in ``scenes`` paper scenes."""
    from photomodel import Locator
    from photomodel.sim import hand_stereo_rig, parse_conditions, simulate_scene

    rig = hand_stereo_rig()
    locator = Locator(model, rig)
    errors = []
    for k in range(scenes):
        shot = simulate_scene(catalogue_garment(name), rig, parse_conditions("paper"),
                              scene_rng(seed, "paper", name, k))
        result = locator(shot.right_bgr, shot.left_bgr, rng=scene_rng(seed, "search", name, k))
        errors.append(result.T_cam1_model[:3, 3] - shot.T_cam1_model[:3, 3])
    e = np.array(errors)
    return {"scenes": scenes, "mean_error_mm": e.mean(axis=0).tolist(),
            "bias_mm": float(np.linalg.norm(e.mean(axis=0))),
            "median_error_mm": float(np.median(np.linalg.norm(e, axis=1))),
            "max_error_mm": float(np.linalg.norm(e, axis=1).max())}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--garments", default="all,plane-coloured")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--pose-scenes", type=int, default=0)
    parser.add_argument("--pose-garments", default="plane-coloured")
    parser.add_argument("--out", type=Path, default=Path("build/bench/build.json"))
    args = parser.parse_args(argv)
    posed = set(expand_garments(args.pose_garments))
    rows = [measure(name, args.seed, args.pose_scenes if name in posed else 0)
            for name in expand_garments(args.garments)]
    print(f"{'garment':15} {'build':6} {'area err %':>10} {'centroid err mm':>15} "
          f"{'size mm':>13} {'S_in':>5} {'S_out':>5} {'plane %':>7} warn")
    for row in rows:
        for label in ("hue", "robust"):
            r = row[label]
            if "error" in r:
                print(f"{row['garment']:15} {label:6} fails: {r['error'][:60]}")
                continue
            print(f"{row['garment']:15} {label:6} {r['area_error_pct']:10.2f} "
                  f"{r['centroid_error_mm']:15.2f} {r['size_mm'][0]:6.1f}x{r['size_mm'][1]:<6.1f}"
                  f" {r['n_in']:5d} {r['n_out']:5d} {100 * r['plane_colour_share']:7.1f} "
                  f"{'yes' if r['warned'] else ''}")
            if "pose" in r:
                pe = r["pose"]
                print(f"{'':15} {label:6} pose over {pe['scenes']} scenes: bias "
                      f"{pe['bias_mm']:.2f} mm, median error {pe['median_error_mm']:.2f} mm, "
                      f"max {pe['max_error_mm']:.2f} mm")
        if "robust_vs_hue" in row:
            d = row["robust_vs_hue"]
            print(f"{'':15} change: centroid {d['centroid_shift_mm']:.3f} mm, size "
                  f"{d['size_change_mm']:.3f} mm, area {d['area_change_pct']:+.3f} %")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps({**metadata("build", args.seed), "garments": rows},
                                   indent=1) + "\n")
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
