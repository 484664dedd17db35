"""``photomodel demo``: an end-to-end run on built-in (rendered) data.

Renders a dataset in the DESIGN.md layout (model photos, stereo calibration, one stereo
scene and its truth), then runs the real ``build`` and ``locate`` commands on those files
and prints the estimated pose beside the true one.
"""

from __future__ import annotations

import argparse
import json
import shlex
from pathlib import Path

import numpy as np

from photomodel.camera import save_camera, save_stereo
from photomodel.geometry import in_plane_angle_rad
from photomodel.image import write_image


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("demo", help="render a scene, build its model, locate it, compare",
                       description="End-to-end demo on rendered data (no camera needed).")
    p.add_argument("--out", type=Path, default=Path("build/demo"), help="output directory")
    p.add_argument("--seed", type=int, default=3, help="seed of the scene and the search")
    p.add_argument("--fabric", choices=("plaid", "plain"), default="plaid")
    p.set_defaults(run=run)


def write_demo_dataset(out: Path, seed: int, fabric: str) -> str:
    """Render one garment's model photos and one stereo scene into ``out`` (dataset layout)."""
    from photomodel.sim import (
        MODEL_DISTANCE_MM,
        hand_stereo_rig,
        make_garment,
        model_station_camera,
        random_stereo_scene,
        render_model_photos,
    )

    rng = np.random.default_rng(seed)
    name = f"tshirt-{fabric}"
    garment = make_garment("tshirt", fabric, (200.0, 160.0), rng=rng, name=name)
    camera = model_station_camera()
    photo, background = render_model_photos(garment, camera, rng)
    rig = hand_stereo_rig()
    scene = random_stereo_scene(garment, rig, rng)
    save_camera(out / "model_camera.yaml", camera, distance_mm=MODEL_DISTANCE_MM)
    save_stereo(out / "stereo.yaml", rig)
    write_image(out / "models" / name / "photo.bmp", photo)
    write_image(out / "models" / name / "background.bmp", background)
    write_image(out / "scenes" / "0000" / "right.png", scene.right_bgr)
    write_image(out / "scenes" / "0000" / "left.png", scene.left_bgr)
    truth = {"0000": {"model": name, "T_cam1_model": scene.T_cam1_model.tolist()}}
    (out / "truth.json").write_text(json.dumps(truth, indent=2))
    return name


def run(args: argparse.Namespace) -> int:
    from photomodel.cli._main import main

    out: Path = args.out
    print(f"demo: rendering a {args.fabric} T-shirt and one stereo scene into {out}/")
    name = write_demo_dataset(out, args.seed, args.fabric)
    model = out / f"{name}.npz"
    scene = out / "scenes" / "0000"
    steps = [
        ["build", "--photo", str(out / "models" / name / "photo.bmp"),
         "--background", str(out / "models" / name / "background.bmp"),
         "--camera", str(out / "model_camera.yaml"), "--out", str(model), "--name", name],
        ["locate", "--model", str(model), "--stereo", str(out / "stereo.yaml"),
         "--right", str(scene / "right.png"), "--left", str(scene / "left.png"),
         "--seed", str(args.seed), "--json", "--overlay", str(out / "overlay.png")],
    ]
    import contextlib
    import io

    outputs = []
    for argv in steps:
        print(f"\n$ photomodel {shlex.join(argv)}")
        buf = io.StringIO()
        with contextlib.redirect_stdout(buf):
            code = main(argv)
        text = buf.getvalue()
        print(text.rstrip())
        if code:
            return code
        outputs.append(text)
    est = json.loads(outputs[-1])
    T_true = np.array(json.loads((out / "truth.json").read_text())["0000"]["T_cam1_model"])
    T_est = np.array(est["T_cam1_model"])
    th_true = float(np.rad2deg(in_plane_angle_rad(T_true)))
    err = T_est[:3, 3] - T_true[:3, 3]
    print("\n               x mm      y mm      z mm   theta deg")
    print(f"estimated {_row(T_est[:3, 3], est['theta_deg'])}")
    print(f"true      {_row(T_true[:3, 3], th_true)}")
    print(f"error     {_row(err, est['theta_deg'] - th_true)}")
    print(f"\nfound={est['found']} score={est['score']:.3f} in {est['seconds']:.2f} s; "
          f"overlay: {out / 'overlay.png'}, model preview: {model.with_suffix('.preview.png')}")
    return 0


def _row(xyz: np.ndarray, theta: float) -> str:
    return f"{xyz[0]:9.2f} {xyz[1]:9.2f} {xyz[2]:9.2f} {theta:11.2f}"
