"""``photomodel handeye``: camera 1's pose on the hand from robot poses and target views."""

from __future__ import annotations

import argparse
import json

from photomodel.cli._options import add_stereo_options
from photomodel.robot import available_link_sets

HAND_EYE_METHODS = ("andreff", "daniilidis", "horaud", "park", "tsai")
"""``cv2.calibrateHandEye``'s methods (``photomodel.robot.HAND_EYE_METHODS``'s names; a test
checks that they agree), written here so that ``--help`` loads no robot code."""


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("handeye", help="hand-eye calibration (T_hand_cam1) from pose pairs",
                       description="Calibrate camera 1's pose on the hand, T_hand_cam1, from "
                                   "pairs of robot poses (joint angles or hand poses) and "
                                   "observations of a fixed target (T_cam1_target poses or "
                                   "chessboard images), by cv2.calibrateHandEye. The pairs "
                                   "file is JSON: {\"pairs\": [{\"joints_deg\": [...] or "
                                   "\"T_base_hand\": 4x4, \"T_cam1_target\": 4x4 or \"image\": "
                                   "path}, ...], \"chessboard\": {\"inner_corners\": [9, 6], "
                                   "\"square_mm\": 25}}.")
    p.add_argument("--pairs", required=True, help="pairs file (JSON)")
    p.add_argument("--out", required=True, help="hand-eye file to write (.yaml, .xml, .json)")
    add_stereo_options(p, pair=False, required=False, prefix="for chessboard images: ")
    p.add_argument("--method", choices=HAND_EYE_METHODS, default="park",
                   help="cv2.calibrateHandEye method (default park)")
    p.add_argument("--link-set", default=None, choices=available_link_sets(),
                   help="PA10-7C link lengths for joint-angle pairs")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    from photomodel.camera import load_stereo
    from photomodel.robot import calibrate_hand_eye, load_arm, load_hand_eye_pairs, save_hand_eye

    arm = load_arm("pa10-7c", args.link_set)
    camera = load_stereo(args.stereo).cam1 if args.stereo else None
    pairs = load_hand_eye_pairs(args.pairs, arm, camera)
    result = calibrate_hand_eye(pairs.T_base_hand, pairs.T_cam1_target, args.method)
    save_hand_eye(args.out, result.T_hand_cam1,
                  {"method": result.method, "n_pairs": result.n_pairs,
                   "residual_mm": result.residual_mm, "residual_deg": result.residual_deg})
    if args.json:
        print(json.dumps(result.to_json_dict()))
    else:
        x, y, z = result.T_hand_cam1[:3, 3]
        print(f"T_hand_cam1 from {result.n_pairs} pairs ({result.method}, {result.backend}): "
              f"t = ({x:.2f}, {y:.2f}, {z:.2f}) mm; residual {result.residual_mm:.2f} mm, "
              f"{result.residual_deg:.3f} deg; written to {args.out}")
    return 0
