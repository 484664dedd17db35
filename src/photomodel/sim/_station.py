"""The photo-model the model station builds of a simulated garment."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from photomodel.camera import PinholeCamera
from photomodel.model import PhotoModel, build_photo_model
from photomodel.sim._catalogue import catalogue_garment
from photomodel.sim._dataset import scene_rng
from photomodel.sim._rigs import MODEL_DISTANCE_MM, model_station_camera
from photomodel.sim._scenes import render_model_photos

__all__ = ["station_model", "station_scale"]


def station_model(garment: str, seed: int) -> PhotoModel:
    """Build garment ``garment``'s photo-model as a cell would: its model photos at the
    simulated station (:func:`render_model_photos`, noise from ``scene_rng(seed, "model",
    garment)``, the photos ``photomodel simulate --seed`` writes) through
    :func:`~photomodel.model.build_photo_model`.

    Parameters
    ----------
    garment : str
        A name :func:`catalogue_garment` knows (``"No.3"``, ``"cat-00042"``, ...).
    seed : int
        The dataset's seed.

    Returns
    -------
    PhotoModel
        Named ``garment``.
    """
    camera = model_station_camera()
    photo, background = render_model_photos(catalogue_garment(garment), camera,
                                            scene_rng(seed, "model", garment))
    return build_photo_model(photo, background, camera, MODEL_DISTANCE_MM, name=garment).model


def station_scale(station: PhotoModel, nominal: PhotoModel
                  ) -> tuple[float, NDArray[np.float64]]:
    """The truth of a model of unknown scale built from a station photo
    (:func:`~photomodel.model.build_unknown_scale`): real mm per nominal mm, and the nominal
    model's frame (at that factor) in the station model's frame (4, 4). The station model's
    outline (mm, through the station camera and its lens) against the same photo pixels at
    the nominal scale, least squares with a shift."""
    sm, nm = station.meta, nominal.meta
    camera = PinholeCamera(np.asarray(sm["camera_K"]), np.asarray(sm["camera_dist"]))
    c = np.asarray(sm["centroid_in_camera_mm"])
    xy = station.outline_mm[:, :2] + c[:2]
    uv = camera.project(np.column_stack([xy, np.full(len(xy), c[2])]))
    shrink = nm["scale"]["photo_shrink"]
    K = np.asarray(nm["camera_K"])
    nominal_xy = ((uv + 0.5) * shrink - 0.5 - K[:2, 2]) / K[0, 0] * nm["distance_mm"]
    A = np.column_stack([nominal_xy.ravel(), np.tile([1.0, 0.0], len(xy)),
                         np.tile([0.0, 1.0], len(xy))])
    s, tx, ty = np.linalg.lstsq(A, xy.ravel(), rcond=None)[0]
    T_station_nominal = np.eye(4)
    T_station_nominal[:2, 3] = (np.array([tx, ty])
                                + s * np.asarray(nm["centroid_in_camera_mm"])[:2] - c[:2])
    return float(s), T_station_nominal
