"""``photomodel demo``: an end-to-end run on built-in (simulated) data.

Simulates a dataset (``photomodel simulate``: one catalogue garment's model photos, the stereo
calibration and one stereo scene with its truth), then runs the real ``build`` and ``locate``
commands on those files and prints the estimated pose beside the true one.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import shlex
from pathlib import Path

import numpy as np

from photomodel.geometry import in_plane_angle_rad


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("demo", help="simulate a scene, build its model, locate it, compare",
                       description="End-to-end demo on simulated data (no camera needed).")
    p.add_argument("--out", type=Path, default=Path("build/demo"), help="output directory")
    p.add_argument("--seed", type=int, default=3, help="seed of the scene and the search")
    p.add_argument("--garment", default="No.1", help="catalogue garment (No.1 ... No.12)")
    p.add_argument("--conditions", default="paper",
                   help="simulated conditions, e.g. paper, wood+wrinkles (see simulate --help)")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    from photomodel.cli._main import main

    out: Path = args.out
    data = out / "dataset"
    name = args.garment
    model = out / f"{name}.npz"
    steps = [
        ["simulate", "--out", str(data), "--garments", name, "--conditions", args.conditions,
         "--scenes", "1", "--seed", str(args.seed), "--force"],
        ["build", "--photo", str(data / "models" / name / "photo.bmp"),
         "--background", str(data / "models" / name / "background.bmp"),
         "--camera", str(data / "model_camera.yaml"), "--out", str(model), "--name", name],
    ]
    outputs = [_step(main, argv) for argv in steps]
    if any(code for code, _ in outputs):
        return next(code for code, _ in outputs if code)
    truth = json.loads((data / "truth.json").read_text())
    scene_id, facts = next(iter(truth.items()))
    scene = data / "scenes" / scene_id
    code, text = _step(main, [
        "locate", "--model", str(model), "--stereo", str(data / "stereo.yaml"),
        "--right", str(scene / "right.png"), "--left", str(scene / "left.png"),
        "--seed", str(args.seed), "--json", "--overlay", str(out / "overlay.png")])
    if code:
        return code
    est = json.loads(text)
    T_true = np.array(facts["T_cam1_model"])
    T_est = np.array(est["T_cam1_model"])
    th_true = float(np.rad2deg(in_plane_angle_rad(T_true)))
    err = T_est[:3, 3] - T_true[:3, 3]
    print(f"\nscene {scene_id} (camera 1 frame)   x mm      y mm      z mm   theta deg")
    print(f"estimated {_row(T_est[:3, 3], est['theta_deg'])}")
    print(f"true      {_row(T_true[:3, 3], th_true)}")
    print(f"error     {_row(err, est['theta_deg'] - th_true)}")
    print(f"\nfound={est['found']} score={est['score']:.3f} in {est['seconds']:.2f} s; "
          f"overlay: {out / 'overlay.png'}, model preview: {model.with_suffix('.preview.png')}")
    return 0


def _step(main, argv: list[str]) -> tuple[int, str]:  # type: ignore[no-untyped-def]
    """Run one ``photomodel`` command, echoing it and its standard output."""
    print(f"\n$ photomodel {shlex.join(argv)}")
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        code = main(argv)
    text = buf.getvalue()
    print(text.rstrip())
    return code, text


def _row(xyz: np.ndarray, theta: float) -> str:
    return f"{xyz[0]:9.2f} {xyz[1]:9.2f} {xyz[2]:9.2f} {theta:11.2f}"
