"""Shared data of the identification tests: three catalogue models and simulated scenes."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from photomodel.camera import StereoRig, save_stereo
from photomodel.model import PhotoModel, build_photo_model, save_model
from photomodel.sim import (
    MODEL_DISTANCE_MM,
    catalogue_garment,
    hand_stereo_rig,
    model_station_camera,
    parse_conditions,
    render_model_photos,
    simulate_scene,
)

LIBRARY = ("No.3", "No.5", "No.9")
"""Small, colourful and unlike each other: a light flower print, red dots, camouflage."""


@dataclass(frozen=True)
class IdentifyData:
    """Models, rig and two scenes (No.5 on the table; the empty table), also as files."""

    models: tuple[PhotoModel, ...]
    rig: StereoRig
    scene_right: np.ndarray
    scene_left: np.ndarray
    T_cam1_model: np.ndarray
    empty_right: np.ndarray
    empty_left: np.ndarray
    root: Path
    library: Path
    stereo: Path
    right: Path
    left: Path
    empty_right_path: Path
    empty_left_path: Path


def make_identify_data(root: Path) -> IdentifyData:
    camera = model_station_camera()
    models = []
    for k, name in enumerate(LIBRARY):
        photo, background = render_model_photos(catalogue_garment(name), camera, rng=10 + k)
        models.append(build_photo_model(photo, background, camera, MODEL_DISTANCE_MM,
                                        name=name).model)
    rig = hand_stereo_rig()
    shot = simulate_scene(catalogue_garment("No.5"), rig, parse_conditions("paper"), rng=5)
    empty = simulate_scene(None, rig, parse_conditions("empty"), rng=6)
    library = root / "library"
    library.mkdir()
    for m in models:
        save_model(m, library / f"{m.name}.npz")
    stereo = root / "stereo.yaml"
    save_stereo(stereo, rig)
    paths = {n: root / f"{n}.png" for n in ("right", "left", "empty_right", "empty_left")}
    for n, img in (("right", shot.right_bgr), ("left", shot.left_bgr),
                   ("empty_right", empty.right_bgr), ("empty_left", empty.left_bgr)):
        assert cv2.imwrite(str(paths[n]), img)
    assert shot.T_cam1_model is not None
    return IdentifyData(tuple(models), rig, shot.right_bgr, shot.left_bgr, shot.T_cam1_model,
                        empty.right_bgr, empty.left_bgr, root, library, stereo,
                        paths["right"], paths["left"], paths["empty_right"],
                        paths["empty_left"])
