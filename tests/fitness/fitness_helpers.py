"""Numpy transcriptions shared by the fitness tests' references."""

from __future__ import annotations

import numpy as np


def bilinear_samples(img: np.ndarray, uv: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Bilinear samples (N, C) of ``img`` (H, W, C) at pixels ``uv`` (N, 2), and whether each
    lies inside the image (the kernels' rule: ``0 <= u <= W - 1``, ``0 <= v <= H - 1``; the
    samples outside are of no use)."""
    h, w = img.shape[:2]
    u, v = uv[:, 0], uv[:, 1]
    ok = (u >= 0) & (v >= 0) & (u <= w - 1) & (v <= h - 1)
    iu = np.minimum(np.floor(np.where(ok, u, 0)).astype(int), w - 2)
    iv = np.minimum(np.floor(np.where(ok, v, 0)).astype(int), h - 2)
    fu, fv = (np.where(ok, u, 0) - iu)[:, None], (np.where(ok, v, 0) - iv)[:, None]
    top = img[iv, iu] * (1 - fu) + img[iv, iu + 1] * fu
    bottom = img[iv + 1, iu] * (1 - fu) + img[iv + 1, iu + 1] * fu
    return top * (1 - fv) + bottom * fv, ok


def residual_products(r: np.ndarray, ok: np.ndarray, weights: np.ndarray, h: np.ndarray
                      ) -> tuple[np.ndarray, np.ndarray]:
    """The held-offset gradient ``-J^T (w r)`` (G,) and the inner points' metric
    ``J^T diag(w) J`` (G, G) from forward differences of the residuals: ``r`` (1 + G,
    cameras, N, 3) of a gene vector and of its G forward differences (steps ``h`` (G,)),
    ``ok`` (1 + G, cameras, N) whether each sample fell inside the image. A sample counts
    where every pose saw it; its weight ``w`` is its signed ``weights`` (N,) times its
    agreement ``exp(-|r|^2 / 2)``, averaged over the cameras; the metric takes the inner
    (positive) samples only."""
    usable = ok.all(axis=0)
    r0 = r[0]
    J = (r[1:] - r0) / h[:, None, None, None]
    w = np.exp(-0.5 * np.sum(r0**2, axis=-1)) * weights / r.shape[1] * usable
    inner = np.where(weights > 0, w, 0.0)
    return (-np.einsum("gcnd,cn,cnd->g", J, w, r0),
            np.einsum("gcnd,cn,hcnd->gh", J, inner, J))
