"""Outline evidence: how much of a model's outline both cameras see as an edge at a pose.

The ``soft`` fitness is ``S_in - S_out``: the inner points' agreement minus the band's. Two
kinds of scene score alike with it, and a cell must tell them apart:

* the garment, half hidden by a gripper: the hidden half disagrees inside (``S_in`` about
  0.6), the visible outline is sharp (fitness about 0.3);
* a plain model laid inside a larger region of about its colour (a grey sock on a grey
  object): everything agrees inside and much of the band agrees too (``S_in`` 0.85-0.95,
  fitness about 0.3-0.4).

The outline tells them apart. Each inner-ring point has a band point just outside it
(:attr:`~photomodel.fitness.ModelSamples.table_out`); the pair shows the model's edge when
the inner point agrees with the model (``a_in``) and the band point does not look like the
garment there (``1 - a_out``). The evidence is the mean of ``a_in (1 - a_out)`` over the
pairs and both cameras, at the offsets the fitness found for the pose, with the inner ring's
colour mixed with the band's as the fitness expects it (``SoftMatch.edge_mix``). A garment
in full view scores about 0.7, a visible half about 0.5, a model lying in a region of its
colour about 0.2-0.3 (the identification experiment's scenes). ``locate``'s score is the mean
of the fitness and this evidence (:func:`~photomodel.locate.soft_score`).
"""

from __future__ import annotations

import cv2
import numpy as np
from numpy.typing import NDArray

from photomodel.fitness._soft import SoftFitness
from photomodel.image._features import features_from_linear, linear_intensity

__all__ = ["edge_evidence"]


def _sample(image: NDArray[np.float32], uv: NDArray[np.float64]
            ) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """Bilinear samples (n, 3) of a feature image at pixels (n, 2) and whether each lies in
    the image."""
    h, w = image.shape[:2]
    u, v = uv[:, 0], uv[:, 1]
    inside = (u >= 0) & (v >= 0) & (u <= w - 1) & (v <= h - 1)
    mx = np.where(inside, u, 0).astype(np.float32).reshape(-1, 1)
    my = np.where(inside, v, 0).astype(np.float32).reshape(-1, 1)
    out = cv2.remap(image, mx, my, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
    return out.reshape(-1, 3).astype(np.float64), inside


def edge_evidence(fitness: SoftFitness, T_cam1_model: NDArray[np.float64]) -> float:
    """Share of the model's outline that both cameras see as an edge at a pose, in [0, 1].

    Parameters
    ----------
    fitness : SoftFitness
        The fitness at the level and camera blur of the pose's score (level 0 for
        ``locate``).
    T_cam1_model : ndarray (4, 4)

    Returns
    -------
    float
        Mean of ``a_in (1 - a_out)`` over the inner-ring points with a band point and both
        cameras (0 for a model without such points); a point outside an image counts 0.
    """
    T = np.asarray(T_cam1_model, dtype=np.float64).reshape(4, 4)
    s = fitness.samples
    pairs = s.table_out if s.table_out is not None else np.zeros(0, dtype=np.intp)
    ring = np.flatnonzero(pairs >= 0)
    if len(ring) == 0:
        return 0.0
    fitness.evaluate_transforms(T[None])      # the offsets of both cameras at this pose
    offsets = fitness.last_terms[0, :, 3:]
    feats = fitness.features
    m = feats.match
    scale = 0.5**fitness.level
    uv_in = np.stack(feats.rig.project_poses(T, s.p_in[ring])) * scale
    uv_out = np.stack(feats.rig.project_poses(T, s.p_out[pairs[ring]])) * scale
    t = fitness.edge_mix_fraction
    total = 0.0
    for cam in range(2):
        image = feats.pyramids[cam][fitness.level]
        x_in, ok_in = _sample(image, uv_in[cam])
        x_out, ok_out = _sample(image, uv_out[cam])
        o = offsets[cam]
        expected = s.f_in[ring] + o
        if t > 0.0:
            expected = features_from_linear((1.0 - t) * linear_intensity(expected)
                                            + t * linear_intensity(x_out))
        e_in = x_in - expected
        e_out = x_out - s.f_out[pairs[ring]] - o
        a_in, a_out = (np.exp(-0.5 * (e[:, 0] ** 2 / m.sigma_l**2
                                      + (e[:, 1] ** 2 + e[:, 2] ** 2) / m.sigma_c**2))
                       for e in (e_in, e_out))
        total += float(np.mean(np.where(ok_in & ok_out, a_in * (1.0 - a_out), 0.0)))
    return 0.5 * total
