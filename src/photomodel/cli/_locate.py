"""``photomodel locate``: the pose of a model in a stereo pair, as text or JSON."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from photomodel.cli._options import add_stereo_options, load_stereo_pair
from photomodel.errors import InputError

if TYPE_CHECKING:
    from photomodel.locate import LocateResult

PAPER_FITNESSES = ("balanced", "paper")
"""The fitnesses a paper method may search (``photomodel.fitness.FITNESS_PRESETS``' names; a
test checks that they agree), written here so that ``--help`` loads no search code."""


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("locate", help="find a model's 6-DoF pose in a stereo pair",
                       description="Search the pose T_cam1_model of a photo-model in the images "
                                   "of the hand's two cameras (camera 1 = right = reference).")
    p.add_argument("--model", required=True, type=Path, help="photo-model file")
    add_stereo_options(p)
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.add_argument("--seed", type=int, default=0, help="seed of the search (default 0)")
    p.add_argument("--method", choices=("default", "paper"), default=None,
                   help="default: the soft fitness searched coarse to fine; paper: the paper's "
                        "fitness and binary GA")
    p.add_argument("--paper", action="store_true", help="the same as --method paper")
    paper = p.add_argument_group("paper method options (with --method paper)")
    paper.add_argument("--optimizer", choices=("ga", "full", "rga", "cma", "de"), default=None,
                       help="the paper's binary GA (default), full grid search, or a "
                            "comparison optimiser")
    paper.add_argument("--fitness", choices=PAPER_FITNESSES, default=None,
                       help="the paper's votes (default) or the balanced variant")
    paper.add_argument("--refine", action="store_true",
                       help="refine the global search's best pose locally")
    paper.add_argument("--generations", type=int, default=None, help="GA: most generations")
    p.add_argument("--x-mm", type=float, nargs=2, default=(-255.0, 255.0), metavar=("LO", "HI"))
    p.add_argument("--y-mm", type=float, nargs=2, default=(-195.0, 195.0), metavar=("LO", "HI"))
    p.add_argument("--z-mm", type=float, nargs=2, default=(500.0, 900.0), metavar=("LO", "HI"))
    p.add_argument("--theta-deg", type=float, default=53.0, help="in-plane angle range +-")
    p.add_argument("--tilt-deg", type=float, default=10.0,
                   help="tilt range +-, from the table that faces the rig")
    p.add_argument("--min-score", type=float, default=None,
                   help="score in [0, 1] from which the garment counts as found (default: the "
                        "calibrated threshold; 0.5 with --method paper)")
    p.add_argument("--threshold-file", type=Path, default=None,
                   help="threshold file to read the default --min-score from")
    p.add_argument("--overlay", type=Path, default=None,
                   help="write a PNG with the found outline on both images")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    paper = args.paper or args.method == "paper"
    if args.method == "default" and args.paper:
        raise InputError("--paper", "contradicts --method default")
    given = [f"--{k.replace('_', '-')}" for k in ("optimizer", "fitness", "generations")
             if getattr(args, k) is not None] + (["--refine"] if args.refine else [])
    if given and not paper:
        raise InputError(given[0], "applies to --method paper only")
    if args.generations is not None and args.generations < 1:
        raise InputError("--generations", f"expected a positive count, got {args.generations}")
    if args.min_score is not None:
        from photomodel.cli._options import check_float

        check_float("--min-score", args.min_score, 0.0, 1.0)
    from photomodel.image import IMAGE_SUFFIXES

    if args.overlay is not None and args.overlay.suffix.lower() not in IMAGE_SUFFIXES:
        raise InputError(args.overlay, f"unknown image type; use one of {IMAGE_SUFFIXES}")
    from photomodel.model import load_model

    model = load_model(args.model)
    rig, right, left = load_stereo_pair(args)

    from photomodel.locate import Locator, PaperMethod
    from photomodel.search import GAConfig, SearchSpace

    try:    # the tilt is measured from the table that faces the rig
        space = SearchSpace.from_ranges(tuple(args.x_mm), tuple(args.y_mm), tuple(args.z_mm),
                                        args.theta_deg, args.tilt_deg, rig.R_cam1_facing)
    except ValueError as exc:   # names the option and its range, in mm and deg
        from photomodel.cli._options import as_option_error

        raise as_option_error(exc, {"x_mm": "--x-mm", "y_mm": "--y-mm", "z_mm": "--z-mm",
                                    "theta_deg": "--theta-deg", "tilt_deg": "--tilt-deg"},
                              "search space") from None
    method: str | PaperMethod = "default"
    if paper:
        cap = {} if args.generations is None else {"max_generations": args.generations}
        try:
            method = PaperMethod(fitness=args.fitness or "paper",
                                 optimizer=args.optimizer or "ga", refine=args.refine,
                                 ga=GAConfig.paper(**cap))
        except ValueError as exc:
            raise InputError("--method paper", str(exc)) from None
    locator = Locator(model, rig, space, method,  # type: ignore[arg-type]
                      min_score=args.min_score, threshold=args.threshold_file)
    if paper and sys.stderr.isatty():
        from photomodel.cli._progress import search_progress

        with search_progress(f"locating {model.name}", enabled=True) as progress:
            result = locator(right, left, rng=args.seed, progress=progress)
    else:
        result = locator(right, left, rng=args.seed)
    if args.overlay is not None:
        from photomodel.image import write_image
        from photomodel.locate import draw_overlay

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
    if result.scale is not None:
        lines.append(f"scale       {result.scale:.5f} mm per nominal mm, measured from this pair "
                     "(store it: photomodel models set-scale)")
    lines.append(f"search      {s.iterations} iterations, {s.evaluations} evaluations, "
                 f"{result.seconds:.2f} s ({s.stop_reason})")
    return "\n".join(lines)
