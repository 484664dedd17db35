"""``photomodel models list|add|remove|show|reindex|label|unlabel|labels|set-scale``: manage a
model library directory, its label map and the scale of its models of unknown scale."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from photomodel.library import LibraryEntry, Skipped


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("models", help="manage a model library (a directory of photo-models)",
                       description="List, add, remove and show the photo-models of a library "
                                   "directory: its model files, whatever their names (what "
                                   "photomodel build --out DIR/NAME.model writes; add copies "
                                   "a model in as DIR/<name>.npz), and DIR/index.json, which "
                                   "caches them and which the writers (add, remove, reindex) "
                                   "keep. Files that are not readable photo-models are skipped "
                                   "with a warning. Writers take turns (a lock file in DIR), "
                                   "so concurrent adds and removes keep every entry. "
                                   "DIR/labels.json, the label map (label, unlabel, labels), "
                                   "names the model a garment's barcode, QR code or "
                                   "DataMatrix stands for.")
    actions = p.add_subparsers(dest="action", required=True, metavar="ACTION")
    ls = actions.add_parser("list", help="the library's models: name, size, colours, dates")
    ls.add_argument("--models", required=True, type=Path, help="library directory")
    ls.add_argument("--json", action="store_true", help="print one JSON object")
    ls.set_defaults(run=run_list)
    add = actions.add_parser("add", help="copy a model file into the library")
    add.add_argument("--models", required=True, type=Path,
                     help="library directory (created if missing)")
    add.add_argument("model", type=Path, nargs="+", help="photo-model file(s) (.npz)")
    add.add_argument("--name", default=None, help="name in the library (one model only)")
    add.add_argument("--replace", action="store_true", help="replace a model of the same name")
    add.set_defaults(run=run_add)
    rm = actions.add_parser("remove", help="delete a model from the library")
    rm.add_argument("--models", required=True, type=Path, help="library directory")
    rm.add_argument("name", nargs="+", help="model name(s)")
    rm.set_defaults(run=run_remove)
    show = actions.add_parser("show", help="one model's index entry")
    show.add_argument("--models", required=True, type=Path, help="library directory")
    show.add_argument("name", help="model name")
    show.add_argument("--json", action="store_true", help="print one JSON object")
    show.set_defaults(run=run_show)
    index = actions.add_parser("reindex", help="write the index from the model files (a "
                                               "directory of built models opens faster)")
    index.add_argument("--models", required=True, type=Path, help="library directory")
    index.set_defaults(run=run_reindex)
    label = actions.add_parser(
        "label", help="let a label's code (barcode, QR code, DataMatrix) name a model",
        description="Store CODE -> NAME in the library's label map (DIR/labels.json): when "
                    "identify reads CODE on a garment, it names model NAME and says whether "
                    "the photo-model agrees. NAME must be a model of the library.")
    label.add_argument("--models", required=True, type=Path, help="library directory")
    label.add_argument("name", help="model name")
    label.add_argument("code", help="the label's text, as a reader reports it")
    label.add_argument("--replace", action="store_true",
                       help="move a code that names another model to this one")
    label.set_defaults(run=run_label)
    unlabel = actions.add_parser("unlabel", help="drop a code from the label map")
    unlabel.add_argument("--models", required=True, type=Path, help="library directory")
    unlabel.add_argument("code", nargs="+", help="label code(s)")
    unlabel.set_defaults(run=run_unlabel)
    labels = actions.add_parser("labels", help="the label map: code -> model")
    labels.add_argument("--models", required=True, type=Path, help="library directory")
    labels.add_argument("--json", action="store_true", help="print one JSON object")
    labels.set_defaults(run=run_labels)
    scale = actions.add_parser(
        "set-scale", help="store a model of unknown scale at its measured scale",
        description="A model built with --scale unknown has nominal millimetres until its "
                    "first locate measures the real scale from a stereo pair (locate --json "
                    "reports it as scale). set-scale stores the model at that scale, sampled "
                    "anew; its locates are then ordinary.")
    scale.add_argument("--models", required=True, type=Path, help="library directory")
    scale.add_argument("name", help="model name")
    given = scale.add_mutually_exclusive_group(required=True)
    given.add_argument("--from-result", type=Path,
                       help="a locate --json answer of this model that found it and measured "
                            "its scale")
    given.add_argument("--factor", type=float, help="real mm per nominal mm")
    scale.set_defaults(run=run_set_scale)


def warn_skipped(skipped: tuple[Skipped, ...] | list[Skipped] | list[str]) -> None:
    """One warning line on stderr per skipped file."""
    for s in skipped:
        print(f"photomodel: warning: {s}", file=sys.stderr)


def _colours(entry: LibraryEntry) -> str:
    return " ".join(f"{hex_}({100 * share:.0f}%)" for hex_, share in entry.colours)


def _entry_json(entry: LibraryEntry) -> dict[str, Any]:
    """The entry for people and scripts: its index fields without the descriptor (numbers
    for the screen, not for reading)."""
    d = entry.to_json_dict()
    d.pop("descriptor", None)
    return {"name": entry.name, **d}


def run_list(args: argparse.Namespace) -> int:
    from photomodel.library import LOOKED_FOR, ModelLibrary

    scan = ModelLibrary(args.models).scan()
    warn_skipped(scan.skipped)
    if args.json:
        print(json.dumps({"library": str(args.models),
                          "models": [_entry_json(e) for e in scan.entries],
                          "skipped": [{"file": str(s.path), "reason": s.reason}
                                      for s in scan.skipped]}))
        return 0
    if not scan.entries:
        print(f"{args.models}: no models (looked for {LOOKED_FOR})")
        return 0
    width = max(len(e.name) for e in scan.entries)
    for e in scan.entries:
        print(f"{e.name:<{width}}  {e.size_mm[0]:6.1f} x {e.size_mm[1]:6.1f} mm  "
              f"{_colours(e):<36}  added {e.added_utc}")
    print(f"{len(scan.entries)} model(s)")
    return 0


def run_add(args: argparse.Namespace) -> int:
    from photomodel.errors import InputError
    from photomodel.library import check_model_name

    if args.name is not None and len(args.model) > 1:
        raise InputError("--name", "give one model file with --name")
    if args.name is not None:
        check_model_name(args.name, "--name")
    from photomodel.library import ModelLibrary

    library = ModelLibrary(args.models, create=True)
    for path in args.model:
        entry = library.add(path, args.name, replace=args.replace)
        print(f"added {entry.name} ({entry.size_mm[0]:.1f} x {entry.size_mm[1]:.1f} mm) to "
              f"{args.models}/{entry.file}")
    return 0


def run_remove(args: argparse.Namespace) -> int:
    from photomodel.library import ModelLibrary

    library = ModelLibrary(args.models)
    for name in args.name:
        entry = library.remove(name)
        print(f"removed {entry.name} ({entry.file}) from {args.models}")
    return 0


def run_show(args: argparse.Namespace) -> int:
    from photomodel.library import ModelLibrary

    library = ModelLibrary(args.models)
    entry = library.entry(args.name)
    if args.json:
        print(json.dumps(_entry_json(entry)))
        return 0
    print("\n".join([
        f"name        {entry.name}",
        f"file        {args.models / entry.file} ({entry.file_bytes} bytes)",
        f"size        {entry.size_mm[0]:.1f} x {entry.size_mm[1]:.1f} mm, "
        f"area {entry.area_mm2:.0f} mm^2",
        f"colours     {_colours(entry)}",
        f"points      {entry.n_in} inside, {entry.n_out} in the band",
        f"built       {entry.created_utc or 'unknown'}",
        f"added       {entry.added_utc}",
    ]))
    return 0


def run_reindex(args: argparse.Namespace) -> int:
    from photomodel.library import ModelLibrary

    scan = ModelLibrary(args.models).reindex()
    warn_skipped(scan.skipped)
    print(f"indexed {len(scan.entries)} model(s) in {args.models}/index.json")
    return 0


def run_label(args: argparse.Namespace) -> int:
    from photomodel.library import ModelLibrary, check_label_code, check_model_name

    check_model_name(args.name, "NAME")
    check_label_code(args.code, "CODE")
    library = ModelLibrary(args.models)
    old = library.set_label(args.code, args.name, replace=args.replace)
    where = library.labels_path
    if old == args.name:
        print(f"label {args.code!r} already names {args.name} in {where}")
    elif old is not None:
        print(f"label {args.code!r} now names {args.name} (was {old}) in {where}")
    else:
        print(f"label {args.code!r} names {args.name} in {where}")
    return 0


def run_unlabel(args: argparse.Namespace) -> int:
    from photomodel.library import ModelLibrary

    library = ModelLibrary(args.models)
    for code in args.code:
        name = library.remove_label(code)
        print(f"removed label {code!r} (named {name}) from {library.labels_path}")
    return 0


def run_labels(args: argparse.Namespace) -> int:
    from photomodel.library import ModelLibrary

    library = ModelLibrary(args.models)
    labels = library.labels()
    if args.json:
        print(json.dumps({"library": str(args.models), "labels": labels}))
        return 0
    if not labels:
        print(f"{args.models}: no labels (photomodel models label --models {args.models} "
              "NAME CODE adds one)")
        return 0
    width = max(len(repr(c)) for c in labels)
    for code in sorted(labels):
        print(f"{code!r:<{width}}  {labels[code]}")
    print(f"{len(labels)} label(s)")
    return 0


def run_set_scale(args: argparse.Namespace) -> int:
    from photomodel._limits import read_capped
    from photomodel.errors import InputError
    from photomodel.library import ModelLibrary, check_model_name
    from photomodel.model import at_scale, confirmed_scale

    check_model_name(args.name, "NAME")
    factor, source = args.factor, f"factor {args.factor}"
    if args.from_result is not None:
        raw = read_capped(args.from_result, "locate result", 1 << 20)
        try:
            factor = confirmed_scale(json.loads(raw), args.name)
        except (UnicodeDecodeError, json.JSONDecodeError) as exc:
            raise InputError(args.from_result, f"not a locate --json answer ({exc})") from None
        except ValueError as exc:
            raise InputError(args.from_result, str(exc)) from None
        source = f"locate result {args.from_result.name}"
    library = ModelLibrary(args.models)
    model = library.load_entry(library.entry(args.name))
    try:
        scaled = at_scale(model, float(factor), source)
    except ValueError as exc:
        field, _, text = str(exc).partition(": ")
        raise InputError({"name": args.name, "factor": "--factor" if args.from_result is None
                          else args.from_result}[field], text) from None
    entry = library.add_model(scaled, replace=True)
    print(f"{args.name}: scale {float(factor):.5f} mm per nominal mm stored "
          f"({entry.size_mm[0]:.0f} x {entry.size_mm[1]:.0f} mm, {entry.n_in} points inside) "
          f"in {args.models}/{entry.file}")
    return 0
