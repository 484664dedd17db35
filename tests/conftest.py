"""Fixtures shared across test packages: rendered garments and their built photo-models."""

from __future__ import annotations

import os
import tempfile
from dataclasses import dataclass

import numpy as np
import pytest

from photomodel.camera import PinholeCamera, StereoRig
from photomodel.model import BuildResult, build_photo_model
from photomodel.sim import (
    MODEL_DISTANCE_MM,
    Garment,
    hand_stereo_rig,
    make_garment,
    model_station_camera,
    render_model_photos,
)

# The tests read the package's threshold, not a user's calibration in ~/.config.
os.environ["PHOTOMODEL_THRESHOLD"] = os.path.join(tempfile.gettempdir(),
                                                  "photomodel-tests-no-threshold.json")


@dataclass(frozen=True)
class GarmentCase:
    """A garment, its model-station photos and camera, the built model and the hand rig."""

    garment: Garment
    camera: PinholeCamera
    photo: np.ndarray
    background: np.ndarray
    built: BuildResult
    rig: StereoRig


def make_case(fabric: str, seed: int, size_mm: tuple[float, float] = (200.0, 160.0),
              shape: str = "tshirt") -> GarmentCase:
    garment = make_garment(shape, fabric, size_mm, rng=seed)
    camera = model_station_camera()
    photo, background = render_model_photos(garment, camera, rng=seed + 1)
    built = build_photo_model(photo, background, camera, MODEL_DISTANCE_MM, name=garment.name)
    return GarmentCase(garment, camera, photo, background, built, hand_stereo_rig())


@pytest.fixture(scope="session")
def plaid_case() -> GarmentCase:
    return make_case("plaid", 11)


@pytest.fixture(scope="session")
def plain_case() -> GarmentCase:
    return make_case("plain", 21)
