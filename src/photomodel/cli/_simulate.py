"""``photomodel simulate``: write a simulated dataset directory (docs/contracts.md, "Dataset
directory"), or with ``--sequences`` stereo sequences with per-frame truth for a tracker."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from photomodel.errors import InputError


def add_parser(sub: argparse._SubParsersAction) -> None:
    from photomodel.sim import CONDITIONS

    p = sub.add_parser(
        "simulate", help="write a simulated dataset (model photos, stereo scenes, truth)",
        description="Simulate the paper's cell: model photos of catalogue garments at the model "
                    "station and stereo scenes of the hand cameras, with calibration files and "
                    "the true poses (truth.json).",
        epilog="conditions (join with '+', e.g. wood+wrinkles): " + ", ".join(CONDITIONS))
    p.add_argument("--out", required=True, type=Path, help="dataset directory to create")
    p.add_argument("--garments", default=None,
                   help="comma-separated catalogue names (No.1,...,No.12, look-alikes such as "
                        "No.3-red, plane-coloured ones such as green-print, articles of the "
                        "simulated catalogue cat-00000 to cat-99999) or groups: 'all' (the "
                        "paper's 12, default unless --catalogue is given), 'similar' "
                        "(look-alike pairs), 'plane-coloured' (garments partly or wholly of a "
                        "station plane's colour, each on its plane), 'catalogue:N' (the first "
                        "N articles of the simulated catalogue)")
    p.add_argument("--catalogue", type=int, default=None, metavar="N",
                   help="also write the model photos (no scenes) of the first N articles of "
                        "the simulated catalogue, cat-00000 ... (1 to 100000): random "
                        "garments of every shape, fabric and size, one in ten a look-alike of "
                        "the one before, to build model libraries of any size. About 1.8 MB "
                        "per article (1000 articles: 1.8 GB). Without --garments, no garment "
                        "scenes are written (target-less conditions such as no-target still "
                        "are)")
    p.add_argument("--scenes", type=int, default=None, metavar="N",
                   help="scenes per garment and condition, 1 to 10000 (default 1); with "
                        "--table, scenes per condition")
    p.add_argument("--table", type=int, default=None, metavar="N",
                   help="instead of one garment per scene, tables of N garments (2 to 6) "
                        "drawn from --garments, piled up in a known order, with the "
                        "distractors of the conditions: scenes/table<N>_<index>/, truth per "
                        "garment (pose, layer, visible fraction, covered by)")
    p.add_argument("--labels", action="store_true",
                   help="every garment carries a printed label (a QR code, DataMatrix or Code "
                        "128 of its article code, PM-<name>-NNNN or 10 digits, at a drawn "
                        "place and size: modules about 1.5 to 6 px wide in the hand cameras); "
                        "the truth gives each scene's label, its module width and corners "
                        "(needs zxing-cpp: pip install 'photomodel[labels]')")
    p.add_argument("--conditions", default=None,
                   help="comma-separated conditions, or 'all' for every named one "
                        "(default: paper)")
    p.add_argument("--seed", type=int, default=0,
                   help="seed of the dataset, 0 to 4294967295 (default 0)")
    p.add_argument("--add-garment", nargs=4, action="append", default=[],
                   metavar=("NAME", "IMAGE", "MASK", "WIDTH_MM"),
                   help="also simulate your own garment: a photo, its mask (nonzero = garment) "
                        "and the mask's width in mm; repeatable")
    p.add_argument("--force", action="store_true",
                   help="replace --out if it is a dataset that simulate wrote (never a file "
                        "or another directory)")
    p.add_argument("--calibration-views", type=int, default=0, metavar="N",
                   help="also write calibration/: N chessboard views (3 to 200) for each of "
                        "the stereo rig, the model station and the hand-eye calibration, with "
                        "their truth (default 0: none)")
    p.add_argument("--contact-sheet", type=Path, default=None, metavar="PNG",
                   help="also write a contact sheet of the dataset")
    seq = p.add_argument_group(
        "sequences", "instead of a dataset, write stereo sequences with per-frame truth for a "
                     "tracker: OUT/<kind>-<fps>fps/<frame>/right.png, left.png and truth.json, "
                     "with OUT/stereo.yaml and OUT/models/<garment>.npz (docs/contracts.md)")
    seq.add_argument("--sequences", default=None, metavar="KINDS",
                     help="comma-separated kinds: approach (the hand descends to 300 mm above "
                          "the garment), conveyor (the garment rides across the view), "
                          "occluder (a gripper sweeps over the garment), lost (the garment "
                          "is lifted out of view and put down elsewhere), or 'all'; "
                          "--garments names the one garment (default No.1)")
    seq.add_argument("--fps", default=None, metavar="LIST",
                     help="comma-separated frame rates, frames per second, each greater than "
                          "0 and at most 240 (default 30)")
    seq.add_argument("--seconds", type=float, default=None, metavar="S",
                     help="length of each sequence, s, greater than 0 and at most 600 "
                          "(default 2)")
    seq.add_argument("--conveyor-mm-s", type=float, default=None, metavar="V",
                     help="belt speed of a conveyor sequence, 100 to 300 mm/s (default 200)")
    p.set_defaults(run=run)


def _split(text: str) -> list[str]:
    return [t.strip() for t in text.split(",") if t.strip()]


_OPTIONS = {"scenes": "--scenes", "seed": "--seed", "garments": "--garments",
            "conditions": "--conditions", "calibration_views": "--calibration-views",
            "library": "--catalogue", "table": "--table", "label": "--labels"}


def run(args: argparse.Namespace) -> int:
    if args.sequences is not None:
        return _run_sequences(args)
    for option, value in (("--fps", args.fps), ("--seconds", args.seconds),
                          ("--conveyor-mm-s", args.conveyor_mm_s)):
        if value is not None:
            raise InputError(option, "applies only with --sequences")
    if args.scenes is None:
        args.scenes = 1
    if args.conditions is None:
        args.conditions = "paper"
    return _run_dataset(args)


def _run_dataset(args: argparse.Namespace) -> int:
    from photomodel.cli._options import as_option_error, check_int, check_seed
    from photomodel.cli._progress import count_progress
    from photomodel.image import write_image
    from photomodel.sim import (
        CONDITIONS,
        MAX_CATALOGUE,
        MAX_SCENES,
        catalogue_names,
        check_garment_name,
        contact_sheet,
        expand_garments,
        load_garment,
        parse_conditions,
        write_dataset,
    )

    check_int("--scenes", args.scenes, 1, MAX_SCENES)
    if args.table is not None:
        from photomodel.sim import MAX_TABLE_GARMENTS, MIN_TABLE_GARMENTS

        check_int("--table", args.table, MIN_TABLE_GARMENTS, MAX_TABLE_GARMENTS)
    library: tuple[str, ...] = ()
    if args.catalogue is not None:
        library = catalogue_names(check_int("--catalogue", args.catalogue, 1, MAX_CATALOGUE))
    check_seed(args.seed)
    if args.calibration_views != 0:
        from photomodel.sim import MAX_CALIBRATION_VIEWS, MIN_CALIBRATION_VIEWS

        if not MIN_CALIBRATION_VIEWS <= args.calibration_views <= MAX_CALIBRATION_VIEWS:
            raise InputError("--calibration-views",
                             f"expected 0 (none) or an integer from {MIN_CALIBRATION_VIEWS} "
                             f"to {MAX_CALIBRATION_VIEWS}, got {args.calibration_views}")
    given = args.garments if args.garments is not None else ("" if library else "all")
    try:
        garments = list(expand_garments(given))
    except ValueError as exc:
        raise InputError("--garments", str(exc)) from None
    if not garments and not args.add_garment and not library:
        raise InputError("--garments", "no garment named")
    conditions = list(CONDITIONS) if args.conditions == "all" else _split(args.conditions)
    for spec in conditions:
        try:
            parse_conditions(spec)
        except ValueError as exc:
            raise InputError("--conditions", str(exc)) from None
    extra = {}
    for name, image, mask, width in args.add_garment:
        try:
            check_garment_name(name)
        except ValueError as exc:
            raise InputError("--add-garment", str(exc).removeprefix("garments: ")) from None
        if name in garments or name in extra:
            raise InputError("--add-garment", f"garment name {name!r} is used twice")
        try:
            width_mm = float(width)
        except ValueError:
            raise InputError("--add-garment", f"WIDTH_MM must be a number, got {width!r}") from None
        extra[name] = load_garment(image, mask, width_mm, name)
    if args.contact_sheet is not None and args.contact_sheet.suffix.lower() != ".png":
        raise InputError(args.contact_sheet, "contact sheet must be a .png file")
    if args.labels:
        from photomodel.image import zxing

        zxing("--labels")   # one line before anything is simulated when it is missing
    try:
        if conditions == list(CONDITIONS) and args.conditions == "all":
            # Every named condition, but the lens presets need their own datasets.
            conditions = [c for c in conditions if c not in ("no-distortion", "wide-lens")]
            if args.table is not None:  # a table needs garments
                conditions = [c for c in conditions if parse_conditions(c).target]
        with count_progress("simulating", sys.stderr.isatty()) as progress:
            summary = write_dataset(args.out, garments, conditions, args.scenes, args.seed,
                                    extra_garments=extra, library=library,
                                    overwrite=args.force, progress=progress,
                                    calibration_views=args.calibration_views,
                                    table=args.table, labels=args.labels)
    except ValueError as exc:   # an InputError (names its file) passes unchanged
        raise as_option_error(exc, _OPTIONS, "--conditions" if "lens" in str(exc)
                              else str(args.out)) from None
    print(f"wrote {args.out}/: {len(summary.models)} model(s), {len(summary.scenes)} scene(s), "
          f"truth.json, stereo.yaml, model_camera.yaml")
    if args.calibration_views:
        print(f"calibration: {args.out}/calibration/ ({args.calibration_views} views per set; "
              "see its README.txt)")
    if args.contact_sheet is not None:
        write_image(args.contact_sheet, contact_sheet(args.out))
        print(f"contact sheet: {args.contact_sheet}")
    return 0


_SEQUENCE_OPTIONS = {"kinds": "--sequences", "kind": "--sequences", "fps": "--fps",
                     "seconds": "--seconds", "conveyor_mm_s": "--conveyor-mm-s",
                     "garment": "--garments", "seed": "--seed"}


def _frame_rates(text: str) -> list[float]:
    """The frame rates of an ``--fps`` value (``30,60``); InputError naming ``--fps``."""
    import math

    from photomodel.sim import MAX_FPS

    rates = []
    for part in _split(text):
        try:
            rate = float(part)
        except ValueError:
            raise InputError("--fps", f"expected frame rates separated by commas (30,60), "
                                      f"got {part!r}") from None
        if not (math.isfinite(rate) and 0 < rate <= MAX_FPS):
            raise InputError("--fps", f"expected frame rates greater than 0 and at most "
                                      f"{MAX_FPS:g}, got {part}")
        rates.append(rate)
    if not rates:
        raise InputError("--fps", "expected at least one frame rate")
    return rates


def _run_sequences(args: argparse.Namespace) -> int:
    """``simulate --sequences``: validate the options, then :func:`write_sequences`."""
    from photomodel.cli._options import as_option_error, check_float, check_seed
    from photomodel.cli._progress import count_progress
    from photomodel.sim import (
        CONVEYOR_MM_S_RANGE,
        MAX_SECONDS,
        SEQUENCE_KINDS,
        expand_garments,
        write_sequences,
    )

    for option, given in (("--scenes", args.scenes is not None),
                          ("--conditions", args.conditions is not None),
                          ("--catalogue", args.catalogue is not None),
                          ("--add-garment", bool(args.add_garment)),
                          ("--calibration-views", args.calibration_views != 0),
                          ("--table", args.table is not None),
                          ("--labels", args.labels),
                          ("--contact-sheet", args.contact_sheet is not None)):
        if given:
            raise InputError(option, "does not apply with --sequences (it writes sequences, "
                                     "not a dataset)")
    kinds = list(SEQUENCE_KINDS) if args.sequences.strip() == "all" else _split(args.sequences)
    if not kinds:
        raise InputError("--sequences", f"expected kinds separated by commas, of "
                                        f"{', '.join(SEQUENCE_KINDS)} or all")
    for kind in kinds:
        if kind not in SEQUENCE_KINDS:
            raise InputError("--sequences", f"unknown kind {kind!r}; known: "
                                            f"{', '.join(SEQUENCE_KINDS)} (or all)")
    rates = _frame_rates("30" if args.fps is None else args.fps)
    seconds = check_float("--seconds", 2.0 if args.seconds is None else args.seconds, 0.0,
                          MAX_SECONDS, lo_open=True, unit="s")
    speed = check_float("--conveyor-mm-s",
                        200.0 if args.conveyor_mm_s is None else args.conveyor_mm_s,
                        *CONVEYOR_MM_S_RANGE, unit="mm/s")
    check_seed(args.seed)
    try:
        garments = expand_garments("No.1" if args.garments is None else args.garments)
    except ValueError as exc:
        raise InputError("--garments", str(exc)) from None
    if len(garments) != 1:
        raise InputError("--garments", f"with --sequences, name one garment, got "
                                       f"{len(garments)}")
    try:
        with count_progress("simulating", sys.stderr.isatty()) as progress:
            summary = write_sequences(args.out, kinds, rates, seconds=seconds,
                                      garment=garments[0], seed=args.seed,
                                      conveyor_mm_s=speed, overwrite=args.force,
                                      progress=progress)
    except ValueError as exc:   # an InputError (names its file) passes unchanged
        raise as_option_error(exc, _SEQUENCE_OPTIONS, str(args.out)) from None
    print(f"wrote {args.out}/: {len(summary.sequences)} sequence(s) "
          f"({', '.join(summary.sequences)}), {summary.frames} frame(s), "
          f"{summary.model.relative_to(summary.out).as_posix()}, stereo.yaml")
    return 0
