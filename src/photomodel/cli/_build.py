"""``photomodel build``: photo + background + camera -> model file and preview PNG."""

from __future__ import annotations

import argparse
import math
from pathlib import Path

from photomodel.errors import InputError

MODEL_SUFFIXES = (".npz", ".model")
_OPTIONS = {"step_mm": "--step-mm", "band_gap_mm": "--band-gap-mm",
            "band_width_mm": "--band-width-mm", "hue_threshold_deg": "--hue-threshold-deg",
            "distance_mm": "--distance-mm"}


def add_parser(sub: argparse._SubParsersAction) -> None:
    from photomodel.model._config import RANGES, BuildConfig

    d = BuildConfig()

    def span(key: str) -> str:
        lo, hi = RANGES[key]
        return f"{lo:g} to {hi:g}, default {getattr(d, key):g}"

    p = sub.add_parser("build", help="build a photo-model from a garment photo",
                       description="Build a photo-model (paper sec. 2.2) from a photo of the "
                                   "garment on the green plane and a photo of the plane alone.")
    p.add_argument("--photo", required=True, type=Path, help="garment on the plane (BMP, PNG..)")
    p.add_argument("--background", required=True, type=Path, help="the plane alone")
    p.add_argument("--camera", required=True, type=Path,
                   help="model camera calibration (OpenCV YAML/XML/JSON or ROS camera_info)")
    p.add_argument("--distance-mm", type=float, default=None,
                   help="camera-to-plane distance (default: the camera file's distance_mm, "
                        "else 400)")
    p.add_argument("--out", required=True, type=Path,
                   help="model file to write, at exactly this path (e.g. shirt.model)")
    p.add_argument("--name", default=None,
                   help="model name (default: the output file's name without .npz/.model)")
    p.add_argument("--step-mm", type=float, default=d.step_mm,
                   help=f"sampling pitch of S_in/S_out, mm ({span('step_mm')})")
    p.add_argument("--band-gap-mm", type=float, default=d.band_gap_mm,
                   help=f"gap between the outline and S_out, mm ({span('band_gap_mm')})")
    p.add_argument("--band-width-mm", type=float, default=d.band_width_mm,
                   help=f"width of the S_out band, mm ({span('band_width_mm')})")
    p.add_argument("--hue-threshold-deg", type=float, default=d.hue_threshold_deg,
                   help="hue error from the plane above which a pixel is garment, deg "
                        f"({span('hue_threshold_deg')})")
    p.add_argument("--hue-only", action="store_true",
                   help="the paper's rule alone: no per-pixel comparison with the background "
                        "photo (a region of the plane's colour is then lost; a plane without "
                        "hue is refused)")
    p.add_argument("--no-preview", action="store_true", help="do not write the preview PNG")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    from photomodel.camera import load_camera, load_distance_mm
    from photomodel.cli._options import as_option_error, check_float
    from photomodel.image import read_color_image, write_image
    from photomodel.library import check_model_name
    from photomodel.model import BuildConfig, build_photo_model, render_preview, save_model
    from photomodel.model._build import MAX_DISTANCE_MM

    if args.out.is_dir():
        raise InputError(args.out, "is a directory; --out names the model file to write")
    if args.distance_mm is not None:
        check_float("--distance-mm", args.distance_mm, 0.0, MAX_DISTANCE_MM, lo_open=True,
                    unit="mm")
    try:
        config = BuildConfig(step_mm=args.step_mm, band_gap_mm=args.band_gap_mm,
                             band_width_mm=args.band_width_mm,
                             hue_threshold_deg=args.hue_threshold_deg,
                             background_compare=not args.hue_only)
    except ValueError as exc:
        raise as_option_error(exc, _OPTIONS, "build") from None
    if args.name is not None:
        check_model_name(args.name, "--name")
    camera = load_camera(args.camera)
    distance = args.distance_mm if args.distance_mm is not None else load_distance_mm(args.camera)
    distance = 400.0 if distance is None else distance
    if not (math.isfinite(distance) and 0 < distance <= MAX_DISTANCE_MM):
        raise InputError(args.camera, f"distance_mm: expected a distance above 0 to "
                                      f"{MAX_DISTANCE_MM:g} mm, got {distance:g}")
    photo = read_color_image(args.photo)
    background = read_color_image(args.background)
    name = args.name or (args.out.stem if args.out.suffix.lower() in MODEL_SUFFIXES
                         else args.out.name)
    try:
        built = build_photo_model(photo, background, camera, distance, name=name, config=config,
                                  photo_source=args.photo, background_source=args.background)
    except ValueError as exc:   # an InputError (names its file) passes unchanged
        raise as_option_error(exc, _OPTIONS, str(args.photo)) from None
    preview = None if args.no_preview else render_preview(photo, built)
    path = save_model(built.model, args.out)
    if preview is not None:
        write_image(path.with_suffix(".preview.png"), preview)
    m = built.model
    quality = "" if built.quality is None else f", {built.quality.summary()}"
    print(f"{path}: model '{m.name}', {m.size_mm[0]:.0f} x {m.size_mm[1]:.0f} mm, "
          f"area {m.area_mm2:.0f} mm^2, S_in {m.n_in} points, S_out {m.n_out} points{quality}")
    return 0
