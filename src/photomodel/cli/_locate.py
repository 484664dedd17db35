"""``photomodel locate``: the pose of a model in a stereo pair, as text or JSON."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from photomodel.camera import load_stereo
from photomodel.cli._progress import search_progress
from photomodel.errors import InputError
from photomodel.fitness import FITNESS_PRESETS
from photomodel.image import read_color_image, write_image
from photomodel.locate import (
    DEFAULT_FITNESS,
    DEFAULT_MIN_SCORE,
    LocateResult,
    draw_overlay,
    locate,
)
from photomodel.model import load_model
from photomodel.search import GAConfig, SearchSpace

IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff")


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("locate", help="find a model's 6-DoF pose in a stereo pair",
                       description="Search the pose T_cam1_model of a photo-model in the images "
                                   "of the hand's two cameras (camera 1 = right = reference).")
    p.add_argument("--model", required=True, type=Path, help="photo-model file (.npz)")
    p.add_argument("--stereo", required=True, type=Path, help="stereo calibration (K1, D1, ...)")
    p.add_argument("--right", required=True, type=Path, help="camera 1 (right) image")
    p.add_argument("--left", required=True, type=Path, help="camera 2 (left) image")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.add_argument("--seed", type=int, default=0, help="seed of the search (default 0)")
    p.add_argument("--optimizer", choices=("ga", "full", "rga", "cma", "de"), default="ga",
                   help="the paper's binary GA (default) or full grid search")
    p.add_argument("--fitness", choices=sorted([*FITNESS_PRESETS, "soft"]), default=DEFAULT_FITNESS,
                   help=f"fitness function (default {DEFAULT_FITNESS})")
    p.add_argument("--no-refine", action="store_true",
                   help="skip the local refinement after the global search")
    p.add_argument("--paper", action="store_true",
                   help="the paper's method as read here: paper fitness, plain binary GA "
                        "without restarts, no refinement")
    p.add_argument("--generations", type=int, default=GAConfig().max_generations,
                   help="GA: most generations")
    p.add_argument("--x-mm", type=float, nargs=2, default=(-255.0, 255.0), metavar=("LO", "HI"))
    p.add_argument("--y-mm", type=float, nargs=2, default=(-195.0, 195.0), metavar=("LO", "HI"))
    p.add_argument("--z-mm", type=float, nargs=2, default=(500.0, 900.0), metavar=("LO", "HI"))
    p.add_argument("--theta-deg", type=float, default=53.0, help="in-plane angle range +-")
    p.add_argument("--tilt-deg", type=float, default=10.0,
                   help="tilt range +-, from the table that faces the rig")
    p.add_argument("--min-score", type=float, default=None,
                   help="score in [0, 1] from which the garment counts as found (default: the "
                        f"calibrated threshold with the soft fitness, {DEFAULT_MIN_SCORE} with "
                        "the others)")
    p.add_argument("--overlay", type=Path, default=None,
                   help="write a PNG with the found outline on both images")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    if args.overlay is not None and args.overlay.suffix.lower() not in IMAGE_SUFFIXES:
        raise InputError(args.overlay, f"unknown image type; use one of {IMAGE_SUFFIXES}")
    if args.generations < 1:
        raise InputError("--generations", f"expected a positive count, got {args.generations}")
    try:
        ga = (GAConfig.paper if args.paper else GAConfig)(max_generations=args.generations)
    except ValueError as exc:
        raise InputError("--generations", str(exc)) from None
    model = load_model(args.model)
    rig = load_stereo(args.stereo)
    try:    # the tilt is measured from the table that faces the rig
        space = SearchSpace.from_ranges(tuple(args.x_mm), tuple(args.y_mm), tuple(args.z_mm),
                                        args.theta_deg, args.tilt_deg, rig.R_cam1_facing)
    except ValueError as exc:
        raise InputError("search space", str(exc)) from None
    right = read_color_image(args.right)
    left = read_color_image(args.left)
    rig.cam1.check_image(right, str(args.right))
    rig.cam2.check_image(left, str(args.left))
    with search_progress(f"locating {model.name}", enabled=sys.stderr.isatty()) as progress:
        result = locate(model, rig, right, left, optimizer=args.optimizer,
                        fitness="paper" if args.paper else args.fitness,
                        refine=not (args.paper or args.no_refine), rng=args.seed, space=space,
                        min_score=args.min_score, ga_config=ga, progress=progress)
    if args.overlay is not None:
        caption = (f"{model.name}: {'found' if result.found else 'NOT found'}  score "
                   f"{result.score:.2f}  xyz {format_xyz(result)} mm  theta "
                   f"{result.theta_deg:.2f} deg")
        write_image(args.overlay, draw_overlay(model, rig, right, left, result.A_cam1_model,
                                               caption))
    if args.json:
        print(json.dumps(result.to_json_dict()))
    else:
        print(format_result(result))
    return 0


def format_xyz(result: LocateResult) -> str:
    x, y, z = result.position_mm
    return f"{x:.2f} {y:.2f} {z:.2f}"


def format_result(result: LocateResult) -> str:
    """Human-readable summary of a locate result."""
    w, qx, qy, qz = result.quat_wxyz
    s = result.search
    lines = [
        f"model       {result.model}: {'found' if result.found else 'NOT found'} "
        f"(score {result.score:.3f}, fitness {result.fitness:.3g})",
        f"position    x {result.position_mm[0]:.2f}  y {result.position_mm[1]:.2f}  "
        f"z {result.position_mm[2]:.2f} mm (camera 1)",
        f"theta       {result.theta_deg:.2f} deg",
        f"quat_wxyz   {w:.5f} {qx:.5f} {qy:.5f} {qz:.5f}",
    ]
    if result.strain is not None:
        exx, eyy, exy = 100.0 * result.strain
        lines.append(f"strain      x {exx:+.2f} %  y {eyy:+.2f} %  shear {exy:+.2f} % "
                     "(the garment against its photo)")
    lines.append(f"search      {s.iterations} iterations, {s.evaluations} evaluations, "
                 f"{result.seconds:.2f} s ({s.stop_reason})")
    return "\n".join(lines)
