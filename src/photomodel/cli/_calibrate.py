"""``photomodel calibrate stereo|camera``: calibration files from views of a chessboard."""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

_PATTERN_HELP = ("the target: chessboard:COLSxROWS:SQUARE_MM, COLS x ROWS inner corners (not "
                 "squares), squares SQUARE_MM wide, e.g. chessboard:9x6:25; or "
                 "charuco:COLSxROWS:SQUARE_MM:MARKER_MM:DICT, COLS x ROWS squares, e.g. "
                 "charuco:9x7:30:22:DICT_4X4_50 (OpenCV's aruco module)")
_FORMATS = (".yaml", ".yml", ".xml", ".json")


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("calibrate", help="calibrate the stereo rig or the model camera from "
                                         "chessboard views",
                       description="Calibration files from views of a printed chessboard "
                                   "(or ChArUco board), through OpenCV. Views in which the "
                                   "board is not found are listed and skipped. Beside the "
                                   "output file OUT.yaml it "
                                   "writes OUT.coverage.png (where the corners fell in each "
                                   "image) and OUT.errors.png (each view's RMS reprojection "
                                   "error).")
    commands = p.add_subparsers(dest="calibrate_command", required=True, metavar="TARGET")
    stereo = commands.add_parser(
        "stereo", help="the hand's stereo rig (camera 1 = right)",
        description="Calibrate the stereo rig from DIR/<id>/right.png and DIR/<id>/left.png, "
                    "simultaneous views of the chessboard: each camera's intrinsics "
                    "(cv2.calibrateCamera over every view in which it finds the board), then "
                    "R, T (cv2.stereoCalibrate over the pairs in which both do); camera 1 is "
                    "the right camera, X2 = R X1 + T, T in mm.")
    stereo.add_argument("--pairs", required=True, help="folder of pair folders <id>/right.png, "
                                                       "<id>/left.png")
    _common(stereo, "stereo calibration to write (.yaml, .xml or .json)")
    stereo.add_argument("--fix-intrinsics", action="store_true",
                        help="keep each camera's own intrinsics in the stereo fit (default: "
                             "the stereo fit refines them)")
    stereo.set_defaults(run=run_stereo)
    camera = commands.add_parser(
        "camera", help="the model station's camera and its distance to the plane",
        description="Calibrate the model station's camera from the views in DIR and measure "
                    "distance_mm, the depth of the model plane on the optical axis, from "
                    "PLANE.png, a view of the board lying flat on the plane.")
    camera.add_argument("--images", required=True, help="folder of chessboard views (PNG, BMP "
                                                        "or JPEG, taken in name order)")
    camera.add_argument("--plane", required=True, help="view of the board lying flat on the "
                                                       "model plane")
    _common(camera, "camera file to write (.yaml, .xml or .json)")
    camera.add_argument("--target-thickness-mm", type=float, default=0.0,
                        help="thickness of the board lying on the plane, mm (default 0)")
    camera.set_defaults(run=run_camera)


def _common(p: argparse.ArgumentParser, out_help: str) -> None:
    p.add_argument("--pattern", required=True, help=_PATTERN_HELP)
    p.add_argument("--out", required=True, help=out_help)
    p.add_argument("--distortion", type=int, choices=(4, 5, 8), default=4,
                   help="distortion coefficients fitted: 4 = k1 k2 p1 p2 with k3 fixed at 0 "
                        "(default; measured better when the views do not reach the image's "
                        "corners), 5 = k1 k2 p1 p2 k3, 8 = rational model")
    p.add_argument("--json", action="store_true", help="print one JSON object")


def _check_out(out: str) -> Path:
    from photomodel.errors import InputError

    p = Path(out)
    if p.suffix.lower() not in _FORMATS:
        raise InputError("--out", f"unknown calibration format {p.suffix or '(no suffix)'!r}; "
                                  "use .yaml, .xml or .json")
    if p.is_dir():
        raise InputError(p, "is a directory, not the calibration file to write")
    for parent in p.parents:  # checked before the calibration runs, not after
        if parent.exists():
            if not parent.is_dir():
                raise InputError(parent, "is a file, not a folder to write --out in")
            break
    return p


def _camera_line(label: str, cal: Any, camera: Any = None) -> str:
    K = (cal.camera if camera is None else camera).K
    return (f"{label}: {len(cal.views)} views, RMS {cal.rms_px:.3f} px; fx {K[0, 0]:.2f}, "
            f"fy {K[1, 1]:.2f}, cx {K[0, 2]:.2f}, cy {K[1, 2]:.2f} px; corners in "
            f"{100 * cal.coverage:.0f} % of the image")


def _skipped_lines(skipped: Any) -> list[str]:
    return [f"skipped {s.name}: {s.reason}" for s in skipped]


def run_stereo(args: argparse.Namespace) -> int:
    from photomodel.calibrate import calibrate_stereo_folder, parse_pattern, write_plots
    from photomodel.camera import save_stereo

    board = parse_pattern(args.pattern)
    out = _check_out(args.out)
    result = calibrate_stereo_folder(args.pairs, board, distortion=args.distortion,
                                     refine_intrinsics=not args.fix_intrinsics)
    coverage, errors = write_plots(out, result)
    save_stereo(out, result.rig)
    if args.json:
        print(json.dumps({**result.to_json_dict(), "out": str(out),
                          "coverage_png": str(coverage), "errors_png": str(errors)}))
        return 0
    skipped_views = [s for cal in (result.cam1, result.cam2) for s in cal.skipped]
    lines = [_camera_line("right (camera 1)", result.cam1, result.rig.cam1),
             _camera_line("left (camera 2)", result.cam2, result.rig.cam2),
             f"stereo: {len(result.pairs)} pairs, RMS {result.rms_px:.3f} px; baseline "
             f"{result.baseline_mm:.2f} mm, rotation "
             f"{result.to_json_dict()['rotation_deg']:.3f} deg"
             + ("" if result.refined_intrinsics else " (intrinsics fixed)"),
             "per-pair RMS (right, left) px: "
             + ", ".join(f"{n} {e[0]:.3f} {e[1]:.3f}"
                         for n, e in zip(result.pairs, result.per_pair_rms_px, strict=True)),
             *_skipped_lines(result.skipped if result.skipped else skipped_views),
             f"written to {out} (coverage: {coverage.name}, errors: {errors.name})"]
    print("\n".join(lines))
    return 0


def run_camera(args: argparse.Namespace) -> int:
    from photomodel.calibrate import calibrate_station_folder, parse_pattern, write_plots
    from photomodel.camera import save_camera
    from photomodel.cli._options import check_float

    board = parse_pattern(args.pattern)
    out = _check_out(args.out)
    thickness = check_float("--target-thickness-mm", args.target_thickness_mm, 0.0, 1000.0,
                            unit="mm")
    result, plane = calibrate_station_folder(args.images, args.plane, board,
                                             distortion=args.distortion, thickness_mm=thickness)
    coverage, errors = write_plots(out, result)
    save_camera(out, result.camera, plane.distance_mm)
    if args.json:
        print(json.dumps({**result.to_json_dict(), **plane.to_json_dict(), "out": str(out),
                          "coverage_png": str(coverage), "errors_png": str(errors)}))
        return 0
    lines = [_camera_line("camera", result),
             "per-view RMS px: " + ", ".join(
                 f"{n} {e:.3f}" for n, e in zip(result.views, result.per_view_rms_px,
                                                strict=True)),
             *_skipped_lines(result.skipped),
             f"plane: distance_mm {plane.distance_mm:.2f} (on the optical axis; "
             f"{plane.normal_distance_mm:.2f} mm perpendicular, tilt {plane.tilt_deg:.2f} deg, "
             f"RMS {plane.rms_px:.3f} px)",
             f"written to {out} (coverage: {coverage.name}, errors: {errors.name})"]
    print("\n".join(lines))
    return 0
