"""``photomodel identify``: which model of a library is on the table, and its pose, or none."""

from __future__ import annotations

import argparse
import json
import warnings
from pathlib import Path
from typing import TYPE_CHECKING

from photomodel.cli._options import add_stereo_options, load_stereo_pair
from photomodel.errors import InputError

if TYPE_CHECKING:
    from photomodel.identify import LabelCheck, TableResult


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "identify", help="name the library model on the table and find its pose (or none)",
        description="Search every photo-model of a library directory in the images of the "
                    "hand's two cameras (camera 1 = right = reference); print the best model "
                    "with its pose T_cam1_model, or none when its score stays below the "
                    "calibrated threshold. A barcode, QR code or DataMatrix read in either "
                    "view is reported beside it (label), with the model the library's label "
                    "map names for it and whether that agrees (photomodel models label).")
    p.add_argument("--models", required=True, type=Path, help="model library directory")
    add_stereo_options(p)
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.add_argument("--seed", type=int, default=0, help="seed of the searches (default 0)")
    p.add_argument("--min-score", type=float, default=None,
                   help="accept the best model from this score (default: the calibrated, "
                        "stored threshold)")
    p.add_argument("--all", action="store_true",
                   help="every library garment in view (several, or two of one model), "
                        "which lies on which, and the order to pick them in")
    p.add_argument("--max-candidates", type=int, default=6,
                   help="most models verified by a pose search after the screen (default 6; "
                        "fewer are when the best is clearly ahead)")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    from photomodel.cli._models import warn_skipped
    from photomodel.cli._options import check_float
    from photomodel.identify import Identifier, IdentifyConfig
    from photomodel.library import LOOKED_FOR, ModelLibrary
    from photomodel.locate import threshold_path

    if args.min_score is not None:
        check_float("--min-score", args.min_score, 0.0, 1.0)
    try:
        config = IdentifyConfig(min_score=args.min_score, max_candidates=args.max_candidates)
    except ValueError as exc:
        raise InputError("--min-score/--max-candidates", str(exc)) from None
    library = ModelLibrary(args.models)
    rig, right, left = load_stereo_pair(args)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        identifier = Identifier(library, rig, config=config,
                                threshold=threshold_path(library=args.models))
    warn_skipped([str(w.message) for w in caught])
    if not len(identifier):
        raise InputError(args.models, "the library holds no usable photo-model (it looked "
                                      f"for {LOOKED_FOR})")
    if args.all:
        return _print_all(identifier.all(right, left, rng=args.seed), args.json,
                          len(identifier))
    result = identifier(right, left, rng=args.seed)
    if args.json:
        print(json.dumps(result.to_json_dict()))
        return 0
    runner = result.runner_up
    runner_text = ("none" if runner is None else f"{runner.model} (score {runner.score:.3f})")
    if result.found and result.best is not None:
        from photomodel.cli._locate import format_result

        print(format_result(result.best))
    else:
        best = "no model searched" if result.best is None else (
            f"best {result.best.model} at score {result.best.score:.3f}")
        print(f"model       none of the {len(identifier)} models is on the table ({best}, "
              f"threshold {result.min_score:.3f})")
    print(f"runner-up   {runner_text}")
    if result.label is not None:
        print(f"label       {_label_text(result.label)}")
    print(f"identify    {sum(c.result is not None for c in result.candidates)} of "
          f"{len(identifier)} models searched, {result.seconds:.2f} s")
    return 0


def _label_text(label: LabelCheck) -> str:
    """The label line of ``identify``'s text answer."""
    read = f"{label.read.text!r} ({label.read.format})"
    if label.model is None:
        return f"{read}: in no entry of the label map"
    if label.agrees:
        return f"{read} names {label.model}: agrees"
    seen = ("not located" if label.located is None else
            f"{'found' if label.found else 'not found'}, score {label.located.score:.3f}")
    return f"{read} names {label.model} ({seen}): DISAGREES with the photo-model's answer"


def _print_all(result: TableResult, as_json: bool, models: int) -> int:
    """Print ``identify --all``'s answer: one JSON object, or a line per garment."""
    if as_json:
        print(json.dumps(result.to_json_dict()))
        return 0
    if not result.garments:
        print(f"table       none of the {models} models is on the table "
              f"({result.unexplained_mm2:.0f} mm^2 of foreground unexplained)")
    for inst in result.pick_order:
        g = result.garments[inst]
        x, y, z = g.result.position_mm
        under = ", ".join(f"#{i}" for i in g.covered_by) or "nothing"
        print(f"pick {g.pick_rank + 1}      #{g.instance} {g.model}  score {g.result.score:.3f}"
              f"  visible {g.visible_fraction:.0%}  at ({x:.1f}, {y:.1f}, {z:.1f}) mm  theta "
              f"{g.result.theta_deg:.1f} deg  under: {under}")
    print(f"identify    {len(result.garments)} garment(s), {result.seconds:.2f} s")
    return 0
