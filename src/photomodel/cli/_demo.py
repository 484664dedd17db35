"""``photomodel demo``: an end-to-end run on built-in (simulated) data.

Simulates a dataset (``photomodel simulate``: the garments' model photos, the stereo
calibration, one stereo scene per garment with its truth), then runs the real commands on
those files: ``build`` of every garment into a model library, ``locate`` of the first garment
in its scene (with an overlay picture), and ``identify`` in the last garment's scene, and
prints the estimated pose beside the true one. Layout under ``--out``: ``data/`` (the
dataset), ``models/<name>.npz`` (the library, with previews), ``overlay.png``.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import shlex
from pathlib import Path
from typing import Any


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("demo", help="simulate scenes, build models, locate and identify",
                       description="End-to-end demo on simulated data (no camera needed).")
    p.add_argument("--out", type=Path, default=Path("build/demo"), help="output directory")
    p.add_argument("--seed", type=int, default=3,
                   help="seed of the scenes and the searches, 0 to 4294967295 (default 3)")
    p.add_argument("--garments", "--garment", default="No.3,No.5,No.9",
                   help="catalogue garments, comma-separated (No.1 ... No.12); the first is "
                        "located, the last identified")
    p.add_argument("--conditions", "--condition", default="paper",
                   help="simulated conditions, e.g. paper, wood+wrinkles (see simulate --help)")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    from photomodel.cli._main import main
    from photomodel.cli._options import check_seed

    check_seed(args.seed)
    out: Path = args.out
    data, library = out / "data", out / "models"
    names = [g.strip() for g in args.garments.split(",") if g.strip()]
    steps = [["simulate", "--out", str(data), "--garments", ",".join(names), "--conditions",
              args.conditions, "--scenes", "1", "--seed", str(args.seed), "--force"]]
    steps += [["build", "--photo", str(data / "models" / g / "photo.bmp"),
               "--background", str(data / "models" / g / "background.bmp"),
               "--camera", str(data / "model_camera.yaml"), "--out", str(library / f"{g}.npz"),
               "--name", g] for g in names]
    for argv in steps:
        code, _ = _step(main, argv)
        if code:
            return code
    truth = json.loads((data / "truth.json").read_text())
    scenes = {facts["model"]: scene_id for scene_id, facts in truth.items()}
    first, last = names[0], names[-1]
    scene = data / "scenes" / scenes[first]
    code, text = _step(main, [
        "locate", "--model", str(library / f"{first}.npz"), "--stereo", str(data / "stereo.yaml"),
        "--right", str(scene / "right.png"), "--left", str(scene / "left.png"),
        "--seed", str(args.seed), "--json", "--overlay", str(out / "overlay.png")])
    if code:
        return code
    _compare(scenes[first], json.loads(text), truth[scenes[first]])
    scene = data / "scenes" / scenes[last]
    code, text = _step(main, [
        "identify", "--models", str(library), "--stereo", str(data / "stereo.yaml"),
        "--right", str(scene / "right.png"), "--left", str(scene / "left.png"),
        "--seed", str(args.seed), "--json"])
    if code:
        return code
    answer = json.loads(text)
    print(f"\nidentify in scene {scenes[last]}: {answer['model']} (truth {last}), score "
          f"{answer['score']:.3f}, runner-up {answer['runner_up']['model']}")
    print(f"\noverlay: {out / 'overlay.png'}, model previews: {library}/*.preview.png")
    return 0


def _compare(scene_id: str, est: dict[str, Any], facts: dict[str, Any]) -> None:
    """Print the located pose beside the truth."""
    import numpy as np

    from photomodel.geometry import in_plane_angle_rad

    T_true = np.array(facts["T_cam1_model"])
    T_est = np.array(est["T_cam1_model"])
    th_true = float(np.rad2deg(in_plane_angle_rad(T_true)))
    err = T_est[:3, 3] - T_true[:3, 3]
    print(f"\nscene {scene_id} (camera 1 frame)   x mm      y mm      z mm   theta deg")
    print(f"estimated {_row(T_est[:3, 3], est['theta_deg'])}")
    print(f"true      {_row(T_true[:3, 3], th_true)}")
    print(f"error     {_row(err, est['theta_deg'] - th_true)}")
    print(f"found={est['found']} score={est['score']:.3f} in {est['seconds']:.2f} s")


def _step(main, argv: list[str]) -> tuple[int, str]:  # type: ignore[no-untyped-def]
    """Run one ``photomodel`` command, echoing it and its standard output."""
    print(f"\n$ photomodel {shlex.join(argv)}")
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        code = main(argv)
    text = buf.getvalue()
    print(text.rstrip())
    return code, text


def _row(xyz: Any, theta: float) -> str:
    return f"{xyz[0]:9.2f} {xyz[1]:9.2f} {xyz[2]:9.2f} {theta:11.2f}"
