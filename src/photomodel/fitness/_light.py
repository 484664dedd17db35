"""Light offsets of a scene from colour histograms, before the garment has been found.

Under another lamp or exposure every log-opponent feature of a scene moves by about one
offset ``o = (o_l, o_a, o_b)`` (see :mod:`photomodel.image._features`). The ``soft`` fitness
takes the offset out per pose; the scan (:func:`~photomodel.fitness.scan_flat_poses`) compares
colours as they are, and under a warm lamp or in dim light its peaks are noise, so the search
would need a GA, which is slower and can miss a print's narrow peak.

This module guesses the offset from where the garment's colours are, not from a grey card:
a histogram of the model's inner colours is correlated with the *presence* of colours in the
scene (a bin counts once it holds a few pixels, so the table, which covers most of the image,
weighs no more than a garment colour). At the scene's true offset every colour of the garment
finds pixels; at another, only some do. A plain garment has one colour and every offset that
lays it on any scene colour ties; its scan then stays untrusted (or its peaks fail the
fitness) and the search keeps its GA.
"""

from __future__ import annotations

import numpy as np
import scipy.ndimage
from numpy.typing import ArrayLike, NDArray

__all__ = ["light_offset_candidates"]

_BIN = 0.1
"""Histogram bin, log-opponent units (the ``soft`` tolerance is 0.12)."""


def light_offset_candidates(model_colours: ArrayLike, image_features: ArrayLike, *,
                            reach: tuple[float, float, float] = (1.3, 0.9, 0.9),
                            count: int = 2, min_pixels: float = 0.002
                            ) -> list[tuple[float, NDArray[np.float64]]]:
    """The ``count`` likeliest light offsets (image minus model) of a scene, best first.

    Parameters
    ----------
    model_colours : array (N, 3)
        Log-opponent colours of the model's inner samples (``ModelSamples.f_in``).
    image_features : array (H, W, 3)
        Log-opponent features of one scene image (a coarse pyramid level is enough).
    reach : (float, float, float)
        Largest offset searched in ``l``, ``a`` and ``b`` (1.3 in ``l``: a quarter of the
        light to 3.7 times it; 0.9 in chroma: beyond a 3000 K lamp under daylight balance).
    count : int
        Candidates returned; each is at least three bins from the better ones.
    min_pixels : float
        Share of the image's pixels from which a colour bin counts as present.

    Returns
    -------
    list of (float, ndarray (3,))
        ``(support, offset)``: the share of the model's colour mass that finds scene pixels
        at its colour plus ``offset`` (in [0, 1]), and the offset.
    """
    model = np.asarray(model_colours, dtype=np.float64).reshape(-1, 3)
    image = np.asarray(image_features, dtype=np.float64).reshape(-1, 3)
    if len(model) == 0 or len(image) == 0:
        raise ValueError("light_offset_candidates: expected model colours and image pixels")
    if count < 1:
        raise ValueError(f"count: expected >= 1, got {count}")
    span = np.ceil(np.asarray(reach) / _BIN).astype(int)        # shifts per side, in bins
    lo = np.floor(np.minimum(model.min(axis=0), image.min(axis=0)) / _BIN).astype(int) - span
    hi = np.floor(np.maximum(model.max(axis=0), image.max(axis=0)) / _BIN).astype(int) + span
    shape = tuple(int(s) for s in hi - lo + 1)
    present = _histogram(image, lo, shape) / (min_pixels * len(image))
    present = scipy.ndimage.gaussian_filter(np.minimum(present, 1.0), 1.0, mode="constant")
    weights = _histogram(model, lo, shape)
    weights /= weights.sum()
    support = np.zeros(tuple(2 * span + 1))
    for b in np.argwhere(weights > 0):
        support += weights[tuple(b)] * present[b[0] - span[0]:b[0] + span[0] + 1,
                                               b[1] - span[1]:b[1] + span[1] + 1,
                                               b[2] - span[2]:b[2] + span[2] + 1]
    found: list[tuple[float, NDArray[np.float64]]] = []
    for _ in range(count):
        i = np.unravel_index(int(np.argmax(support)), support.shape)
        if not support[i] > 0:
            break
        found.append((float(support[i]), (np.asarray(i) - span) * _BIN))
        support[tuple(slice(max(j - 3, 0), j + 4) for j in i)] = -1.0
    return found


def _histogram(colours: NDArray[np.float64], lo: NDArray[np.int64],
               shape: tuple[int, ...]) -> NDArray[np.float64]:
    """Counts (shape) of ``colours`` (N, 3) in bins of ``_BIN`` starting at bin ``lo``."""
    index = np.floor(colours / _BIN).astype(int) - lo
    flat = np.ravel_multi_index(tuple(index.T), shape)
    return np.bincount(flat, minlength=int(np.prod(shape))).astype(np.float64).reshape(shape)
