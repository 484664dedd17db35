"""Calibration from simulated views against the simulator's truth, then what that calibration
leaves in the poses: ``locate`` with the recovered calibrations on every garment's scenes.

Steps, each the command a user runs (``python -m photomodel ...`` in a subprocess):

1. ``simulate --out WORK/data --garments G --scenes S --calibration-views V --seed SEED``:
   the garments' model photos, S paper scenes per garment with their truth, and
   ``calibration/`` (board pairs for the hand rig, station views and a plane view, hand-eye
   joint angles with board views) with ``calibration/truth.json``.
2. ``calibrate stereo`` on the pairs, ``calibrate camera`` on the station views and the plane
   view, ``handeye`` on the hand-eye pairs with the recovered stereo file: each compared with
   the truth (:mod:`photomodel.calibrate._compare`): focal lengths (relative), principal
   points (px), the distortion's bend over the whole image and 5 % in from its sides (px),
   the baseline (mm) and stereo rotation (deg), the station's plane distance (mm), the
   hand-eye translation (mm) and rotation (deg).
3. ``build`` of every garment twice: with the true station camera (``data/model_camera.yaml``)
   and with the recovered one; then, in this process, the default :class:`photomodel.Locator`
   of each model with its rig (true models with the true stereo file, recovered models with
   the recovered stereo file) on each of the garment's scenes, seed = the scene's index. The
   errors against the scene's truth (camera 1's frame, mm and deg) in the paper's Table 1
   form per garment: success (found, position < 10 mm, theta < 5 deg), mean and sd of x, y,
   z, theta. The mean is the bias a calibration error leaves; the sd is issue 5's target
   (x, y <= 0.25 mm, z <= 0.5 mm, theta <= 0.05 deg).

Writes JSON (``--out``, default build/bench/calibrate.json) with the meta of
benchmarks/_meta.py and prints the tables. About 4 minutes on 2 cores with the defaults.

    python benchmarks/bench_calibrate.py [--views 20] [--scenes 10] [--garments all]
        [--seed 5] [--quick]
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from _meta import metadata  # noqa: E402

import photomodel as pm  # noqa: E402
from photomodel.calibrate import (  # noqa: E402
    camera_difference,
    stereo_difference,
    transform_difference,
)
from photomodel.camera import PinholeCamera, StereoRig  # noqa: E402
from photomodel.experiments import Trial, error_table, trial_record  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
SUCCESS_MM, SUCCESS_DEG = 10.0, 5.0
SD_TARGETS = {"x_mm": 0.25, "y_mm": 0.25, "z_mm": 0.5, "theta_deg": 0.05}
CAL_TARGETS = {"focal_rel": 0.002, "principal_point_px": 1.0, "baseline_mm": 0.2,
               "rotation_deg": 0.05, "distortion_px": 0.1, "handeye_mm": 0.5,
               "handeye_deg": 0.1}


def _cli(args: list[str]) -> str:
    """Run ``python -m photomodel ARGS``; its stdout (exit on failure with its stderr)."""
    done = subprocess.run([sys.executable, "-m", "photomodel", *args], capture_output=True,
                          text=True, cwd=ROOT)
    if done.returncode:
        sys.exit(f"photomodel {' '.join(args[:2])} failed ({done.returncode}):\n"
                 f"{done.stderr[-3000:]}")
    return done.stdout


def _json_cli(args: list[str]) -> dict[str, Any]:
    return json.loads(_cli([*args, "--json"]).strip().splitlines()[-1])


def _camera(K: Any, D: Any, size: list[int]) -> PinholeCamera:
    return PinholeCamera(np.asarray(K, float), np.asarray(D, float), int(size[0]), int(size[1]))


def calibrate(data: Path, cal: Path, pattern: str) -> dict[str, Any]:
    """Step 2: the three calibrations and their differences from the truth."""
    truth = json.loads((data / "calibration" / "truth.json").read_text())
    r = truth["rig"]
    size = r["image_size"]
    true_rig = StereoRig(_camera(r["K1"], r["D1"], size), _camera(r["K2"], r["D2"], size),
                         np.asarray(r["R"], float), np.asarray(r["T"], float).reshape(3))
    out: dict[str, Any] = {}
    t0 = time.perf_counter()
    stereo = _json_cli(["calibrate", "stereo", "--pairs", str(data / "calibration" / "pairs"),
                        "--pattern", pattern, "--out", str(cal / "stereo.yaml")])
    out["stereo_seconds"] = time.perf_counter() - t0
    out["stereo_rms_px"] = stereo["rms_px"]
    out["stereo_views"] = len(stereo["pairs"])
    out["stereo"] = stereo_difference(pm.load_stereo(cal / "stereo.yaml"), true_rig)
    t0 = time.perf_counter()
    station = _json_cli(["calibrate", "camera", "--images",
                         str(data / "calibration" / "station" / "views"), "--plane",
                         str(data / "calibration" / "station" / "plane.png"), "--pattern",
                         pattern, "--out", str(cal / "station.yaml")])
    out["station_seconds"] = time.perf_counter() - t0
    out["station_rms_px"] = station["rms_px"]
    s = truth["station"]
    true_station = _camera(s["K"], s["D"], s["image_size"])
    out["station"] = {**camera_difference(pm.load_camera(cal / "station.yaml"), true_station),
                      "distance_mm": station["distance_mm"] - s["distance_mm"]}
    t0 = time.perf_counter()
    he = _json_cli(["handeye", "--pairs", str(data / "calibration" / "handeye" / "pairs.json"),
                    "--stereo", str(cal / "stereo.yaml"), "--out", str(cal / "handeye.yaml")])
    out["handeye_seconds"] = time.perf_counter() - t0
    out["handeye"] = {**transform_difference(np.asarray(he["T_hand_cam1"], float),
                                             np.asarray(truth["T_hand_cam1"], float)),
                      "residual_mm": he["residual_mm"], "residual_deg": he["residual_deg"]}
    return out


def locate_all(data: Path, models: dict[str, Path], stereo: Path) -> dict[str, np.ndarray]:
    """Step 3: every scene located with its garment's model; the experiments' record of each
    (errors against the truth, camera 1's frame) as columns for the Table 1."""
    truth = json.loads((data / "truth.json").read_text())
    rig = pm.load_stereo(stereo)
    locators = {name: pm.Locator(pm.load_model(path), rig) for name, path in models.items()}
    records = []
    for index, (scene_id, facts) in enumerate(sorted(truth.items())):
        name = facts["model"]
        if name not in locators:
            continue
        scene = data / "scenes" / scene_id
        right, left = pm.read_image(scene / "right.png"), pm.read_image(scene / "left.png")
        result = locators[name](right, left, rng=index)
        visible = (facts.get("visible_fraction") or [1.0])[0]  # camera 1's, as experiments
        records.append(trial_record(Trial(scene_id, name, facts.get("condition", ""), index),
                                    result, np.asarray(facts["T_cam1_model"], float), visible))
    return {k: np.asarray([r[k] for r in records]) for k in records[0]}


def summarise(records: dict[str, np.ndarray], names: list[str]) -> dict[str, Any]:
    """Per garment and over all: trials, found, successes, mean and sd per axis."""
    out: dict[str, Any] = {}
    pos = np.sqrt(records["err_x_mm"] ** 2 + records["err_y_mm"] ** 2
                  + records["err_z_mm"] ** 2)
    ok = ((records["found"] != 0) & (pos < SUCCESS_MM)
          & (np.abs(records["err_theta_deg"]) < SUCCESS_DEG))
    for label in [*names, None]:
        table = error_table(records, label)
        mask = (np.ones(len(ok), bool) if label is None
                else records["garment"].astype(str) == label)
        row = {"trials": table.trials, "found": table.found,
               "success": int(np.count_nonzero(ok & mask))}
        for axis in ("x_mm", "y_mm", "z_mm", "theta_deg"):
            e = getattr(table, axis)
            row[axis] = {"mean": e.mean, "sd": e.std}
        out["all" if label is None else label] = row
    return out


def _fmt_table(title: str, summary: dict[str, Any]) -> str:
    lines = [title, f"{'garment':>9} {'ok':>7}  " + "  ".join(
        f"{a:>15}" for a in ("x mm", "y mm", "z mm", "theta deg")),
        f"{'':>9} {'':>7}  " + "  ".join(f"{'mean':>7} {'sd':>7}" for _ in range(4))]
    for name, row in summary.items():
        cells = "  ".join(f"{row[a]['mean']:7.3f} {row[a]['sd']:7.3f}"
                          for a in ("x_mm", "y_mm", "z_mm", "theta_deg"))
        lines.append(f"{name:>9} {row['success']:>3}/{row['trials']:<3}  {cells}")
    return "\n".join(lines)


def targets(cal: dict[str, Any], located: dict[str, Any]) -> dict[str, Any]:
    """Each target of the issue with its figure and whether it is met."""
    st = cal["stereo"]
    cams = [st["cam1"], st["cam2"]]
    focal = max(abs(v) for c in cams for v in c["focal_rel"])
    pp = max(abs(v) for c in cams for v in c["principal_point_px"])
    dist = max(c["distortion_px"] for c in cams)
    out = {
        "focal_rel": (focal, focal <= CAL_TARGETS["focal_rel"]),
        "principal_point_px": (pp, pp <= CAL_TARGETS["principal_point_px"]),
        "baseline_mm": (abs(st["baseline_mm"]),
                        abs(st["baseline_mm"]) <= CAL_TARGETS["baseline_mm"]),
        "rotation_deg": (st["rotation_deg"], st["rotation_deg"] <= CAL_TARGETS["rotation_deg"]),
        "distortion_px": (dist, dist <= CAL_TARGETS["distortion_px"]),
        "station_distortion_px": (cal["station"]["distortion_px"],
                                  cal["station"]["distortion_px"]
                                  <= CAL_TARGETS["distortion_px"]),
        "handeye_mm": (cal["handeye"]["translation_mm"],
                       cal["handeye"]["translation_mm"] <= CAL_TARGETS["handeye_mm"]),
        "handeye_deg": (cal["handeye"]["rotation_deg"],
                        cal["handeye"]["rotation_deg"] <= CAL_TARGETS["handeye_deg"]),
    }
    rec = located["recovered"]
    garments = {k: v for k, v in rec.items() if k != "all"}
    rate = rec["all"]["success"] / max(rec["all"]["trials"], 1)
    out["success_rate"] = (rate, rate >= 0.99)
    for axis, limit in SD_TARGETS.items():
        worst = max(v[axis]["sd"] for v in garments.values())
        out[f"sd_{axis}"] = (worst, bool(worst <= limit))
    return {k: {"value": v, "met": bool(m)} for k, (v, m) in out.items()}


def run(args: argparse.Namespace) -> dict[str, Any]:
    work: Path = args.work
    data, cal, built = work / "data", work / "cal", work / "models"
    cal.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    _cli(["simulate", "--out", str(data), "--garments", args.garments, "--scenes",
          str(args.scenes), "--calibration-views", str(args.views), "--seed", str(args.seed),
          "--force"])
    simulate_s = time.perf_counter() - t0
    truth = json.loads((data / "calibration" / "truth.json").read_text())
    pattern = truth["board"]["pattern"]
    print(f"simulated in {simulate_s:.0f} s; calibrating ({args.views} views a set) ...",
          flush=True)
    calibration = calibrate(data, cal, pattern)
    names = sorted({f["model"] for f in json.loads((data / "truth.json").read_text()).values()
                    if f["model"]}, key=lambda n: (len(n), n))
    located: dict[str, Any] = {}
    records: dict[str, Any] = {}
    for which, camera, stereo in (("true", data / "model_camera.yaml", data / "stereo.yaml"),
                                  ("recovered", cal / "station.yaml", cal / "stereo.yaml")):
        models = {}
        for name in names:
            path = built / which / f"{name}.npz"
            _cli(["build", "--photo", str(data / "models" / name / "photo.bmp"),
                  "--background", str(data / "models" / name / "background.bmp"),
                  "--camera", str(camera), "--out", str(path), "--name", name,
                  "--no-preview"])
            models[name] = path
        t0 = time.perf_counter()
        rec = locate_all(data, models, stereo)
        print(f"{which}: {len(rec['garment'])} scenes located in "
              f"{time.perf_counter() - t0:.0f} s", flush=True)
        located[which] = summarise(rec, names)
        records[which] = {k: v.tolist() for k, v in rec.items()}
    return {"meta": metadata("calibrate", args.seed),
            "settings": {"views": args.views, "scenes": args.scenes,
                         "garments": args.garments, "pattern": pattern,
                         "work": str(work)},
            "simulate_seconds": simulate_s, "calibration": calibration,
            "located": located, "targets": targets(calibration, located),
            "records": records}


def report(result: dict[str, Any]) -> str:
    c = result["calibration"]
    st = c["stereo"]
    lines = [f"stereo: RMS {c['stereo_rms_px']:.3f} px over {c['stereo_views']} pairs; "
             f"baseline {st['baseline_mm']:+.4f} mm, rotation {st['rotation_deg']:.4f} deg"]
    for cam in ("cam1", "cam2"):
        d = st[cam]
        lines.append(f"  {cam}: focal {100 * d['focal_rel'][0]:+.4f} / "
                     f"{100 * d['focal_rel'][1]:+.4f} %, principal point "
                     f"{d['principal_point_px'][0]:+.3f} / {d['principal_point_px'][1]:+.3f} px,"
                     f" distortion {d['distortion_px']:.3f} px (5 % in: "
                     f"{d['distortion_px_inset5']:.3f})")
    s = c["station"]
    lines.append(f"station: RMS {c['station_rms_px']:.3f} px; focal "
                 f"{100 * s['focal_rel'][0]:+.4f} / {100 * s['focal_rel'][1]:+.4f} %, "
                 f"principal point {s['principal_point_px'][0]:+.3f} / "
                 f"{s['principal_point_px'][1]:+.3f} px, distortion {s['distortion_px']:.3f} px "
                 f"(5 % in: {s['distortion_px_inset5']:.3f}), distance {s['distance_mm']:+.3f} mm")
    h = c["handeye"]
    lines.append(f"hand-eye: {h['translation_mm']:.3f} mm, {h['rotation_deg']:.4f} deg "
                 f"(residual {h['residual_mm']:.3f} mm, {h['residual_deg']:.4f} deg)")
    for which in ("true", "recovered"):
        lines.append("")
        lines.append(_fmt_table(f"locate with the {which} calibrations (success / trials; "
                                "error = estimate - truth)", result["located"][which]))
    lines.append("")
    lines.append("targets: " + "; ".join(
        f"{k} {v['value']:.4g} {'met' if v['met'] else 'MISSED'}"
        for k, v in result["targets"].items()))
    return "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--views", type=int, default=20, help="views per calibration set")
    ap.add_argument("--scenes", type=int, default=10, help="paper scenes per garment")
    ap.add_argument("--garments", default="all", help="simulate --garments (default all)")
    ap.add_argument("--seed", type=int, default=5)
    ap.add_argument("--quick", action="store_true", help="2 garments, 2 scenes, 12 views")
    ap.add_argument("--work", type=Path, default=ROOT / "build" / "bench-calibrate")
    ap.add_argument("--out", type=Path, default=ROOT / "build" / "bench" / "calibrate.json")
    args = ap.parse_args()
    if args.quick:
        args.views, args.scenes, args.garments = 12, 2, "No.1,No.5"
    result = run(args)
    print(report(result))
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(result, indent=1))
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
