"""``photomodel track``: a model's pose through a stereo sequence, one line per frame."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Any

from photomodel.cli._options import add_stereo_options
from photomodel.errors import InputError, PhotomodelError

if TYPE_CHECKING:
    from photomodel.track import TrackResult

TIMING_FILES = ("truth.json", "meta.json")
"""Files of a sequence folder whose ``fps`` and per-frame ``t_s`` give the frames' times."""


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("track", help="follow a model's pose through a stereo sequence",
                       description="Track the pose T_cam1_model of a photo-model through a "
                                   "sequence of stereo pairs DIR/<frame>/right.png, left.png "
                                   "(frames in name order): a full locate on the first frame "
                                   "and after a loss, a local refinement from the predicted "
                                   "pose on the others. One line per frame (one JSON object "
                                   "with --json); a bad frame is one line on stderr and the "
                                   "exit code is 1.")
    p.add_argument("--model", required=True, type=Path, help="photo-model file")
    add_stereo_options(p, pair=False)
    p.add_argument("--frames", required=True, type=Path,
                   help="sequence folder: one sub-folder per frame with right.png, left.png")
    p.add_argument("--json", action="store_true", help="print one JSON object per frame")
    p.add_argument("--fps", type=float, default=None,
                   help="frame rate for the frames' times (default: the folder's truth.json "
                        "or meta.json, else 30)")
    p.add_argument("--seed", type=int, default=0, help="seed of the detections (default 0)")
    p.set_defaults(run=run)


def frame_folders(root: Path) -> list[Path]:
    """The frame folders of a sequence, in name order (those holding a right or left image).

    Raises
    ------
    InputError
        When ``root`` is not a folder or holds no frame.
    """
    if not root.is_dir():
        raise InputError(root, "expected a sequence folder (one sub-folder per frame)")
    frames = sorted(p for p in root.iterdir() if p.is_dir() and not p.name.startswith(".")
                    and ((p / "right.png").exists() or (p / "left.png").exists()))
    if not frames:
        raise InputError(root, "no frames: expected sub-folders with right.png and left.png")
    return frames


def frame_times(root: Path, fps: float | None) -> tuple[float, dict[str, float]]:
    """The frame rate and the per-frame times (s) of a sequence: ``--fps`` first, else the
    folder's truth.json / meta.json (``fps``, ``frames.<name>.t_s``), else 30 fps."""
    times: dict[str, float] = {}
    rate = fps
    for name in TIMING_FILES:
        path = root / name
        if not path.exists():
            continue
        try:
            doc = json.loads(path.read_text(encoding="utf-8"))
            frames = doc.get("frames", {}) if isinstance(doc, dict) else {}
            if rate is None and isinstance(doc, dict) and doc.get("fps") is not None:
                rate = float(doc["fps"])
            if fps is None:
                for key, value in frames.items():
                    if isinstance(value, dict) and value.get("t_s") is not None:
                        times[str(key)] = float(value["t_s"])
        except (ValueError, TypeError, AttributeError, OSError) as exc:
            raise InputError(path, f"unreadable timing file ({exc})") from None
        break
    rate = 30.0 if rate is None else rate
    if not (rate > 0 and rate < 1e6):
        raise InputError("--fps" if fps is not None else root,
                         f"expected a positive frame rate, got {rate:g}")
    return rate, times


def run(args: argparse.Namespace) -> int:
    from photomodel.cli._options import check_seed

    check_seed(args.seed)
    if args.fps is not None and not (args.fps > 0 and args.fps < 1e6):
        raise InputError("--fps", f"expected a positive frame rate, got {args.fps:g}")
    frames = frame_folders(args.frames)
    fps, times = frame_times(args.frames, args.fps)
    from photomodel.camera import load_stereo
    from photomodel.image import read_color_image
    from photomodel.model import load_model
    from photomodel.track import Tracker, TrackerConfig

    model = load_model(args.model)
    rig = load_stereo(args.stereo)
    tracker = Tracker(model, rig, config=TrackerConfig(fps=fps))
    bad = 0
    for k, folder in enumerate(frames):
        t_s = times.get(folder.name, k / fps)
        try:
            right = read_color_image(folder / "right.png")
            left = read_color_image(folder / "left.png")
            result = tracker(right, left, t_s=t_s, rng=args.seed + k)
        except PhotomodelError as exc:
            bad += 1
            print(f"photomodel: error: frame {folder.name}: {exc}", file=sys.stderr, flush=True)
            continue
        print(json.dumps(frame_json(folder.name, result)) if args.json
              else format_frame(folder.name, result), flush=True)
    return 1 if bad else 0


def frame_json(name: str, result: TrackResult) -> dict[str, Any]:
    """The ``track --json`` object of one frame: the frame folder's ``name`` and the
    result's fields (:meth:`~photomodel.track.TrackResult.to_json_dict`)."""
    return {"name": name, **result.to_json_dict()}


def format_frame(name: str, result: TrackResult) -> str:
    """One text line of a frame: name, mode, position, angle, score, time."""
    head = f"{name}  {result.mode:<6}"
    tail = f"  {1e3 * result.seconds:7.1f} ms" + (f"  ({result.note})" if result.note else "")
    if result.mode == "lost":
        return f"{head}  -" + tail
    x, y, z = result.position_mm
    return (f"{head}  x {x:8.2f}  y {y:8.2f}  z {z:8.2f} mm  theta {result.theta_deg:7.2f} "
            f"deg  score {result.score:.3f}  visible {result.visible:.2f}" + tail)
