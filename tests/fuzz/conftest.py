"""Fixtures of the loaders' fuzz tests: seed files, and the tallies written to
``build/fuzz_counts.json`` at the end of the session (inputs tried, accepted, refused with
InputError, and anything else, which must be 0)."""

from __future__ import annotations

import shlex
import sys
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
from fuzz_helpers import (
    CAMERA_INFO_MESSAGE,
    PLAIN_STEREO,
    ROS_CAMERA_INFO,
    Tally,
    read_archive,
    seed_images,
    write_counts,
)

from photomodel.camera import load_stereo, save_camera, save_stereo
from photomodel.model import build_photo_model, save_model
from photomodel.sim import (
    MODEL_DISTANCE_MM,
    hand_stereo_rig,
    make_garment,
    model_station_camera,
    render_model_photos,
)

COUNTS = Path(__file__).resolve().parents[2] / "build" / "fuzz_counts.json"
_TALLIES: dict[str, dict[str, Tally]] = {"short": {}, "long": {}}


@pytest.fixture(scope="session", autouse=True)
def _write_tallies() -> Iterator[None]:
    yield
    command = "python -m pytest " + shlex.join(sys.argv[1:])
    for profile, tallies in _TALLIES.items():
        if any(t.tried for t in tallies.values()):
            write_counts(COUNTS, profile, tallies, command)


@pytest.fixture(scope="session")
def tallies() -> dict[str, dict[str, Tally]]:
    return _TALLIES


@pytest.fixture(scope="session")
def calibration_seeds(tmp_path_factory: pytest.TempPathFactory) -> dict[str, bytes]:
    """Valid calibration files: the project's own stereo and camera files in each format,
    a plain-YAML stereo file, a ROS camera_info file and a CameraInfo message."""
    root = tmp_path_factory.mktemp("calibration_seeds")
    rig = hand_stereo_rig()
    seeds: dict[str, bytes] = {}
    for ext in ("yaml", "xml", "json"):
        save_stereo(root / f"stereo.{ext}", rig)
        save_camera(root / f"camera.{ext}", rig.cam1, distance_mm=400.0)
        seeds[f"stereo.{ext}"] = (root / f"stereo.{ext}").read_bytes()
        seeds[f"camera.{ext}"] = (root / f"camera.{ext}").read_bytes()
    seeds["plain_stereo.yaml"] = PLAIN_STEREO.encode()
    seeds["ros_camera.yaml"] = ROS_CAMERA_INFO.encode()
    seeds["camera_info.yaml"] = CAMERA_INFO_MESSAGE.encode()
    (root / "plain.yaml").write_bytes(seeds["plain_stereo.yaml"])
    load_stereo(root / "plain.yaml")  # the seeds are valid
    return seeds


@pytest.fixture(scope="session")
def image_seeds() -> dict[str, bytes]:
    return seed_images()


@pytest.fixture(scope="session")
def model_seed(tmp_path_factory: pytest.TempPathFactory
               ) -> tuple[bytes, dict[str, np.ndarray], dict]:
    """A small valid model (a 60 x 45 mm garment): its file, its arrays and metadata."""
    garment = make_garment("tshirt", "plain", (60.0, 45.0), rng=3)
    camera = model_station_camera()
    photo, background = render_model_photos(garment, camera, rng=4)
    built = build_photo_model(photo, background, camera, MODEL_DISTANCE_MM, name="seed")
    path = save_model(built.model, tmp_path_factory.mktemp("model_seed") / "seed.model")
    data = path.read_bytes()
    arrays, meta = read_archive(data)
    return data, arrays, meta
