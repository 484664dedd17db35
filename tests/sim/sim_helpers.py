"""Test helpers for the simulator's tests: a dotted calibration card and dot detectors."""

from __future__ import annotations

from collections.abc import Callable
from functools import lru_cache

import numpy as np
from numpy.typing import NDArray

from photomodel.sim import PlaneTexture

DOT_SIGMA_MM = 1.2
DOT_SPACING_MM = 40.0


@lru_cache(maxsize=2)
def dot_card(size_mm: tuple[float, float] = (520.0, 400.0),
             mm_per_px: float = 0.5) -> tuple[PlaneTexture, NDArray[np.float64]]:
    """A white card with dark Gaussian dots on a grid, and the dots' centres (N, 2), mm.

    Each dot is centred on a texel, so its bilinear interpolant is point-symmetric about the
    centre and its intensity centroid is exactly the centre.
    """
    w, h = round(size_mm[0] / mm_per_px), round(size_mm[1] / mm_per_px)
    step, sigma = DOT_SPACING_MM / mm_per_px, DOT_SIGMA_MM / mm_per_px
    us = np.arange(step / 2, w - step / 4, step).round().astype(int)
    vs = np.arange(step / 2, h - step / 4, step).round().astype(int)
    r = int(np.ceil(5 * sigma))
    yy, xx = np.mgrid[-r:r + 1, -r:r + 1]
    dot = 235.0 * np.exp(-(xx**2 + yy**2) / (2 * sigma**2))
    grey = np.full((h, w), 255.0)
    for cv in vs:
        for cu in us:
            grey[cv - r:cv + r + 1, cu - r:cu + r + 1] -= dot
    image = np.repeat(np.rint(grey).astype(np.uint8)[..., None], 3, axis=-1)
    card = PlaneTexture(image, np.ones((h, w), np.float32), mm_per_px,
                        np.array([(w - 1) / 2, (h - 1) / 2]))
    centres_px = np.stack(np.meshgrid(us, vs), axis=-1).reshape(-1, 2)
    return card, card.mm_from_px(centres_px)


def dot_centroid(image: NDArray[np.uint8], uv: NDArray[np.float64],
                 half: int = 10) -> NDArray[np.float64] | None:
    """Intensity-weighted centroid (2,) of a dark dot on white in a window around ``uv``.

    None when the window does not fit in the image.
    """
    c, r = np.rint(uv).astype(int)
    h, w = image.shape[:2]
    if c - half < 0 or r - half < 0 or c + half >= w or r + half >= h:
        return None
    patch = image[r - half:r + half + 1, c - half:c + half + 1].astype(np.float64).mean(axis=2)
    weight = np.clip(255.0 - patch, 0.0, None)
    vv, uu = np.mgrid[r - half:r + half + 1, c - half:c + half + 1]
    return np.array([(weight * uu).sum(), (weight * vv).sum()]) / weight.sum()


def _window(image: NDArray[np.uint8], uv: NDArray[np.float64], half: int
            ) -> tuple[tuple[slice, slice], NDArray[np.float64], NDArray[np.float64]] | None:
    """Rows and columns of the (2 half + 1)^2 window around ``uv`` and its pixels' (u, v) grids.

    None when the window does not fit in the image.
    """
    c, r = np.rint(uv).astype(int)
    h, w = image.shape[:2]
    if c - half < 0 or r - half < 0 or c + half >= w or r + half >= h:
        return None
    rows, cols = slice(r - half, r + half + 1), slice(c - half, c + half + 1)
    vv, uu = np.mgrid[rows, cols].astype(np.float64)
    return (rows, cols), uu, vv


def _weighted_centre(weight: NDArray[np.float64], uu: NDArray[np.float64],
                     vv: NDArray[np.float64]) -> NDArray[np.float64] | None:
    total = weight.sum()
    if not total > 0:
        return None
    return np.array([(weight * uu).sum(), (weight * vv).sum()]) / total


def plane_fit_dot_centroid(image: NDArray[np.uint8], uv: NDArray[np.float64], half: int = 10,
                           ring: int = 2) -> NDArray[np.float64] | None:
    """Centroid (2,) of a dark dot on a white level that varies linearly across the window.

    The white level is a plane fitted (least squares) to the ``ring`` outermost rows and
    columns of the window; each inner pixel weighs ``max(plane - pixel, 0)``. Copes with a
    smooth shading gradient and with a white level below 255 (clipped sensor noise), not with
    shading that varies faster than the window. None when the window does not fit.
    """
    found = _window(image, uv, half)
    if found is None:
        return None
    roi, uu, vv = found
    patch = image[roi].astype(np.float64).mean(axis=2)
    border = np.zeros(patch.shape, bool)
    border[:ring] = border[-ring:] = True
    border[:, :ring] = border[:, -ring:] = True
    du, dv = uu - uu.mean(), vv - vv.mean()
    A = np.column_stack([np.ones(int(border.sum())), du[border], dv[border]])
    coef = np.linalg.lstsq(A, patch[border], rcond=None)[0]
    white = coef[0] + coef[1] * du + coef[2] * dv
    weight = np.where(border, 0.0, np.clip(white - patch, 0.0, None))
    return _weighted_centre(weight, uu, vv)


def flat_field_dot_centroid(image: NDArray[np.uint8], white: NDArray[np.uint8],
                            uv: NDArray[np.float64], half: int = 10) -> NDArray[np.float64] | None:
    """Centroid (2,) of a dark dot, flat-fielded by an image of the same scene without dots.

    Each pixel weighs ``max(1 - image / white, 0)``: the dot's relative darkness, from which
    any shading (a factor common to both images) cancels. ``white`` must not be clipped at 255.
    None when the window does not fit.
    """
    found = _window(image, uv, half)
    if found is None:
        return None
    roi, uu, vv = found
    patch = image[roi].astype(np.float64).mean(axis=2)
    ref = np.maximum(white[roi].astype(np.float64).mean(axis=2), 1.0)
    return _weighted_centre(np.clip(1.0 - patch / ref, 0.0, None), uu, vv)


def scaled_texture(texture: PlaneTexture, gain: float) -> PlaneTexture:
    """The texture with its colours multiplied by ``gain`` (rounded), same alpha and frame."""
    image = np.clip(np.rint(texture.image_bgr * gain), 0, 255).astype(np.uint8)
    return PlaneTexture(image, texture.alpha, texture.mm_per_px, texture.origin_px)


def blank_texture(texture: PlaneTexture, level: int) -> PlaneTexture:
    """A texture of one grey ``level`` with the alpha and frame of ``texture``."""
    return PlaneTexture(np.full_like(texture.image_bgr, level), texture.alpha,
                        texture.mm_per_px, texture.origin_px)


def surface_dot_centroid(to_image: Callable[[NDArray[np.float64]], NDArray[np.float64]],
                         centre_mm: NDArray[np.float64], sigma_mm: float = DOT_SIGMA_MM,
                         n: int = 61) -> NDArray[np.float64]:
    """Where the intensity centroid (2,) of a Gaussian dot lands in an image, by integration.

    ``to_image`` maps material points (N, 2), mm, to pixels (N, 2) (through a curved surface
    and a camera). The dot's darkness, ``exp(-|m - centre|^2 / (2 sigma^2))`` on the material,
    is carried to the image with the area scale of the mapping (its Jacobian determinant,
    by finite differences on an ``n x n`` grid over +-5 sigma), so the result is the centroid
    an unbiased detector finds, curvature and foreshortening included.
    """
    r = 5.0 * sigma_mm
    gx, gy = np.meshgrid(np.linspace(-r, r, n), np.linspace(-r, r, n))
    offsets = np.column_stack([gx.ravel(), gy.ravel()])
    uv = to_image(np.asarray(centre_mm, dtype=np.float64) + offsets).reshape(n, n, 2)
    du, dv = np.gradient(uv, axis=1), np.gradient(uv, axis=0)
    area = np.abs(du[..., 0] * dv[..., 1] - du[..., 1] * dv[..., 0]).ravel()
    weight = np.exp(-(offsets**2).sum(axis=1) / (2.0 * sigma_mm**2)) * area
    return (uv.reshape(-1, 2) * weight[:, None]).sum(axis=0) / weight.sum()
