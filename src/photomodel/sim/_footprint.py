"""Where flat things lie on the table: their silhouettes rasterised in the table plane.

A :class:`Footprint` is a boolean mask on a grid of :data:`CELL_MM` cells aligned with the table
frame's x and y axes (cell ``(i, j)`` of the whole table is centred at
``(j * CELL_MM, i * CELL_MM)``); it keeps only the cells of its bounding box. Two footprints
overlap by the area of the cells both cover. Heights are ignored: a footprint is the item's
silhouette projected along the table's z axis.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
from numpy.typing import NDArray

from photomodel.sim._textures import PlaneTexture

__all__ = ["CELL_MM", "Footprint", "footprint", "union"]

CELL_MM = 1.0
"""Side of a footprint cell, mm."""


@dataclass(frozen=True)
class Footprint:
    """Cells of the table plane an item covers.

    Parameters
    ----------
    i0, j0 : int
        Table-grid row (along y) and column (along x) of the mask's top-left cell.
    mask : ndarray (H, W) bool
        Covered cells, rows along the table's y axis.
    """

    i0: int
    j0: int
    mask: NDArray[np.bool_]

    @property
    def centre_mm(self) -> tuple[float, float]:
        """(x, y) of its bounding box's middle in the table frame, mm."""
        h, w = self.mask.shape
        return ((self.j0 + (w - 1) / 2.0) * CELL_MM, (self.i0 + (h - 1) / 2.0) * CELL_MM)

    @property
    def radius_mm(self) -> float:
        """Half the diagonal of its bounding box, mm."""
        h, w = self.mask.shape
        return 0.5 * float(np.hypot(h, w)) * CELL_MM

    @property
    def area_mm2(self) -> float:
        """Covered area, mm^2."""
        return float(self.mask.sum()) * CELL_MM**2

    def overlap_mm2(self, other: Footprint) -> float:
        """Area both footprints cover, mm^2."""
        h, w = self.mask.shape
        oh, ow = other.mask.shape
        i0, j0 = max(self.i0, other.i0), max(self.j0, other.j0)
        i1, j1 = min(self.i0 + h, other.i0 + oh), min(self.j0 + w, other.j0 + ow)
        if i0 >= i1 or j0 >= j1:
            return 0.0
        mine = self.mask[i0 - self.i0:i1 - self.i0, j0 - self.j0:j1 - self.j0]
        theirs = other.mask[i0 - other.i0:i1 - other.i0, j0 - other.j0:j1 - other.j0]
        return float(np.count_nonzero(mine & theirs)) * CELL_MM**2

    def dilated(self, margin_mm: float) -> Footprint:
        """The footprint grown by ``margin_mm`` all round (a disc of that radius)."""
        r = int(np.ceil(margin_mm / CELL_MM))
        if r <= 0:
            return self
        padded = np.pad(self.mask, r).astype(np.uint8)
        disc = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * r + 1, 2 * r + 1))
        return Footprint(self.i0 - r, self.j0 - r, cv2.dilate(padded, disc).astype(bool))


def footprint(texture: PlaneTexture, T_table_item: NDArray[np.float64]) -> Footprint | None:
    """The cells of the table an item's silhouette (alpha > 0.5) covers, seen along z.

    Parameters
    ----------
    texture : PlaneTexture
        The item's picture; its alpha is the silhouette, in the item frame's z = 0 plane.
    T_table_item : ndarray (4, 4)
        Pose of the item frame in the table frame, mm.

    Returns
    -------
    Footprint or None
        None for an item standing on edge (its plane within 60 deg of vertical, such as a
        box's side: its top covers the same cells) or one that covers no cell.
    """
    R, t = T_table_item[:3, :3], T_table_item[:3, 3]
    if abs(R[2, 2]) < 0.5:
        return None
    # Texture pixel (u, v) -> table grid (column, row): A @ (u, v, 1).
    mm = texture.mm_per_px
    A = np.column_stack([R[:2, :2] * mm, t[:2] - R[:2, :2] @ (texture.origin_px * mm)])
    A /= CELL_MM
    w, h = texture.size_px
    corners = np.array([[-0.5, -0.5, 1.0], [w - 0.5, -0.5, 1.0], [w - 0.5, h - 0.5, 1.0],
                        [-0.5, h - 0.5, 1.0]])
    cells = corners @ A.T
    j0, i0 = (int(np.floor(c)) - 1 for c in cells.min(axis=0))
    j1, i1 = (int(np.ceil(c)) + 2 for c in cells.max(axis=0))
    shifted = A.copy()
    shifted[:, 2] -= (j0, i0)
    alpha = cv2.warpAffine(texture.alpha, shifted, (j1 - j0, i1 - i0), flags=cv2.INTER_LINEAR,
                           borderMode=cv2.BORDER_CONSTANT, borderValue=0)
    mask = alpha > 0.5
    if not mask.any():
        return None
    return Footprint(i0, j0, mask)


def union(parts: list[Footprint]) -> Footprint | None:
    """One footprint covering every cell of ``parts`` (None when there are none)."""
    if not parts:
        return None
    i0 = min(p.i0 for p in parts)
    j0 = min(p.j0 for p in parts)
    i1 = max(p.i0 + p.mask.shape[0] for p in parts)
    j1 = max(p.j0 + p.mask.shape[1] for p in parts)
    mask = np.zeros((i1 - i0, j1 - j0), bool)
    for p in parts:
        h, w = p.mask.shape
        mask[p.i0 - i0:p.i0 - i0 + h, p.j0 - j0:p.j0 - j0 + w] |= p.mask
    return Footprint(i0, j0, mask)
