"""Photo-models of unknown scale: built from a photo with no calibration (a phone photo of the
garment on any plain surface), measured once from the hand cameras' stereo pair.

The photo is taken as a fronto-parallel view of the garment at a *nominal* scale: the photo's
longer side is :data:`NOMINAL_PHOTO_MM` (a garment that fills a photo is 300-600 mm), downsized
first to at most :data:`MAX_PHOTO_PX` on that side. The model keeps its shape and colours;
its millimetres are nominal until :func:`scaled_model` applies the factor a scale-searching
locate measured (``photomodel models set-scale``). A model of unknown scale carries
``meta["scale"] = {"known": False, ...}``.
"""

from __future__ import annotations

import dataclasses
import os
from typing import Any

import cv2
import numpy as np
from numpy.typing import NDArray

from photomodel.camera import PinholeCamera
from photomodel.errors import NoGarmentError
from photomodel.image import bgr_to_hsv, sample_bilinear
from photomodel.model._build import (
    BuildResult,
    _sample,
    _smooth,
    build_photo_model,
    surface_photo,
)
from photomodel.model._config import BuildConfig
from photomodel.model._photomodel import PhotoModel

__all__ = ["MAX_SCALE", "at_scale", "build_unknown_scale", "confirmed_scale", "resampled_model",
           "scale_known", "scaled_model"]

NOMINAL_PHOTO_MM = 600.0
"""Nominal length of the photo's longer side, mm."""
MAX_PHOTO_PX = 1600
"""Longest side a photo of unknown scale is reduced to (0.4 mm a pixel at the nominal scale,
finer than the hand cameras' 0.86 mm)."""
MODEL_MM_PER_PX = 0.45
"""Resolution a resampled model's photo is reduced to when finer (a station model's is 0.53
mm a pixel; the hand cameras resolve 0.86)."""
MAX_SCALE = 20.0
"""Largest factor (and smallest, inverted) a measured scale may apply."""
_NOMINAL_DISTANCE_MM = 1000.0


def scale_known(model: PhotoModel) -> bool:
    """Whether ``model``'s millimetres are real (every model but one of unknown scale)."""
    scale = model.meta.get("scale")
    return not (isinstance(scale, dict) and scale.get("known") is False)


def build_unknown_scale(
    photo_bgr: NDArray[np.uint8],
    background_bgr: NDArray[np.uint8] | None = None,
    *,
    name: str = "garment",
    config: BuildConfig | None = None,
    photo_source: str | os.PathLike[str] = "photo",
    background_source: str | os.PathLike[str] = "background",
) -> BuildResult:
    """Build a photo-model of unknown scale (module docstring).

    Parameters
    ----------
    photo_bgr : ndarray (H, W, 3) uint8
        The garment on a plain surface, photographed from straight above.
    background_bgr : ndarray (H, W, 3) uint8, optional
        The surface alone from the same place; without it, the surface's colour (the median
        of the photo's border band).
    name : str
    config : BuildConfig, optional
        The build's settings (``step_mm`` and the band in nominal millimetres).
    photo_source, background_source : str or path-like
        Names used in error messages.

    Returns
    -------
    BuildResult
        Its model's ``meta["scale"]`` says ``known: False`` and the nominal millimetres of a
        photo pixel.
    """
    h, w = photo_bgr.shape[:2]
    shrink = min(1.0, MAX_PHOTO_PX / max(h, w))
    if shrink < 1.0:
        size = (max(1, round(w * shrink)), max(1, round(h * shrink)))
        photo_bgr = cv2.resize(photo_bgr, size, interpolation=cv2.INTER_AREA)
        if background_bgr is not None and background_bgr.shape[:2] == (h, w):
            background_bgr = cv2.resize(background_bgr, size, interpolation=cv2.INTER_AREA)
    if background_bgr is None:
        background_bgr = surface_photo(photo_bgr)
        background_source = "the surface's colour"
    ph, pw = photo_bgr.shape[:2]
    mm_per_px = NOMINAL_PHOTO_MM / max(ph, pw)
    f = _NOMINAL_DISTANCE_MM / mm_per_px
    camera = PinholeCamera(np.array([[f, 0.0, (pw - 1) / 2], [0.0, f, (ph - 1) / 2],
                                     [0.0, 0.0, 1.0]]), np.zeros(5), pw, ph)
    try:
        built = build_photo_model(photo_bgr, background_bgr, camera, _NOMINAL_DISTANCE_MM,
                                  name=name, config=config, photo_source=photo_source,
                                  background_source=background_source)
    except NoGarmentError:
        raise NoGarmentError(photo_source, "no garment found: nothing in the photo differs "
                                           "from the surface it lies on") from None
    built.model.meta["scale"] = {"known": False, "nominal_mm_per_px": mm_per_px,
                                 "photo_shrink": shrink}
    return built


def scaled_model(model: PhotoModel, factor: float, *, source: str = "") -> PhotoModel:
    """``model`` with every length times ``factor`` (the same photo seen from ``factor`` times
    as far): a model of unknown scale made real by a measured factor.

    Parameters
    ----------
    model : PhotoModel
    factor : float
        Real millimetres per nominal millimetre, in [1 / MAX_SCALE, MAX_SCALE].
    source : str
        What measured it (kept in ``meta["scale"]``); empty: the result is still of unknown
        scale (a trial scale during a search).

    Returns
    -------
    PhotoModel
    """
    if not (np.isfinite(factor) and 1.0 / MAX_SCALE <= factor <= MAX_SCALE):
        raise ValueError(f"scale: expected a factor from {1 / MAX_SCALE:g} to {MAX_SCALE:g}, "
                         f"got {factor:g}")
    meta: dict[str, Any] = dict(model.meta)
    meta["distance_mm"] = float(model.meta["distance_mm"]) * factor
    meta["centroid_in_camera_mm"] = [float(c) * factor
                                     for c in model.meta["centroid_in_camera_mm"]]
    if "area_mm2" in meta:
        meta["area_mm2"] = float(meta["area_mm2"]) * factor**2
    before = model.meta.get("scale")
    before = dict(before) if isinstance(before, dict) else {}
    meta["scale"] = {**before, "known": bool(source) or scale_known(model),
                     "factor": float(before.get("factor", 1.0)) * factor}
    if source:
        meta["scale"]["source"] = source
    return dataclasses.replace(model, points_in_mm=model.points_in_mm * factor,
                               points_out_mm=model.points_out_mm * factor,
                               outline_mm=model.outline_mm * factor, meta=meta)


def resampled_model(model: PhotoModel, factor: float, *, source: str = "") -> PhotoModel:
    """:func:`scaled_model` sampled anew: its points at its build's pitch in the new
    millimetres (a model of unknown scale has them at the nominal pitch), its photo reduced to
    about :data:`MODEL_MM_PER_PX` when finer, so that it costs a search what a station model
    does.

    Parameters
    ----------
    model : PhotoModel
    factor : float
        Real millimetres per millimetre of ``model``.
    source : str
        As for :func:`scaled_model`.

    Returns
    -------
    PhotoModel
    """
    scaled = scaled_model(model, factor, source=source)
    meta: dict[str, Any] = dict(scaled.meta)
    config = BuildConfig(**meta["build_config"]) if isinstance(meta.get("build_config"),
                                                                dict) else BuildConfig()
    K = np.asarray(meta["camera_K"], dtype=np.float64).copy()
    dist = np.asarray(meta["camera_dist"], dtype=np.float64)
    distance = float(meta["distance_mm"])
    K[:2, 2] -= model.crop_origin_px                      # the crop's own camera
    photo, mask = model.photo_bgr, model.mask
    shrink = min(1.0, distance / float(np.sqrt(K[0, 0] * K[1, 1])) / MODEL_MM_PER_PX)
    if shrink < 1.0:
        h, w = mask.shape
        size = (max(1, round(w * shrink)), max(1, round(h * shrink)))
        sx, sy = size[0] / w, size[1] / h
        photo = cv2.resize(photo, size, interpolation=cv2.INTER_AREA)
        mask = (cv2.resize(mask.astype(np.float32), size, interpolation=cv2.INTER_AREA)
                >= 0.5).astype(np.uint8)
        K = np.array([[K[0, 0] * sx, K[0, 1] * sx, (K[0, 2] + 0.5) * sx - 0.5],
                      [0.0, K[1, 1] * sy, (K[1, 2] + 0.5) * sy - 0.5], [0.0, 0.0, 1.0]])
    camera = PinholeCamera(K, dist, mask.shape[1], mask.shape[0])
    centroid = np.asarray(meta["centroid_in_camera_mm"], dtype=np.float64)
    mask = np.ascontiguousarray(mask.astype(np.uint8))
    points_in, points_out, uv_in, _, _, outline = _sample(mask, camera, distance, centroid[:2],
                                                           config)
    hsv_in = bgr_to_hsv(sample_bilinear(_smooth(photo, config.smooth_sigma_px), uv_in))
    meta.update(camera_K=K.tolist(), photo_size_px=[int(mask.shape[1]), int(mask.shape[0])])
    return PhotoModel(name=model.name, points_in_mm=points_in, hsv_in=hsv_in,
                      points_out_mm=points_out, outline_mm=outline,
                      photo_bgr=np.ascontiguousarray(photo), mask=mask,
                      crop_origin_px=np.zeros(2, dtype=np.int64), meta=meta)


def confirmed_scale(answer: Any, name: str) -> float:
    """The factor a locate answer (the ``locate --json`` object) of model ``name`` measured,
    when it found the garment; ValueError saying why not (the answer's subject first: "is no
    locate answer of model ...", "has no measured scale ...", "did not find ...")."""
    if not isinstance(answer, dict) or answer.get("model") != name:
        raise ValueError(f"is no locate answer of model {name!r}")
    factor = answer.get("scale")
    if isinstance(factor, bool) or not isinstance(factor, int | float):
        raise ValueError("has no measured scale (a locate of a model of unknown scale reports "
                         "one)")
    if answer.get("found") is not True:
        raise ValueError("did not find the garment: its scale is not confirmed")
    return float(factor)


def at_scale(model: PhotoModel, factor: float, source: str) -> PhotoModel:
    """A model of unknown scale as ``models set-scale`` stores it: sampled anew at ``factor``
    (:func:`resampled_model`), its scale known from ``source``. ValueError ``"name: ..."`` for
    a model of known scale, ``"factor: ..."`` for a factor out of range."""
    if scale_known(model):
        raise ValueError("name: has a known scale already")
    try:
        return resampled_model(model, factor, source=source)
    except ValueError as exc:
        raise ValueError("factor: " + str(exc).removeprefix("scale: ")) from None
