"""``photomodel cell``: simulated orders end to end (model station, hand cameras, locate, pick)."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

from photomodel.cli._pick import add_layout_options, layout_and_settings
from photomodel.errors import InputError

MAX_ORDERS = 100_000
MAX_TABLES = 10_000
MAX_TOLERANCE_MM = 1000.0
MAX_BELT_MM_S = 500.0
MIN_FPS, MAX_FPS = 5.0, 240.0
_OPTIONS = {"orders": "--orders", "garments": "--garments", "hand_eye": "--hand-eye",
            "tolerance_mm": "--tolerance-mm", "condition": "--conditions",
            "seed": "--seed"}


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("cell", help="simulate pick-and-place orders end to end",
                       description="For each order: photograph the garment at the model station "
                                   "and build its photo-model, photograph the table (with other "
                                   "objects) from the PA10's hand, locate the garment, plan the "
                                   "pick and place, and compare the planned grasp point with "
                                   "the true centroid in the base frame.")
    p.add_argument("--orders", type=int, default=10,
                   help=f"number of orders (cycles), 1 to {MAX_ORDERS} (default 10)")
    p.add_argument("--garments", default=None,
                   help="catalogue garments, used in turn (default all); with --tables, the "
                        "number of garments on each table, 2 to 6 (default 4)")
    p.add_argument("--conditions", "--condition", dest="condition", default="distractors",
                   help="simulated conditions of the table shots, joined with '+' (e.g. "
                        "distractors+wrinkles; default distractors)")
    p.add_argument("--seed", type=int, default=0, help="seed, 0 to 4294967295 (default 0)")
    p.add_argument("--tolerance-mm", type=float, default=10.0,
                   help="grasp point within this distance of the truth counts as success, "
                        f"mm (above 0 to {MAX_TOLERANCE_MM:g}, default 10)")
    p.add_argument("--hand-eye", choices=("calibrated", "true"), default="calibrated",
                   help="plan with a simulated hand-eye calibration (default) or the true mount")
    add_layout_options(p)
    p.add_argument("--out", default=None, help="write every cycle and the summary as JSON")
    p.add_argument("--animate", default=None,
                   help="render the first planned cycle's motion to a .gif (or .mp4); with "
                        "--servo the first order's servoed pick and what camera 1 saw; with "
                        "--tables the first table's looks, picks and boxes")
    p.add_argument("--json", action="store_true", help="print the summary as one JSON object")
    tables = p.add_argument_group("clearing tables")
    tables.add_argument("--tables", type=int, default=None, metavar="K",
                        help="clear K tables instead of orders: look, pick the garment to "
                             "pick first, place it into its model's box, look again, until "
                             f"the table is empty (1 to {MAX_TABLES})")
    servo = p.add_argument_group("servoed picks from a conveyor")
    servo.add_argument("--servo", action="store_true",
                       help="pick each garment from a moving conveyor: the hand cameras track "
                            "it at camera rate while the arm approaches; reported against "
                            "open loop and belt-speed prediction on the same orders")
    servo.add_argument("--conveyor-mm-s", type=float, default=200.0,
                       help=f"belt speed with --servo, 0 to {MAX_BELT_MM_S:g} mm/s (default 200)")
    servo.add_argument("--fps", type=float, default=30.0,
                       help=f"camera and control rate with --servo, {MIN_FPS:g} to "
                            f"{MAX_FPS:g} frames per second (default 30)")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    from photomodel.cli._options import as_option_error, check_float, check_int, check_seed

    check_int("--orders", args.orders, 1, MAX_ORDERS)
    check_seed(args.seed)
    check_float("--tolerance-mm", args.tolerance_mm, 0.0, MAX_TOLERANCE_MM, lo_open=True,
                unit="mm")
    from photomodel.sim import expand_garments, parse_conditions

    if args.tables is not None:
        return _run_tables(args)
    try:
        garments = expand_garments(args.garments or "all")
    except ValueError as exc:
        raise InputError("--garments", str(exc)) from None
    try:
        parse_conditions(args.condition)
    except ValueError as exc:
        raise InputError("--conditions", str(exc)) from None

    from photomodel.cell import CellConfig, run_cell
    from photomodel.cli._progress import count_progress
    from photomodel.robot import animate_plan, check_animation_path

    animate = check_animation_path(args.animate) if args.animate else None
    layout, settings = layout_and_settings(args)
    try:
        config = CellConfig(orders=args.orders, garments=garments, condition=args.condition,
                            seed=args.seed, tolerance_mm=args.tolerance_mm,
                            link_set=args.link_set, hand_eye=args.hand_eye, layout=layout,
                            pick=settings)
    except ValueError as exc:
        raise as_option_error(exc, _OPTIONS, "cell") from None
    if args.servo:
        return _run_servo(args, config, animate)
    with count_progress("cell", enabled=sys.stderr.isatty()) as progress:
        report = run_cell(config, progress)
    if animate is not None and report.first_plan is not None:
        outcome = report.first_plan
        assert outcome.plan is not None
        animate_plan(report.setup.arm, outcome.plan, animate, layout=layout,
                     gripper=settings.gripper, outline_model_mm=outcome.model.outline_mm,
                     title=f"PA10-7C cell: order {outcome.record['order']}, "
                           f"{outcome.record['garment']}")
    s = report.summary
    if not _emit(args, report):
        e = s["grasp_error_mm_found"]
        print(f"{s['orders']} orders: found {s['found']}, plans reachable within limits "
              f"{s['plans_reachable_within_limits']}/{s['found']}, grasp within "
              f"{s['tolerance_mm']:g} mm {s['picked_within_tolerance']}/{s['orders']}; grasp "
              f"error (found) mean {_fmt(e['mean'])} sd {_fmt(e['sd'])} max {_fmt(e['max'])} mm")
    return 0


def _run_servo(args: argparse.Namespace, config: Any, animate: Path | None) -> int:
    """``cell --servo``: orders on a conveyor, open loop, belt-predicted and servoed."""
    from photomodel.cell import ServoSettings, animate_servo, run_servo_cell
    from photomodel.cli._options import check_float
    from photomodel.cli._progress import count_progress

    check_float("--conveyor-mm-s", args.conveyor_mm_s, 0.0, MAX_BELT_MM_S, unit="mm/s")
    check_float("--fps", args.fps, MIN_FPS, MAX_FPS, unit="frames per second")
    servo = ServoSettings(fps=args.fps, conveyor_mm_s=args.conveyor_mm_s)
    with count_progress("cell --servo", enabled=sys.stderr.isatty()) as progress:
        report = run_servo_cell(config, servo, progress, keep=0 if animate else None)
    if animate is not None and report.kept is not None and report.kept.ticks:
        r = report.kept.record
        animate_servo(report.setup.arm, report.setup.rig, report.kept, animate,
                      layout=config.layout, gripper=config.pick.gripper,
                      title=f"servoed pick: order {r['order']}, {r['garment']} on a belt at "
                            f"{servo.conveyor_mm_s:g} mm/s, camera at {servo.fps:g} fps")
    s = report.summary
    if _emit(args, report):
        return 0
    print(f"{s['orders']} orders on a belt at {servo.conveyor_mm_s:g} mm/s, found {s['found']}; "
          f"grasp error (mm) when the gripper closes:")
    for mode, a in s["aims"].items():
        e = a["grasp_error_mm"]
        print(f"  {mode:9s} closed {a['closed']}/{a['orders']}, within {s['tolerance_mm']:g} mm "
              f"{a['within_tolerance']}, mean {_fmt(e['mean'])} sd {_fmt(e['sd'])} "
              f"max {_fmt(e['max'])}")
    return 0


def _run_tables(args: argparse.Namespace) -> int:
    """``cell --tables K --garments N``: piles cleared into one box per model; ``--animate``
    draws the first table's looks."""
    from photomodel.cell import ClearConfig, animate_clear, run_clear
    from photomodel.cli._options import as_option_error, check_int
    from photomodel.cli._progress import count_progress
    from photomodel.sim import MAX_TABLE_GARMENTS, MIN_TABLE_GARMENTS, parse_conditions

    animate = _animation_path(args.animate) if args.animate else None
    check_int("--tables", args.tables, 1, MAX_TABLES)
    text = "4" if args.garments is None else str(args.garments).strip()
    if not text.isdigit():
        raise InputError("--garments", f"with --tables, expected the number of garments on "
                                       f"each table ({MIN_TABLE_GARMENTS} to "
                                       f"{MAX_TABLE_GARMENTS}), got {args.garments!r}")
    check_int("--garments", int(text), MIN_TABLE_GARMENTS, MAX_TABLE_GARMENTS)
    condition = "paper" if args.condition == "distractors" else args.condition
    try:
        parse_conditions(condition)
    except ValueError as exc:
        raise InputError("--conditions", str(exc)) from None
    layout, settings = layout_and_settings(args)
    try:
        config = ClearConfig(tables=args.tables, garments=int(text), condition=condition,
                             seed=args.seed, tolerance_mm=args.tolerance_mm,
                             hand_eye=args.hand_eye, layout=layout, pick=settings)
    except ValueError as exc:
        raise as_option_error(exc, {"tables": "--tables", "garments": "--garments"},
                              "cell") from None
    with count_progress("cell --tables", enabled=sys.stderr.isatty()) as progress:
        report = run_clear(config, progress, keep=0 if animate else None)
    if animate is not None and report.kept and report.setup is not None:
        animate_clear(report.kept, animate, rig=report.setup.rig, models=config.models,
                      layout=config.layout,
                      title=f"clearing a table of {config.garments} garments (seed "
                            f"{config.seed}): look, pick the first, place it into its box")
    s = report.summary
    if not _emit(args, report):
        e = s["grasp_error_mm"]
        print(f"{s['tables']} tables of {config.garments}: {s['placed']}/{s['garments']} "
              f"garments placed, {s['cleared']} tables cleared, {s['wrong_box']} in a wrong "
              f"box, {s['picked_covered']} picks of a covered garment; grasp error mean "
              f"{_fmt(e['mean'])} max {_fmt(e['max'])} mm; {s['seconds_per_garment']:.2f} s "
              "a garment")
    return 0


def _animation_path(path: str) -> Path:
    """``--animate``'s path (:func:`~photomodel.robot.check_animation_path`) in a folder that
    exists, or :class:`InputError` before any work."""
    from photomodel.robot import check_animation_path

    p = check_animation_path(path)
    if not p.parent.is_dir():
        raise InputError(p, f"folder {str(p.parent)!r} does not exist")
    return p


def _emit(args: argparse.Namespace, report: Any) -> bool:
    """Write ``--out`` (the run's metadata, summary and cycles) and print the summary as JSON
    with ``--json``; whether it was printed."""
    from photomodel.cell import write_json_atomic
    from photomodel.experiments import run_metadata

    if args.out:
        write_json_atomic(args.out, {**run_metadata(), **report.to_json_dict()})
    if args.json:
        print(json.dumps(report.summary))
    return bool(args.json)


def _fmt(x: float | None) -> str:
    return "-" if x is None else f"{x:.2f}"
