"""``photomodel pick``: locate a garment from the hand's cameras and plan its pick and place."""

from __future__ import annotations

import argparse
import json
from typing import TYPE_CHECKING

from photomodel.cli._options import add_stereo_options, check_float, load_stereo_pair
from photomodel.errors import InputError
from photomodel.robot import available_link_sets

if TYPE_CHECKING:
    from photomodel.robot import CellLayout, PickSettings

BOX_CENTRE_MM = (150.0, -600.0, 0.0)
"""Defaults of the layout options (``CellLayout``'s, ``Gripper``'s and ``PickSettings``'s;
a test checks that they agree), written here so that ``--help`` loads no robot code."""
TCP_MM = 150.0
APPROACH_MM = 100.0
RETREAT_MM = 150.0


def add_layout_options(p: argparse.ArgumentParser) -> None:
    """Options of the cell's layout and the gripper, shared by ``pick`` and ``cell``."""
    p.add_argument("--link-set", default=None, choices=available_link_sets(),
                   help="PA10-7C link lengths (default 317-450-480-70)")
    p.add_argument("--box-mm", type=float, nargs=3, default=BOX_CENTRE_MM,
                   metavar=("X", "Y", "Z"), help="centre of the box floor, base frame")
    p.add_argument("--box-yaw-deg", type=float, default=0.0, help="box rotation about base z")
    p.add_argument("--box-size-mm", type=float, default=220.0, help="inner side of the box")
    p.add_argument("--tcp-mm", type=float, default=TCP_MM,
                   help="gripper closing point from the flange along the hand's z")
    p.add_argument("--approach-mm", type=float, default=APPROACH_MM,
                   help="pre-grasp height above the grasp point")
    p.add_argument("--retreat-mm", type=float, default=RETREAT_MM,
                   help="lift after grasping")


MAX_CELL_MM = 5000.0
"""Bound on the cell's lengths (box position and size, TCP, approach, retreat): the PA10-7C
reaches about 1 m."""


def layout_and_settings(args: argparse.Namespace,
                        grasp_mm: tuple[float, float] = (0.0, 0.0)
                        ) -> tuple[CellLayout, PickSettings]:
    from photomodel.robot import CellLayout, Gripper, PickSettings

    for i, axis in enumerate("xyz"):
        check_float(f"--box-mm ({axis})", args.box_mm[i], -MAX_CELL_MM, MAX_CELL_MM, unit="mm")
    check_float("--box-yaw-deg", args.box_yaw_deg, -360.0, 360.0, unit="deg")
    check_float("--box-size-mm", args.box_size_mm, 0.0, MAX_CELL_MM, lo_open=True, unit="mm")
    check_float("--tcp-mm", args.tcp_mm, 0.0, MAX_CELL_MM, unit="mm")
    check_float("--approach-mm", args.approach_mm, 0.0, MAX_CELL_MM, unit="mm")
    check_float("--retreat-mm", args.retreat_mm, 0.0, MAX_CELL_MM, unit="mm")
    try:
        layout = CellLayout(box_centre_mm=tuple(args.box_mm), box_yaw_deg=args.box_yaw_deg,
                            box_size_mm=args.box_size_mm)
        settings = PickSettings(grasp_point_mm=grasp_mm, approach_mm=args.approach_mm,
                                retreat_mm=args.retreat_mm, gripper=Gripper(args.tcp_mm))
    except ValueError as exc:
        raise InputError("cell layout", str(exc)) from None
    return layout, settings


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("pick", help="locate a garment and plan the PA10's pick and place",
                       description="Locate the model in the hand cameras' stereo pair, take "
                                   "its pose to the base frame (T_base_hand(q) @ T_hand_cam1 @ "
                                   "T_cam1_model) and plan the grasp and the placing into the "
                                   "box; prints the plan as JSON.")
    p.add_argument("--model", required=True,
                   help="photo-model file (.npz)")
    add_stereo_options(p)
    p.add_argument("--hand-eye", required=True, help="hand-eye file (key T_hand_cam1, mm)")
    pose = p.add_mutually_exclusive_group(required=True)
    pose.add_argument("--joints-deg", type=float, nargs="+", metavar="Q",
                      help="the arm's 7 joint angles when the images were taken, degrees")
    pose.add_argument("--hand-pose-mm", type=float, nargs=3, metavar=("X", "Y", "Z"),
                      help="hand (flange) position in the base frame instead of joints "
                           "(with --hand-rpy-deg)")
    p.add_argument("--hand-rpy-deg", type=float, nargs=3, default=(180.0, 0.0, 0.0),
                   metavar=("ROLL", "PITCH", "YAW"),
                   help="hand orientation (extrinsic x-y-z), default pointing down")
    grasp = p.add_mutually_exclusive_group()
    grasp.add_argument("--grasp-mm", type=float, nargs=2, metavar=("X", "Y"),
                       help="grasp point in the model frame (default 0 0 = the centroid)")
    grasp.add_argument("--grasp-px", type=float, nargs=2, metavar=("U", "V"),
                       help="grasp point as a pixel of the model photo")
    add_layout_options(p)
    p.add_argument("--seed", type=int, default=0, help="seed of the search and the IK")
    p.add_argument("--out", default=None, help="also write the plan JSON to this file")
    p.add_argument("--animate", default=None, help="render the motion to a .gif (or .mp4)")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    import numpy as np

    from photomodel.cell import grasp_point_from_photo_px, pick, write_json_atomic
    from photomodel.model import load_model
    from photomodel.robot import (
        animate_plan,
        check_animation_path,
        hand_pose_from_xyz_rpy,
        joints_for_hand_pose,
        load_arm,
        load_hand_eye,
    )

    animate = check_animation_path(args.animate) if args.animate else None
    arm = load_arm("pa10-7c", args.link_set)
    if args.joints_deg is not None:
        q = arm.check_joints(np.radians(args.joints_deg), "--joints-deg")
    else:
        q = joints_for_hand_pose(arm, hand_pose_from_xyz_rpy(args.hand_pose_mm,
                                                             args.hand_rpy_deg))
    T_hand_cam1 = load_hand_eye(args.hand_eye)
    model = load_model(args.model)
    grasp_mm = (tuple(args.grasp_mm) if args.grasp_mm is not None
                else grasp_point_from_photo_px(model, args.grasp_px)
                if args.grasp_px is not None else (0.0, 0.0))
    layout, settings = layout_and_settings(args, grasp_mm)  # type: ignore[arg-type]
    rig, right, left = load_stereo_pair(args)
    result = pick(model, rig, right, left, arm, q, T_hand_cam1, layout=layout,
                  settings=settings, rng=args.seed)
    data = {"arm": arm.name, "link_set": arm.link_set, "joints_deg": np.degrees(q).tolist(),
            **result.to_json_dict()}
    if animate is not None:
        animate_plan(arm, result.plan, animate, layout=layout, gripper=settings.gripper,
                     outline_model_mm=model.outline_mm, title=f"{arm.name}: {model.name}")
    if args.out:
        write_json_atomic(args.out, data)
    print(json.dumps(data))
    return 0
