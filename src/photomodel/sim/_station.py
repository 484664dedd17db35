"""The photo-model the model station builds of a simulated garment."""

from __future__ import annotations

from photomodel.model import PhotoModel, build_photo_model
from photomodel.sim._catalogue import catalogue_garment
from photomodel.sim._dataset import scene_rng
from photomodel.sim._rigs import MODEL_DISTANCE_MM, model_station_camera
from photomodel.sim._scenes import render_model_photos

__all__ = ["station_model"]


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
