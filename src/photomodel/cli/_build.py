"""``photomodel build``: a model file and preview PNG from a station photo (photo, background,
camera), from the hand cameras' stereo pair where the garment lies (``--stereo``), or from a
photo of unknown scale (``--scale unknown``)."""

from __future__ import annotations

import argparse
import math
from pathlib import Path
from typing import Any

from photomodel.cli._options import add_stereo_options
from photomodel.errors import InputError

MODEL_SUFFIXES = (".npz", ".model")
_OPTIONS = {"step_mm": "--step-mm", "band_gap_mm": "--band-gap-mm",
            "band_width_mm": "--band-width-mm", "hue_threshold_deg": "--hue-threshold-deg",
            "distance_mm": "--distance-mm"}


def add_parser(sub: argparse._SubParsersAction) -> None:
    from photomodel.model import BUILD_RANGES, DEFAULT_STATION_DISTANCE_MM, BuildConfig

    d = BuildConfig()

    def span(key: str) -> str:
        lo, hi = BUILD_RANGES[key]
        return f"{lo:g} to {hi:g}, default {getattr(d, key):g}"

    p = sub.add_parser("build", help="build a photo-model from a garment photo",
                       description="Build a photo-model (paper sec. 2.2) from a photo of the "
                                   "garment on the green plane and a photo of the plane alone "
                                   "(--photo --background --camera); from the hand cameras' "
                                   "stereo pair of the garment where it lies (--stereo --right "
                                   "--left [--empty-right --empty-left]); or from a photo of "
                                   "unknown scale (--scale unknown --photo [--background]), "
                                   "whose first locate measures its scale.")
    p.add_argument("--photo", type=Path, help="garment on the plane (BMP, PNG..)")
    p.add_argument("--background", type=Path, help="the plane alone")
    p.add_argument("--camera", type=Path,
                   help="model camera calibration (OpenCV YAML/XML/JSON or ROS camera_info)")
    add_stereo_options(p, required=False, prefix="in place: ")
    p.add_argument("--empty-right", type=Path,
                   help="in place: camera 1's image of the table without the garment")
    p.add_argument("--empty-left", type=Path,
                   help="in place: camera 2's image of the table without the garment")
    p.add_argument("--scale", choices=("known", "unknown"), default="known",
                   help="unknown: a photo with no calibration; the first locate measures the "
                        "scale (photomodel models set-scale stores it)")
    p.add_argument("--distance-mm", type=float, default=None,
                   help="camera-to-plane distance (default: the camera file's distance_mm, "
                        f"else {DEFAULT_STATION_DISTANCE_MM:g})")
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
    from photomodel._limits import MAX_DISTANCE_MM
    from photomodel.cli._options import as_option_error, check_float
    from photomodel.library import check_model_name
    from photomodel.model import BuildConfig

    mode = _mode(args)
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
    name = args.name or (args.out.stem if args.out.suffix.lower() in MODEL_SUFFIXES
                         else args.out.name)
    built, photo, extra = {"station": _station, "in place": _in_place,
                           "unknown scale": _unknown_scale}[mode](args, config, name)
    _write(args, built, photo, extra)
    return 0


def _mode(args: argparse.Namespace) -> str:
    """Which build the options ask for; a one-line error for a mix or a missing one."""
    stereo = [f for f in ("stereo", "right", "left", "empty_right", "empty_left")
              if getattr(args, f) is not None]
    if stereo:
        if args.scale == "unknown" or args.photo or args.background or args.camera:
            raise InputError("--stereo", "builds in place from the stereo pair: give "
                                         "--stereo --right --left (and --empty-right "
                                         "--empty-left), not --photo, --background, --camera "
                                         "or --scale unknown")
        for flag in ("stereo", "right", "left"):
            if getattr(args, flag) is None:
                raise InputError(f"--{flag}", "missing: a build in place needs --stereo, "
                                              "--right and --left")
        if (args.empty_right is None) != (args.empty_left is None):
            raise InputError("--empty-left" if args.empty_left is None else "--empty-right",
                             "missing: give both views of the empty table, or neither")
        return "in place"
    if args.photo is None:
        raise InputError("--photo", "missing: give --photo (with --background and --camera, "
                                    "or --scale unknown), or build in place with --stereo "
                                    "--right --left")
    if args.scale == "unknown":
        if args.camera is not None or args.distance_mm is not None:
            raise InputError("--camera" if args.camera is not None else "--distance-mm",
                             "a photo of unknown scale has no calibration; drop it, or "
                             "build with --scale known")
        return "unknown scale"
    for flag in ("background", "camera"):
        if getattr(args, flag) is None:
            raise InputError(f"--{flag}", "missing: a station build needs --photo, "
                                          "--background and --camera (or --scale unknown)")
    return "station"


def _station(args: argparse.Namespace, config: Any, name: str) -> tuple[Any, Any, str]:
    from photomodel._limits import MAX_DISTANCE_MM
    from photomodel.camera import load_camera, load_distance_mm
    from photomodel.cli._options import as_option_error
    from photomodel.image import read_color_image
    from photomodel.model import DEFAULT_STATION_DISTANCE_MM, build_photo_model

    camera = load_camera(args.camera)
    distance = args.distance_mm if args.distance_mm is not None else load_distance_mm(args.camera)
    distance = DEFAULT_STATION_DISTANCE_MM if distance is None else distance
    if not (math.isfinite(distance) and 0 < distance <= MAX_DISTANCE_MM):
        raise InputError(args.camera, f"distance_mm: expected a distance above 0 to "
                                      f"{MAX_DISTANCE_MM:g} mm, got {distance:g}")
    photo = read_color_image(args.photo)
    background = read_color_image(args.background)
    try:
        built = build_photo_model(photo, background, camera, distance, name=name,
                                  config=config,
                                  photo_source=args.photo, background_source=args.background)
    except ValueError as exc:   # an InputError (names its file) passes unchanged
        raise as_option_error(exc, _OPTIONS, str(args.photo)) from None
    return built, photo, ""


def _in_place(args: argparse.Namespace, config: Any, name: str
              ) -> tuple[Any, Any, str]:
    import warnings

    from photomodel.camera import load_stereo
    from photomodel.cli._options import as_option_error
    from photomodel.image import read_color_image
    from photomodel.model import build_in_place

    rig = load_stereo(args.stereo)
    views = [read_color_image(p) if p is not None else None
             for p in (args.right, args.left, args.empty_right, args.empty_left)]
    sources = tuple(str(p) for p in (args.right, args.left, args.empty_right or "empty-right",
                                     args.empty_left or "empty-left"))
    try:
        with warnings.catch_warnings():      # the table is no green plane: reported below
            warnings.simplefilter("ignore")
            made = build_in_place(rig, views[0], views[1],
                                  empty_right_bgr=views[2], empty_left_bgr=views[3],
                                  name=name, config=config,
                                  sources=sources)
    except ValueError as exc:
        raise as_option_error(exc, _OPTIONS, str(args.right)) from None
    plane = made.plane
    extra = (f"; in place: {made.mm_per_px:.2f} mm/px, table plane at "
             f"{plane.distance_mm:.1f} mm (stereo rms {plane.rms_mm:.2f} mm, "
             f"{plane.points} pixels), garment wholly in view")
    return made.built, made.orthophoto_bgr, extra


def _unknown_scale(args: argparse.Namespace, config: Any, name: str
                   ) -> tuple[Any, Any, str]:
    import warnings

    from photomodel.cli._options import as_option_error
    from photomodel.image import read_color_image
    from photomodel.model import build_unknown_scale

    photo = read_color_image(args.photo)
    background = read_color_image(args.background) if args.background else None
    if background is not None and background.shape != photo.shape:
        raise InputError(args.background, f"size {background.shape[1]}x{background.shape[0]} "
                                          f"differs from the photo's {photo.shape[1]}x"
                                          f"{photo.shape[0]}")
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            built = build_unknown_scale(photo, background, name=name,
                                        config=config,
                                        photo_source=args.photo,
                                        background_source=args.background or "background")
    except ValueError as exc:
        raise as_option_error(exc, _OPTIONS, str(args.photo)) from None
    scale = built.model.meta["scale"]
    mm, shrink = scale["nominal_mm_per_px"], scale["photo_shrink"]
    if shrink < 1.0:                     # the build reduced the photo: its preview too
        import cv2

        h, w = photo.shape[:2]
        photo = cv2.resize(photo, (max(1, round(w * shrink)), max(1, round(h * shrink))),
                           interpolation=cv2.INTER_AREA)
    return built, photo, (f"; scale unknown (nominal {mm:.3f} mm/px): its first locate "
                         "measures it, then `photomodel models set-scale` stores it")


def _write(args: argparse.Namespace, built: Any, photo: Any, extra: str) -> None:
    """Save the model (and its preview) and print one line about it."""
    from photomodel.image import write_image
    from photomodel.model import render_preview, save_model

    model = built.model
    preview = None if args.no_preview else render_preview(photo, built)
    path = save_model(model, args.out)
    if preview is not None:
        write_image(path.with_suffix(".preview.png"), preview)
    quality = built.quality
    text = "" if quality is None else f", {quality.summary()}"
    unit = "mm" if "scale" not in model.meta else "nominal mm"
    print(f"{path}: model '{model.name}', {model.size_mm[0]:.0f} x {model.size_mm[1]:.0f} "
          f"{unit}, area {model.area_mm2:.0f} {unit}^2, S_in {model.n_in} points, S_out "
          f"{model.n_out} points{text}{extra}")
