"""What a stereo pair shows beside the table: the garment-like regions that screening compares.

On one coarse pyramid level (:data:`SCENE_LEVEL`, about 3.4 mm a pixel at the working
distance):

1. **The table's colour** is learnt from a band along the image border (the garments lie
   inside the view, the table fills its edges): the densest colour of the band and the spread
   of the band's pixels near it. Pixels far from it (:attr:`SceneConfig.table_sigma`
   standard deviations, and at least :attr:`SceneConfig.min_distance` log units) are
   *foreground*: garments, objects, grippers.
2. **The table's depth** comes from stereo: the foreground of camera 1 is mapped into camera 2
   through the homography of a plane facing the rig (:attr:`StereoRig.R_cam1_facing`) at each
   candidate depth, and the depth whose mapping agrees best with camera 2's foreground (the
   highest intersection over union; 20 depths, then 9 around the best) is the table's.
   Garments lie on the table, so this fixes the millimetres of a pixel (a large object above
   the table, such as a gripper, can pull it towards the cameras).
3. **Regions** are the connected parts of camera 1's foreground; each keeps its area (mm^2),
   its colour histogram (the grid of :mod:`photomodel.model._descriptor`), its principal
   second moments (mm^2) and whether it touches the border. The whole foreground is one more
   region, for a garment that an occluder cuts in two.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
from numpy.typing import NDArray

from photomodel.fitness._soft import StereoFeatures
from photomodel.model import COLOUR_BIN, soft_colour_histogram

__all__ = ["SCENE_LEVEL", "Region", "SceneConfig", "SceneRegions", "scene_regions"]

SCENE_LEVEL = 2


@dataclass(frozen=True)
class SceneConfig:
    """Settings of :func:`scene_regions`.

    Attributes
    ----------
    level : int
        Pyramid level analysed.
    border_px : int
        Width of the border band the table's colour is learnt from, pixels of ``level``.
    table_sigma : float
        Mahalanobis distance from the table's colour beyond which a pixel is foreground.
    min_distance : float
        Least colour distance (log units) of a foreground pixel from the table's colour.
    min_area_mm2 : float
        Smallest region kept (smaller specks are noise or table texture).
    max_regions : int
        Largest regions kept.
    depth_steps : int
        Coarse candidate depths of the table between the search box's nearest and farthest
        (9 finer ones follow around the best).
    """

    level: int = SCENE_LEVEL
    border_px: int = 6
    table_sigma: float = 4.0
    min_distance: float = 0.12
    min_area_mm2: float = 1500.0
    max_regions: int = 12
    depth_steps: int = 20


@dataclass(frozen=True)
class Region:
    """One garment-like region of camera 1's image.

    Attributes
    ----------
    area_mm2 : float
    mm_per_px : float
        Size of a pixel of the analysed level on the table.
    colour_hist : ndarray (prod(COLOUR_GRID_SHAPE),) float64
        Pixel counts of its colours (trilinear shares, pixels of the analysed level).
    mean_lab : ndarray (3,)
        Mean log-opponent colour.
    moments_mm2 : (float, float)
        Principal second moments, largest first.
    touches_border : bool
    pixels : int
    lab : ndarray (pixels, 3) float32
        Its pixels' log-opponent colours.
    xy_mm : ndarray (pixels, 2) float32
        Its pixels' positions on the table (camera 1's columns and rows times ``mm_per_px``).
    """

    area_mm2: float
    mm_per_px: float
    colour_hist: NDArray[np.float64]
    mean_lab: NDArray[np.float64]
    moments_mm2: tuple[float, float]
    touches_border: bool
    pixels: int
    lab: NDArray[np.float32]
    xy_mm: NDArray[np.float32]


@dataclass(frozen=True)
class SceneRegions:
    """The regions of a stereo pair (largest first; the last is the whole foreground when
    there are two or more) and the table's depth along camera 1's axis (mm; NaN when
    nothing but the table is in view)."""

    regions: tuple[Region, ...]
    table_depth_mm: float
    foreground: NDArray[np.bool_]


def border_band(image: NDArray[np.float32], width_px: int) -> NDArray[np.float32]:
    """The pixels (N, 3) of an image's border band ``width_px`` wide (at most a quarter of
    its sides), where the table shows: garments lie inside the view."""
    h, w = image.shape[:2]
    b = max(1, min(width_px, h // 4, w // 4))
    return np.concatenate([image[:b].reshape(-1, 3), image[-b:].reshape(-1, 3),
                           image[b:-b, :b].reshape(-1, 3), image[b:-b, -b:].reshape(-1, 3)])


def _table_mask(image: NDArray[np.float32], config: SceneConfig) -> NDArray[np.bool_]:
    """Foreground (not table) pixels of one level image (H, W, 3)."""
    h, w, _ = image.shape
    band = border_band(image, config.border_px)
    q = np.floor(band / COLOUR_BIN).astype(np.int64)
    q -= q.min(axis=0)
    dims = q.max(axis=0) + 3
    # the densest bin, counting its neighbours (a mottled table spreads over a few)
    flat = np.ravel_multi_index(tuple((q + 1).T), tuple(dims))
    near = np.bincount(flat, minlength=int(np.prod(dims))).astype(np.float64).reshape(dims)
    for axis in range(3):
        near = near + np.roll(near, 1, axis) + np.roll(near, -1, axis)
    mode = np.array(np.unravel_index(int(np.argmax(near)), near.shape)) - 1
    close = np.abs(q - mode).max(axis=1) <= 1
    pixels = band[close.reshape(-1)].astype(np.float64)
    mean = pixels.mean(axis=0)
    cov = np.cov(pixels.T) + np.eye(3) * (0.25 * config.min_distance) ** 2
    whiten = np.linalg.inv(np.linalg.cholesky(cov)).T.astype(np.float32)   # L^-T
    d = image.reshape(-1, 3) - mean.astype(np.float32)
    y = d @ whiten                                   # Mahalanobis distance = |y|
    far = ((y * y).sum(axis=1) > config.table_sigma**2) & (
        (d * d).sum(axis=1) > config.min_distance**2)
    mask = far.reshape(h, w).astype(np.uint8)
    kernel = np.ones((3, 3), np.uint8)
    mask = cv2.morphologyEx(mask, cv2.MORPH_OPEN, kernel)
    mask = cv2.morphologyEx(mask, cv2.MORPH_CLOSE, kernel)
    return mask.astype(bool)


def _table_depth(features: StereoFeatures, masks: tuple[NDArray[np.bool_], NDArray[np.bool_]],
                 level: int, z_range_mm: tuple[float, float], steps: int) -> float:
    """Depth (mm, along camera 1's axis) of the plane facing the rig whose homography maps
    camera 1's foreground best onto camera 2's (intersection over union); NaN without
    foreground."""
    m1, m2 = masks
    if not m1.any() or not m2.any():
        return float("nan")
    rig = features.rig
    K1, K2 = features.camera_matrices(level)
    n = rig.R_cam1_facing[:, 2]
    src = m1.astype(np.uint8)
    h2, w2 = m2.shape
    Kinv = np.linalg.inv(K1)

    def overlap(z: float) -> float:
        d = float(n[2] * z)           # the plane n . X = d through (0, 0, z)
        H = K2 @ (rig.R + np.outer(rig.T, n) / d) @ Kinv
        warped = cv2.warpPerspective(src, H, (w2, h2), flags=cv2.INTER_NEAREST).astype(bool)
        union = np.count_nonzero(warped | m2)
        return np.count_nonzero(warped & m2) / union if union else 0.0

    zs = np.geomspace(z_range_mm[0], z_range_mm[1], steps)
    i = int(np.argmax([overlap(float(z)) for z in zs]))
    fine = np.geomspace(zs[max(i - 1, 0)], zs[min(i + 1, len(zs) - 1)], 9)
    return float(fine[int(np.argmax([overlap(float(z)) for z in fine]))])


def _region(image: NDArray[np.float32], inside: NDArray[np.bool_], mm_per_px: float,
            touches: bool) -> Region:
    rows, cols = np.nonzero(inside)
    colours = image[rows, cols].astype(np.float64)
    hist = soft_colour_histogram(colours, np.ones(len(colours)))
    xy = np.stack([cols, rows], axis=1).astype(np.float64) * mm_per_px
    cov = np.cov(xy.T) if len(xy) > 2 else np.zeros((2, 2))
    moments = np.sort(np.linalg.eigvalsh(cov))[::-1]
    return Region(area_mm2=float(len(rows) * mm_per_px**2), mm_per_px=mm_per_px,
                  colour_hist=hist, mean_lab=colours.mean(axis=0),
                  moments_mm2=(float(moments[0]), float(moments[1])), touches_border=touches,
                  pixels=len(rows), lab=colours.astype(np.float32),
                  xy_mm=xy.astype(np.float32))


def scene_regions(features: StereoFeatures, z_range_mm: tuple[float, float] = (450.0, 1000.0),
                  config: SceneConfig | None = None) -> SceneRegions:
    """The garment-like regions of a stereo pair (see the module docstring).

    Parameters
    ----------
    features : StereoFeatures
    z_range_mm : (float, float)
        Depths of the table considered (a search box's z bounds).
    config : SceneConfig, optional

    Returns
    -------
    SceneRegions
    """
    c = config or SceneConfig()
    level = min(c.level, features.levels - 1)
    images = (features.pyramids[0][level], features.pyramids[1][level])
    masks = (_table_mask(images[0], c), _table_mask(images[1], c))
    z = _table_depth(features, masks, level, z_range_mm, c.depth_steps)
    if not np.isfinite(z):
        return SceneRegions((), z, masks[0])
    K1, _ = features.camera_matrices(level)
    mm_per_px = z / float(np.sqrt(K1[0, 0] * K1[1, 1]))
    count, labels, stats, _ = cv2.connectedComponentsWithStats(masks[0].astype(np.uint8), 8)
    h, w = masks[0].shape
    min_px = c.min_area_mm2 / mm_per_px**2
    order = [i for i in np.argsort(-stats[1:, cv2.CC_STAT_AREA]) + 1
             if stats[i, cv2.CC_STAT_AREA] >= min_px][: c.max_regions]
    regions = []
    for i in order:
        x, y, bw, bh = stats[i, :4]
        touches = bool(x == 0 or y == 0 or x + bw >= w or y + bh >= h)
        regions.append(_region(images[0], labels == i, mm_per_px, touches))
    if len(regions) > 1:
        whole = np.isin(labels, order)
        regions.append(_region(images[0], whole, mm_per_px,
                               any(r.touches_border for r in regions)))
    return SceneRegions(tuple(regions), z, masks[0])
