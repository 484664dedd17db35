"""The first locate of a photo-model of unknown scale: its scale searched with its pose.

1. **A first scale from the scene**: the scene's garment-like regions
   (:func:`~photomodel.fitness.scene_regions`, their areas in mm^2 from the table's stereo
   depth), best first by how much of the model's colours they hold; each gives the factor that
   makes the model's nominal area the region's (within a few per cent: blur and shadow).
2. **Pose and scale together**: the model at that factor is located with the Gauss-Newton
   refinement's prior on the mean strain removed (:data:`FREE_SCALE`): the mean of the fitted
   strain ``(e_xx + e_yy) / 2`` is the scale still missing. The factor is corrected by it and
   the model located again from the pose found, until the correction is under
   :data:`SCALE_TOLERANCE` (1-2 rounds from 5 % off).
3. The first region whose garment is found gives the answer: its pose, score and ``scale``
   (real millimetres per nominal millimetre; ``photomodel models set-scale`` stores it).
"""

from __future__ import annotations

import time
from dataclasses import replace

import numpy as np

from photomodel.fitness import PreparedModel, StereoFeatures, scene_regions
from photomodel.locate._locate import LocateResult, LocateSettings, locate_in_features
from photomodel.model import MAX_SCALE, PhotoModel, describe_model, resampled_model
from photomodel.search import GaussNewtonConfig, PyramidConfig, SearchSpace

__all__ = ["FREE_SCALE", "SCALE_TOLERANCE", "initial_scales", "locate_unknown_scale"]

FREE_SCALE = PyramidConfig(gauss_newton=GaussNewtonConfig(strain_weights=(0.0, 30.0)))
"""The search with no prior on the mean strain: the model may grow or shrink freely at every
level (a model a few per cent too large fits as well farther away in one camera; the other
camera settles the depth only when the size is free too)."""
SCALE_TOLERANCE = 5e-3
"""A correction of the scale under this (0.5 %), once applied, ends the search: the round after
one corrected the factor by c corrects it by a fifth of c or less (docs/method/register.md)."""
MAX_ROUNDS = 4
MAX_REGIONS = 3


def initial_scales(model: PhotoModel, features: StereoFeatures, space: SearchSpace
                   ) -> list[float]:
    """Scale factors (at most :data:`MAX_REGIONS`) that make the model's nominal area that of
    a region of the scene, the regions best first by the share of the model's colours they
    hold (step 1 of the module docstring)."""
    d = describe_model(model)
    regions = scene_regions(features, (float(space.lower[2]), float(space.upper[2])))
    ranked = []
    for r in regions.regions:
        if r.pixels <= 0 or r.area_mm2 <= 0:
            continue
        share = r.colour_hist / max(float(r.colour_hist.sum()), 1e-9)
        overlap = float(np.minimum(share[d.colour_bins], d.colour_weights).sum())
        ranked.append((overlap, float(np.sqrt(r.area_mm2 / d.area_mm2))))
    ranked.sort(key=lambda t: -t[0])
    out: list[float] = []
    for _, s in ranked:
        if 1.0 / MAX_SCALE <= s <= MAX_SCALE and all(abs(s / o - 1.0) > 0.03 for o in out):
            out.append(s)
        if len(out) == MAX_REGIONS:
            break
    return out


def locate_unknown_scale(
    model: PhotoModel,
    features: StereoFeatures,
    *,
    space: SearchSpace | None = None,
    rng: int | np.random.Generator | None = None,
    min_score: float | None = None,
    t0: float | None = None,
) -> LocateResult:
    """Locate a model of unknown scale and measure its scale (module docstring).

    Parameters
    ----------
    model : PhotoModel
        A model of unknown scale (nominal millimetres).
    features : StereoFeatures
    space : SearchSpace, optional
    rng : int, Generator or None
    min_score : float, optional
    t0 : float, optional

    Returns
    -------
    LocateResult
        Its ``scale`` is the factor measured (None when no region gave a garment); its pose
        is that of the model at that scale. Not found: the best try.
    """
    t0 = time.perf_counter() if t0 is None else t0
    gen = np.random.default_rng(rng)
    space = space or SearchSpace.from_ranges(R_cam1_plane=features.rig.R_cam1_facing)
    best: LocateResult | None = None
    for s0 in initial_scales(model, features, space):
        scale, seeds = s0, None
        result = None
        for _ in range(MAX_ROUNDS):
            trial = PreparedModel(resampled_model(model, scale))
            result = locate_in_features(trial, features, space=space, rng=gen,
                                        min_score=min_score, seeds=seeds,
                                        settings=LocateSettings(
                                            retries=0 if seeds is not None else 1,
                                            pyramid=FREE_SCALE))
            strain = result.strain
            if strain is None or not result.found:
                break
            correction = 0.5 * float(strain[0] + strain[1])
            scale *= 1.0 + correction
            seeds = [result.search.x]
            if abs(correction) < SCALE_TOLERANCE:
                break
        if result is None:
            continue
        result = replace(result, scale=scale)
        if best is None or result.score > best.score:
            best = result
        if result.found:
            break
    if best is None:       # no region: nothing in view
        best = locate_in_features(model, features, space=space, rng=gen, min_score=min_score)
    return replace(best, seconds=time.perf_counter() - t0)
