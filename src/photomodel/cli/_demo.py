"""``photomodel demo``: an end-to-end run on built-in (simulated) data.

Simulates a cell (``photomodel simulate``: chessboard views for the calibrations, the garments'
model photos, one stereo scene per garment with its truth), then runs the real commands on
those files, with no file written by hand: ``calibrate stereo`` (the hand rig) and
``calibrate camera`` (the model station) from the board views, ``handeye`` from the arm's
joint angles and camera 1's board views, ``build`` of every garment into a model library
with the calibrated station camera, ``locate`` of the first garment in its scene with the
calibrated rig (with an overlay picture), ``identify`` in the last garment's scene, and
``pick`` of the first garment (the arm's joints when the scene was taken, the calibrated
hand-eye transform). Prints the estimated pose and grasp beside the true ones. Layout under
``--out``: ``data/`` (the dataset), ``calibration/`` (stereo.yaml, station.yaml,
hand_eye.yaml and their pictures), ``models/<name>.npz`` (the library, with previews),
``overlay.png``, ``pick.json``.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import shlex
from pathlib import Path
from typing import Any


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("demo", help="simulate a cell; calibrate, build, locate, pick and identify",
                       description="End-to-end demo on simulated data (no camera needed).")
    p.add_argument("--out", type=Path, default=Path("build/demo"), help="output directory")
    p.add_argument("--seed", type=int, default=3,
                   help="seed of the scenes and the searches, 0 to 4294967295 (default 3)")
    p.add_argument("--garments", "--garment", default="No.3,No.5,No.9",
                   help="catalogue garments, comma-separated (No.1 ... No.12); the first is "
                        "located, the last identified")
    p.add_argument("--calibration-views", type=int, default=12, metavar="N",
                   help="chessboard views per calibration set, 3 to 200 (default 12)")
    p.add_argument("--conditions", "--condition", default="paper",
                   help="simulated conditions, e.g. paper, wood+wrinkles (see simulate --help)")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    from photomodel.cli._main import main
    from photomodel.cli._options import check_seed
    from photomodel.sim import CALIBRATION_BOARD

    check_seed(args.seed)
    out: Path = args.out
    data, cal, library = out / "data", out / "calibration", out / "models"
    boards = data / "calibration"
    pattern = CALIBRATION_BOARD.pattern
    stereo, station, hand_eye = cal / "stereo.yaml", cal / "station.yaml", cal / "hand_eye.yaml"
    names = [g.strip() for g in args.garments.split(",") if g.strip()]
    steps = [
        ["simulate", "--out", str(data), "--garments", ",".join(names), "--conditions",
         args.conditions, "--scenes", "1", "--seed", str(args.seed), "--calibration-views",
         str(args.calibration_views), "--force"],
        ["calibrate", "stereo", "--pairs", str(boards / "pairs"), "--pattern", pattern,
         "--out", str(stereo)],
        ["calibrate", "camera", "--images", str(boards / "station" / "views"), "--plane",
         str(boards / "station" / "plane.png"), "--pattern", pattern, "--out", str(station)],
        ["handeye", "--pairs", str(boards / "handeye" / "pairs.json"), "--stereo", str(stereo),
         "--out", str(hand_eye)],
    ]
    steps += [["build", "--photo", str(data / "models" / g / "photo.bmp"),
               "--background", str(data / "models" / g / "background.bmp"),
               "--camera", str(station), "--out", str(library / f"{g}.npz"), "--name", g]
              for g in names]
    for argv in steps:
        code, _ = _step(main, argv)
        if code:
            return code
    truth = json.loads((data / "truth.json").read_text())
    scenes = {facts["model"]: scene_id for scene_id, facts in truth.items()}
    first, last = names[0], names[-1]
    scene = data / "scenes" / scenes[first]
    code, text = _step(main, [
        "locate", "--model", str(library / f"{first}.npz"), "--stereo", str(stereo),
        "--right", str(scene / "right.png"), "--left", str(scene / "left.png"),
        "--seed", str(args.seed), "--json", "--overlay", str(out / "overlay.png")])
    if code:
        return code
    _compare(scenes[first], json.loads(text), truth[scenes[first]])
    joints = json.loads((boards / "handeye" / "photo_joints.json").read_text())["joints_deg"]
    code, text = _step(main, [
        "pick", "--model", str(library / f"{first}.npz"), "--stereo", str(stereo),
        "--right", str(scene / "right.png"), "--left", str(scene / "left.png"),
        "--hand-eye", str(hand_eye), "--joints-deg", *[f"{q:.6f}" for q in joints],
        "--seed", str(args.seed), "--out", str(out / "pick.json")], echo=False)
    if code:
        return code
    _compare_pick(json.loads(text), truth[scenes[first]], boards / "truth.json")
    scene = data / "scenes" / scenes[last]
    code, text = _step(main, [
        "identify", "--models", str(library), "--stereo", str(stereo),
        "--right", str(scene / "right.png"), "--left", str(scene / "left.png"),
        "--seed", str(args.seed), "--json"])
    if code:
        return code
    answer = json.loads(text)
    print(f"\nidentify in scene {scenes[last]}: {answer['model']} (truth {last}), score "
          f"{answer['score']:.3f}, runner-up {answer['runner_up']['model']}")
    print(f"\ncalibrations: {cal}/*.yaml (coverage and error pictures beside them); overlay: "
          f"{out / 'overlay.png'}; model previews: {library}/*.preview.png; pick plan: "
          f"{out / 'pick.json'}")
    return 0


def _compare_pick(plan: dict[str, Any], facts: dict[str, Any], calibration_truth: Path
                  ) -> None:
    """Print the planned grasp (the model's origin in the base frame) beside the truth."""
    import numpy as np

    from photomodel.robot import forward_kinematics, load_arm

    cal = json.loads(calibration_truth.read_text())
    q = np.radians(cal["photo_joints_deg"])
    T_true = (forward_kinematics(load_arm(cal["arm"]), q) @ np.array(cal["T_hand_cam1"])
              @ np.array(facts["T_cam1_model"]))
    est = np.array(plan["T_base_model"])[:3, 3]
    print(f"pick: garment origin in the base frame ({est[0]:.1f}, {est[1]:.1f}, {est[2]:.1f}) "
          f"mm, {np.linalg.norm(est - T_true[:3, 3]):.2f} mm from the truth; "
          f"{len(plan.get('waypoints', []))} waypoints, plan in pick.json")


def _compare(scene_id: str, est: dict[str, Any], facts: dict[str, Any]) -> None:
    """Print the located pose beside the truth."""
    import numpy as np

    from photomodel.geometry import in_plane_angle_rad

    T_true = np.array(facts["T_cam1_model"])
    T_est = np.array(est["T_cam1_model"])
    th_true = float(np.rad2deg(in_plane_angle_rad(T_true)))
    err = T_est[:3, 3] - T_true[:3, 3]
    print(f"\nscene {scene_id} (camera 1 frame)   x mm      y mm      z mm   theta deg")
    print(f"estimated {_row(T_est[:3, 3], est['theta_deg'])}")
    print(f"true      {_row(T_true[:3, 3], th_true)}")
    print(f"error     {_row(err, est['theta_deg'] - th_true)}")
    print(f"found={est['found']} score={est['score']:.3f} in {est['seconds']:.2f} s")


def _step(main, argv: list[str], echo: bool = True  # type: ignore[no-untyped-def]
          ) -> tuple[int, str]:
    """Run one ``photomodel`` command, echoing it and (``echo``) its standard output."""
    print(f"\n$ photomodel {shlex.join(argv)}")
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        code = main(argv)
    text = buf.getvalue()
    if echo:
        print(text.rstrip())
    return code, text


def _row(xyz: Any, theta: float) -> str:
    return f"{xyz[0]:9.2f} {xyz[1]:9.2f} {xyz[2]:9.2f} {theta:11.2f}"
