"""Benchmark: register anywhere. Models built in place from the hand cameras, models of unknown
scale measured by their first locate, and labels.

In place
--------
Per catalogue garment (the 12), one registration shot: ``paper`` conditions, the garment at a
random place on the table as it lies in its station photo (in-plane angle 0: the model's frame
is how the garment lay when registered, and later locates find it within the search box's
+-53 deg of that, as a station model's), with the empty table's pair. Two models: ``empty``
(against the empty pair) and ``colour`` (against the table's colour only). Then ``--scenes``
test shots per condition of every group (:data:`GROUPS`), located with the in-place models and
with the garment's station model, each against the truth: an in-place model's true pose in a
test shot is ``T_true_test @ inv(T_true_build) @ T_cam1_model_build`` (its frame where the
build put it, carried with the garment), so an error of the build (plane, scale) shows as one.
Figures: success (10 mm, 5 deg), the Table 1 form, the mean position error, per garment the sd
of the position error against the station model's (target at most 1.5x), and the build's
time (target at most 1 s).

Unknown scale
-------------
Per garment, its station photo as a photo of unknown scale (no calibration: the nominal scale
of :func:`photomodel.model.build_unknown_scale`). The true factor is fitted between the
station model's outline (mm, through the station camera and its lens) and the same photo
pixels at the nominal scale. On ``--scenes`` paper shots: the first, scale-searching locate
(``Locator`` of the nominal model, its first call, model preparation included), its factor
against the truth (target within 0.5 %), and its time against an ordinary locate of the
station model (first call with preparation, and warm). Then the model at its measured factor
(:func:`photomodel.model.resampled_model`, as ``models set-scale`` stores it) against the
station model on the same test shots: success and accuracy.

Labels
------
:func:`_register_labels.measure_labels` (read rate where the module is at least 3 px in one
view, identity from the label, disagreements flagged).

Bad input
---------
``photomodel build`` on views of different sizes, an "empty" pair with the garment in it, a
garment cut by the image border, a photo of unknown scale with no garment: one line each, exit
non-zero, nothing written.

Run: ``.venv/bin/python benchmarks/bench_register.py`` (about 15 minutes on 2 cores)
Smoke: ``--scenes 1 --garments No.2,No.5 --label-scenes 20``
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
import warnings
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from _accuracy import pose_errors, table1
from _meta import metadata

REPO = Path(__file__).resolve().parents[1]
DEFAULT_OUT = REPO / "benchmarks" / "results" / "register.json"
POSE_TOL_MM = 10.0
POSE_TOL_DEG = 5.0
GROUPS = {
    "paper": ("paper",),
    "light": ("dim", "bright", "warm-light", "cool-light"),
    "optics": ("noise", "blur", "vignetting"),
    "table": ("grey", "wood", "conveyor", "green"),
    "geometry": ("tilt", "wrinkles"),
    "clutter": ("distractors", "overlap", "gripper"),
}
TARGETS = {"success": 0.99, "mean_error_mm": 1.0, "sd_ratio": 1.5, "build_s": 1.0,
           "scale_error": 0.005, "first_locate_ratio": 5.0, "label_read": 0.99}


def _log(msg: str) -> None:
    print(msg, file=sys.stderr, flush=True)


def _ok(e: tuple[float, float, float, float]) -> bool:
    return bool(np.linalg.norm(e[:3]) <= POSE_TOL_MM and abs(e[3]) <= POSE_TOL_DEG)


def _summary(rows: list[dict[str, Any]], key: str) -> dict[str, Any]:
    """Success, Table 1 of the successes, mean position error of ``rows[...][key]``."""
    errors = [tuple(r[key]) for r in rows]
    good = [e for e in errors if _ok(e)]
    return {"scenes": len(errors), "success": len(good) / max(len(errors), 1),
            "mean_error_mm": float(np.mean([np.linalg.norm(e[:3]) for e in good]))
            if good else None,
            "table1": table1(good)}


def run_in_place(args: argparse.Namespace) -> dict[str, Any]:
    """In-place models against station models on every group's test shots."""
    import photomodel as pm
    from photomodel.model import build_in_place
    from photomodel.sim import (
        catalogue_garment,
        hand_stereo_rig,
        parse_conditions,
        scene_rng,
        simulate_scene,
        station_model,
    )

    rig = hand_stereo_rig()
    rows: list[dict[str, Any]] = []
    builds: list[dict[str, Any]] = []
    for name in args.garments:
        gen = scene_rng(args.seed, "register", name)
        garment = catalogue_garment(name)
        placement = (float(gen.uniform(-120, 120)), float(gen.uniform(-90, 90)), 0.0)
        shot = simulate_scene(garment, rig, parse_conditions("paper"), gen, empty=True,
                              placement=placement)
        assert shot.T_cam1_model is not None and shot.empty_bgr is not None
        locators = {"station": pm.Locator(station_model(name, args.seed), rig)}
        carry = {}
        for kind, empty in (("empty", shot.empty_bgr), ("colour", (None, None))):
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                t0 = time.perf_counter()
                made = build_in_place(rig, shot.right_bgr, shot.left_bgr,
                                      empty_right_bgr=empty[0], empty_left_bgr=empty[1],
                                      name=name)
                seconds = time.perf_counter() - t0
            locators[kind] = pm.Locator(made.built.model, rig)
            carry[kind] = np.linalg.inv(shot.T_cam1_model) @ made.T_cam1_model
            n_true = shot.T_cam1_model[:3, 2]
            builds.append({"garment": name, "kind": kind, "seconds": seconds,
                           "plane_distance_error_mm": made.plane.distance_mm
                           - float(n_true @ shot.T_cam1_model[:3, 3]),
                           "plane_normal_error_deg": float(np.degrees(np.arccos(min(
                               1.0, abs(float(made.plane.normal_cam1 @ n_true)))))),
                           "mm_per_px": made.mm_per_px, "points": made.plane.points})
        for group, conditions in GROUPS.items():
            for condition in conditions:
                for k in range(args.scenes):
                    test = simulate_scene(garment, rig, parse_conditions(condition),
                                          scene_rng(args.seed, "register-test", name,
                                                    condition, k))
                    assert test.T_cam1_model is not None
                    row: dict[str, Any] = {"garment": name, "group": group,
                                           "condition": condition, "scene": k}
                    for kind, loc in locators.items():
                        r = loc(test.right_bgr, test.left_bgr, rng=k)
                        T_true = test.T_cam1_model @ carry.get(kind, np.eye(4))
                        row[kind] = pose_errors(r.T_cam1_model, T_true)
                    rows.append(row)
        _log(f"  in place {name}: {len(rows)} shots so far")
    out: dict[str, Any] = {"builds": builds,
                           "build_seconds": {"median": float(np.median(
                               [b["seconds"] for b in builds])),
                               "max": float(max(b["seconds"] for b in builds))}}
    for kind in ("station", "empty", "colour"):
        out[kind] = {"all": _summary(rows, kind),
                     "groups": {g: _summary([r for r in rows if r["group"] == g], kind)
                                for g in GROUPS}}
    ratios: dict[str, dict[str, float]] = {}
    for kind in ("empty", "colour"):
        ratios[kind] = {}
        for name in args.garments:
            mine = [r for r in rows if r["garment"] == name]
            sd = {}
            for key in ("station", kind):
                good = np.asarray([r[key][:3] for r in mine if _ok(r[key])])
                sd[key] = float(np.linalg.norm(good.std(axis=0, ddof=1))) if len(good) > 2 \
                    else float("nan")
            ratios[kind][name] = sd[kind] / sd["station"] if sd["station"] > 0 else float("nan")
    out["sd_ratio_by_garment"] = ratios
    out["rows"] = rows
    return out


def run_unknown_scale(args: argparse.Namespace) -> dict[str, Any]:
    """The scale from the first locate; then the model at that scale."""
    import photomodel as pm
    from photomodel.model import build_unknown_scale, resampled_model
    from photomodel.sim import (
        catalogue_garment,
        hand_stereo_rig,
        model_station_camera,
        parse_conditions,
        render_model_photos,
        scene_rng,
        simulate_scene,
        station_model,
        station_scale,
    )

    rig = hand_stereo_rig()
    camera = model_station_camera()
    rows: list[dict[str, Any]] = []
    for name in args.garments:
        garment = catalogue_garment(name)
        station = station_model(name, args.seed)
        photo, _ = render_model_photos(garment, camera, scene_rng(args.seed, "model", name))
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            nominal = build_unknown_scale(photo, None, name=name).model
        truth, carry = station_scale(station, nominal)
        for k in range(args.scenes):
            test = simulate_scene(garment, rig, parse_conditions("paper"),
                                  scene_rng(args.seed, "scale-test", name, k))
            assert test.T_cam1_model is not None
            t0 = time.perf_counter()
            first = pm.Locator(nominal, rig)(test.right_bgr, test.left_bgr, rng=k)
            t_first = time.perf_counter() - t0
            t0 = time.perf_counter()
            ordinary = pm.Locator(station, rig)
            r_station = ordinary(test.right_bgr, test.left_bgr, rng=k)
            t_ordinary = time.perf_counter() - t0
            t0 = time.perf_counter()
            ordinary(test.right_bgr, test.left_bgr, rng=k)
            t_warm = time.perf_counter() - t0
            row = {"garment": name, "scene": k, "found": first.found,
                   "scale": first.scale, "true_scale": truth,
                   "scale_error": None if first.scale is None else first.scale / truth - 1.0,
                   "first_s": t_first, "ordinary_first_s": t_ordinary, "ordinary_warm_s": t_warm,
                   "station": pose_errors(r_station.T_cam1_model, test.T_cam1_model)}
            if first.scale is not None:
                known = pm.Locator(resampled_model(nominal, first.scale, source="bench"), rig)
                later = []
                for j in range(args.scenes):
                    other = simulate_scene(garment, rig, parse_conditions("paper"),
                                           scene_rng(args.seed, "scale-after", name, k, j))
                    assert other.T_cam1_model is not None
                    r = known(other.right_bgr, other.left_bgr, rng=j)
                    later.append(pose_errors(r.T_cam1_model, other.T_cam1_model @ carry))
                row["after"] = later
            rows.append(row)
        _log(f"  unknown scale {name}: true {truth:.5f}, measured "
             f"{[round(r['scale'], 5) if r['scale'] else None for r in rows[-args.scenes:]]}")
    errors = [abs(r["scale_error"]) for r in rows if r["scale_error"] is not None]
    after = [tuple(e) for r in rows for e in r.get("after", [])]
    good = [e for e in after if _ok(e)]
    station = [tuple(r["station"]) for r in rows]
    first = np.asarray([r["first_s"] for r in rows])
    return {
        "scenes": len(rows), "measured": len(errors),
        "scale_error": {"median": float(np.median(errors)) if errors else None,
                        "max": float(max(errors)) if errors else None,
                        "within_0.5%": sum(e <= 0.005 for e in errors) / max(len(rows), 1)},
        "first_locate_s": {"median": float(np.median(first)),
                           "p90": float(np.quantile(first, 0.9))},
        "ordinary_first_s": float(np.median([r["ordinary_first_s"] for r in rows])),
        "ordinary_warm_s": float(np.median([r["ordinary_warm_s"] for r in rows])),
        "ratio_to_ordinary_first": float(np.median(first))
        / float(np.median([r["ordinary_first_s"] for r in rows])),
        "ratio_to_ordinary_warm": float(np.median(first))
        / float(np.median([r["ordinary_warm_s"] for r in rows])),
        "after": {"scenes": len(after), "success": len(good) / max(len(after), 1),
                  "table1": table1(good)},
        "station": {"success": sum(_ok(e) for e in station) / max(len(station), 1),
                    "table1": table1([e for e in station if _ok(e)])},
        "rows": rows}


def run_bad_inputs(args: argparse.Namespace) -> dict[str, Any]:
    """``photomodel build`` on the issue's bad inputs: one line, exit != 0, nothing written."""
    import cv2

    from photomodel.camera import save_stereo
    from photomodel.sim import (
        catalogue_garment,
        hand_stereo_rig,
        parse_conditions,
        simulate_scene,
    )

    rig = hand_stereo_rig()
    out: dict[str, Any] = {}
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        save_stereo(d / "stereo.yaml", rig)
        shot = simulate_scene(catalogue_garment("No.2"), rig, parse_conditions("paper"), 1,
                              empty=True, placement=(0.0, 0.0, 0.0))
        assert shot.empty_bgr is not None
        images = {"right": shot.right_bgr, "left": shot.left_bgr,
                  "empty_right": shot.empty_bgr[0], "empty_left": shot.empty_bgr[1],
                  "small": cv2.resize(shot.left_bgr, (320, 240)),
                  "plain": np.full((480, 640, 3), 128, np.uint8)}
        w = shot.right_bgr.shape[1]
        shifted = np.roll(shot.right_bgr, w // 2, axis=1)     # the garment across the border
        images["cut"] = shifted
        images["cut_left"] = np.roll(shot.left_bgr, w // 2, axis=1)
        for n, img in images.items():
            cv2.imwrite(str(d / f"{n}.png"), img)
        base = [sys.executable, "-m", "photomodel", "build", "--out", str(d / "out.model")]
        stereo = ["--stereo", str(d / "stereo.yaml")]
        cases = {
            "views of different sizes": stereo + ["--right", str(d / "right.png"), "--left",
                                                  str(d / "small.png")],
            "an empty pair with the garment in it": stereo + [
                "--right", str(d / "right.png"), "--left", str(d / "left.png"),
                "--empty-right", str(d / "right.png"), "--empty-left", str(d / "left.png")],
            "a garment cut by the image border": stereo + [
                "--right", str(d / "cut.png"), "--left", str(d / "cut_left.png")],
            "a photo of unknown scale with no garment": ["--scale", "unknown", "--photo",
                                                        str(d / "plain.png")],
        }
        for case, extra in cases.items():
            p = subprocess.run(base + extra, capture_output=True, text=True, cwd=REPO)
            lines = [x for x in p.stderr.splitlines() if x.strip()]
            written = sorted(f.name for f in d.iterdir() if f.name.startswith("out"))
            out[case] = {"exit": p.returncode, "stderr": p.stderr.strip(),
                         "one_line": len(lines) == 1 and "Traceback" not in p.stderr,
                         "written": written}
    return out


def verdicts(result: dict[str, Any]) -> dict[str, Any]:
    def v(value: Any, target: str, ok: bool) -> dict[str, Any]:
        return {"value": value, "target": target, "verdict": "pass" if ok else "fail"}

    out: dict[str, Any] = {}
    ip = result.get("in_place")
    if ip:
        for kind in ("empty", "colour"):
            a = ip[kind]["all"]
            ratios = [x for x in ip["sd_ratio_by_garment"][kind].values() if np.isfinite(x)]
            out[f"in_place_{kind}_success"] = v(a["success"], ">= 0.99",
                                                a["success"] >= TARGETS["success"])
            out[f"in_place_{kind}_mean_error_mm"] = v(
                a["mean_error_mm"], "<= 1.0",
                a["mean_error_mm"] is not None and a["mean_error_mm"] <= 1.0)
            out[f"in_place_{kind}_sd_ratio_max"] = v(max(ratios) if ratios else None, "<= 1.5",
                                                     bool(ratios) and max(ratios) <= 1.5)
        out["build_s_max"] = v(ip["build_seconds"]["max"], "<= 1.0",
                               ip["build_seconds"]["max"] <= TARGETS["build_s"])
    us = result.get("unknown_scale")
    if us:
        out["scale_error_max"] = v(us["scale_error"]["max"], "<= 0.005",
                                   us["scale_error"]["max"] is not None
                                   and us["scale_error"]["max"] <= 0.005
                                   and us["measured"] == us["scenes"])
        out["after_success"] = v(us["after"]["success"], ">= station's",
                                 us["after"]["success"] >= us["station"]["success"] - 1e-9)
        out["first_locate_ratio_warm"] = v(us["ratio_to_ordinary_warm"], "<= 5",
                                           us["ratio_to_ordinary_warm"] <= 5.0)
        out["first_locate_ratio_first"] = v(us["ratio_to_ordinary_first"], "<= 5",
                                            us["ratio_to_ordinary_first"] <= 5.0)
    lb = result.get("labels")
    if lb and "read_rate_3px" in lb:
        out["label_read_rate_3px"] = v(lb["read_rate_3px"], ">= 0.99",
                                       lb["read_rate_3px"] >= TARGETS["label_read"])
    bad = result.get("bad_input")
    if bad:
        fine = all(c["exit"] != 0 and c["one_line"] and not c["written"] for c in bad.values())
        out["bad_input"] = v(fine, "one line, exit != 0, nothing written", fine)
    return out


def main(argv: Sequence[str] | None = None) -> dict[str, Any]:
    from photomodel.sim import garment_names

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scenes", type=int, default=2,
                    help="test shots per condition and garment (2)")
    ap.add_argument("--garments", type=lambda s: [g for g in s.split(",") if g],
                    default=list(garment_names()), help="catalogue garments (the 12)")
    ap.add_argument("--label-scenes", type=int, default=200)
    ap.add_argument("--skip", type=lambda s: [g for g in s.split(",") if g], default=[],
                    help="parts to leave out: in_place,unknown_scale,labels,bad_input")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", type=Path, default=DEFAULT_OUT)
    args = ap.parse_args(argv)
    result: dict[str, Any] = {"meta": metadata("register", args.seed),
                              "settings": {k: v for k, v in vars(args).items() if k != "out"}}
    t0 = time.perf_counter()
    if "in_place" not in args.skip:
        _log("in place ...")
        result["in_place"] = run_in_place(args)
    if "unknown_scale" not in args.skip:
        _log("unknown scale ...")
        result["unknown_scale"] = run_unknown_scale(args)
    if "labels" not in args.skip:
        _log("labels ...")
        try:
            from _register_labels import measure_labels
        except ImportError as exc:
            result["labels"] = {"error": str(exc)}
        else:
            result["labels"] = measure_labels(args.seed, args.label_scenes)
    if "bad_input" not in args.skip:
        result["bad_input"] = run_bad_inputs(args)
    result["targets"] = verdicts(result)
    result["seconds"] = time.perf_counter() - t0
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(result, indent=1, default=str) + "\n")
    for name, v in result["targets"].items():
        print(f"  {name}: {v['verdict']} ({v['value']}; target {v['target']})")
    print(f"wrote {args.out}")
    return result


if __name__ == "__main__":
    main()
