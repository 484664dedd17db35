"""``DescriptorBank``: every model's descriptor in arrays, scored against a scene's regions.

For each model and each region of :func:`~photomodel.fitness.scene_regions`, with the
region's millimetres per pixel (from the table's stereo depth) the model's colour histogram
becomes the pixels it would cover there, ``A w`` (``A`` its area in pixels, ``w`` its bin
shares). Then

- *containment* ``c = sum min(A w, H[bins + shift]) / A``: the share of the model's colour mass
  the region holds (``H`` the region's colour counts, trilinear, widened by one bin each way);
  about 1 for the garment in full view, its visible share when partly hidden, low for a model
  that is larger than the region or whose colours it lacks;
- *explained share* ``e = sum min(A w, H[bins + shift]) / P`` (``P`` the region's pixels):
  the share of the region the model accounts for; a smaller look-alike leaves part of its
  garment's region unexplained.

The light ``shift`` is tried at zero (the model station's light) and at the offset that moves
the model's mean colour onto the region's, restricted to what a lamp does: any change of
intensity (``l``), and a colour temperature along the black-body direction of ``(a, b)``
(:data:`LIGHT_DIRECTION_AB`). A model's evidence is its best ``c - unexplained_weight *
(1 - e)`` over regions and shifts, in [0, 1] after clipping. The loops run in one compiled
kernel over all models: milliseconds for thousands.

The best-screened (``BankConfig.refine``) are then looked at pixel by pixel
(:meth:`DescriptorBank.refine`): in each region, the pixels whose colour (at either light) lies
within a bin of one of the model's colours are the part it explains; their area against the
model's (a visible share, no more than 1 for the garment itself) and their principal moments
against the model's tell the garment from a look-alike of other size or shape even where the
region also holds an occluder or a neighbour. A model's refined evidence is the mean of its
screening evidence and the best of ``min(v, 1) - 0.5 max(ln v, 0) - 0.3 shape min(v, 1)``
over regions and lights (``v`` the explained area over the model's).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numba import prange
from numpy.typing import NDArray

from photomodel._jit import njit
from photomodel.fitness import SceneRegions
from photomodel.model import (
    COLOUR_BIN,
    COLOUR_GRID_LOW,
    COLOUR_GRID_SHAPE,
    ModelDescriptor,
)

__all__ = ["LIGHT_DIRECTION_AB", "BankConfig", "DescriptorBank"]

LIGHT_DIRECTION_AB = np.array([0.41, 0.91]) / np.hypot(0.41, 0.91)
"""Direction in (a, b) along which a lamp's colour temperature moves log-opponent colours
(a 3000 K lamp under a daylight balance moves them by about 0.73 along it)."""


@dataclass(frozen=True)
class BankConfig:
    """Settings of :meth:`DescriptorBank.evidence`.

    Attributes
    ----------
    unexplained_weight : float
        Weight of the region's share that a model leaves unexplained.
    light_l : (float, float)
        Range of lightness offsets tried (log units; -1.3 is a quarter of the light).
    light_t : (float, float)
        Range of colour-temperature offsets along :data:`LIGHT_DIRECTION_AB`.
    refine : int
        Best-screened models looked at pixel by pixel (:meth:`DescriptorBank.refine`).
    shape_weight : float
        Weight of the disagreement of the region's principal moments with the model's
        (``|ln(ratio)|`` of each, summed, 0.5 counting fully), in proportion to how exactly
        the model fills the region (``min(c, e)``).
    """

    unexplained_weight: float = 0.3
    shape_weight: float = 0.3
    light_l: tuple[float, float] = (-1.3, 0.8)
    light_t: tuple[float, float] = (-0.4, 0.9)
    refine: int = 16


class DescriptorBank:
    """The descriptors of a library as arrays (see the module docstring).

    Parameters
    ----------
    names : sequence of str
    descriptors : sequence of ModelDescriptor
        One per name.
    """

    def __init__(self, names: Sequence[str], descriptors: Sequence[ModelDescriptor]) -> None:
        if len(names) != len(descriptors):
            raise ValueError(f"descriptors: expected one per name ({len(names)}), got "
                             f"{len(descriptors)}")
        self.names = tuple(names)
        self.index = {name: i for i, name in enumerate(self.names)}
        m = len(descriptors)
        k = max((len(d.colour_bins) for d in descriptors), default=1)
        self.bins = np.zeros((m, k, 3), dtype=np.int32)
        self.weights = np.zeros((m, k), dtype=np.float32)
        self.area_mm2 = np.zeros(m)
        self.mean_lab = np.zeros((m, 3))
        self.moments_mm2 = np.ones((m, 2))
        for i, d in enumerate(descriptors):
            n = len(d.colour_bins)
            self.bins[i, :n] = np.stack(np.unravel_index(d.colour_bins, COLOUR_GRID_SHAPE), 1)
            self.weights[i, :n] = d.colour_weights
            self.area_mm2[i] = d.area_mm2
            self.mean_lab[i] = d.mean_lab
            self.moments_mm2[i] = np.maximum(d.moments_mm2, 1.0)

    def __len__(self) -> int:
        return len(self.names)

    def evidence(self, scene: SceneRegions, config: BankConfig | None = None
                 ) -> NDArray[np.float64]:
        """Each model's evidence (len(self),) in [0, 1] in the scene's regions (0 without
        regions), the ``config.refine`` best refined (:meth:`refine`)."""
        c = config or BankConfig()
        first = self.screen(scene, c)
        return self.refine(scene, first, c)

    def _light_shift(self, m: int, mean_lab: NDArray[np.float64], c: BankConfig
                     ) -> NDArray[np.float64]:
        """The lamp change (3,) that moves model ``m``'s mean colour onto ``mean_lab``."""
        offset = mean_lab - self.mean_lab[m]
        dt = float(np.clip(offset[1:] @ LIGHT_DIRECTION_AB, *c.light_t))
        return np.array([np.clip(offset[0], *c.light_l), *(dt * LIGHT_DIRECTION_AB)])

    def refine(self, scene: SceneRegions, evidence: NDArray[np.float64],
               config: BankConfig | None = None) -> NDArray[np.float64]:
        """``evidence`` with its ``config.refine`` best models' values refined pixel by pixel
        (see the module docstring)."""
        c = config or BankConfig()
        out = evidence.copy()
        if not scene.regions or not c.refine:
            return out
        top = np.argsort(-evidence, kind="stable")[: c.refine]
        grid = np.asarray(COLOUR_GRID_SHAPE)
        palettes = np.zeros((len(top), int(np.prod(grid))), dtype=np.bool_)
        for row, m in enumerate(top):
            near = (self.bins[m][self.weights[m] > 0.01][:, None, :] + _STEPS[None]
                    ).reshape(-1, 3)
            near = near[np.all((near >= 0) & (near < grid), axis=1)]
            palettes[row, np.ravel_multi_index(tuple(near.T), COLOUR_GRID_SHAPE)] = True
        regions = scene.regions
        starts = np.cumsum([0, *(r.pixels for r in regions)]).astype(np.int64)
        shifts = np.stack([[self._light_shift(int(m), r.mean_lab, c) for r in regions]
                           for m in top])
        best = _refine_kernel(
            palettes, np.ascontiguousarray(np.concatenate([r.lab for r in regions]),
                                           dtype=np.float32),
            np.ascontiguousarray(np.concatenate([r.xy_mm for r in regions]),
                                 dtype=np.float32),
            starts, np.array([r.mm_per_px for r in regions], dtype=np.float64), shifts,
            self.area_mm2[top], self.moments_mm2[top], COLOUR_GRID_LOW.astype(np.float64),
            float(COLOUR_BIN), grid.astype(np.int64))
        out[top] = 0.5 * evidence[top] + 0.5 * best
        return np.clip(out, 0.0, 1.0)

    def screen(self, scene: SceneRegions, config: BankConfig | None = None
               ) -> NDArray[np.float64]:
        """Each model's screening evidence (len(self),) from the regions' colour counts, in
        [0, 1] (0 without regions)."""
        c = config or BankConfig()
        out = np.zeros(len(self))
        if not scene.regions or not len(self):
            return out
        for region in scene.regions:
            hist = region.colour_hist.reshape(COLOUR_GRID_SHAPE)
            offset = region.mean_lab[None, :] - self.mean_lab
            dl = np.clip(offset[:, 0], *c.light_l)
            dt = np.clip(offset[:, 1:] @ LIGHT_DIRECTION_AB, *c.light_t)
            shift = np.stack([dl, dt * LIGHT_DIRECTION_AB[0], dt * LIGHT_DIRECTION_AB[1]], 1)
            area_px = self.area_mm2 / region.mm_per_px**2
            shape = np.abs(np.log(np.maximum(region.moments_mm2, 1.0) / self.moments_mm2)).sum(1)
            score = _region_evidence(self.bins, self.weights, area_px, shift / COLOUR_BIN,
                                     np.ascontiguousarray(hist, dtype=np.float32),
                                     float(region.pixels), float(c.unexplained_weight),
                                     np.minimum(shape / 0.5, 1.0), float(c.shape_weight))
            np.maximum(out, score, out=out)
        return np.clip(out, 0.0, 1.0)


_STEPS = np.stack(np.meshgrid([-1, 0, 1], [-1, 0, 1], [-1, 0, 1], indexing="ij"),
                  -1).reshape(-1, 3)
"""A colour bin and its 26 neighbours, as offsets (27, 3)."""


@njit(parallel=True)
def _refine_kernel(palettes, lab, xy_mm, starts, mm_per_px, shifts, area_mm2, moments_mm2,
                   low, bin_width, grid):  # pragma: no cover - compiled
    """Best ``min(v, 1) - 0.5 max(ln v, 0) - 0.3 shape min(v, 1)`` per model (R,) over the
    regions (pixels ``starts[g]:starts[g + 1]``) and the two lights (none, ``shifts[r, g]``),
    of the region pixels whose colour bin is in the model's palette (R, bins)."""
    r_count = palettes.shape[0]
    g_count = len(starts) - 1
    nl, na, nb = grid[0], grid[1], grid[2]
    out = np.zeros(r_count)
    for r in prange(r_count):
        best = 0.0
        for g in range(g_count):
            for light in range(2):
                n = 0
                sx = 0.0
                sy = 0.0
                sxx = 0.0
                syy = 0.0
                sxy = 0.0
                for p in range(starts[g], starts[g + 1]):
                    cl = (lab[p, 0] - shifts[r, g, 0] * light - low[0]) / bin_width - 0.5
                    ca = (lab[p, 1] - shifts[r, g, 1] * light - low[1]) / bin_width - 0.5
                    cb = (lab[p, 2] - shifts[r, g, 2] * light - low[2]) / bin_width - 0.5
                    il = min(max(int(np.floor(cl + 0.5)), 0), nl - 1)
                    ia = min(max(int(np.floor(ca + 0.5)), 0), na - 1)
                    ib = min(max(int(np.floor(cb + 0.5)), 0), nb - 1)
                    if not palettes[r, (il * na + ia) * nb + ib]:
                        continue
                    x = float(xy_mm[p, 0])
                    y = float(xy_mm[p, 1])
                    n += 1
                    sx += x
                    sy += y
                    sxx += x * x
                    syy += y * y
                    sxy += x * y
                if n < 3:
                    continue
                v = n * mm_per_px[g] ** 2 / area_mm2[r]
                cxx = (sxx - sx * sx / n) / (n - 1)
                cyy = (syy - sy * sy / n) / (n - 1)
                cxy = (sxy - sx * sy / n) / (n - 1)
                half = 0.5 * (cxx + cyy)
                root = np.sqrt(max(0.25 * (cxx - cyy) ** 2 + cxy * cxy, 0.0))
                m1 = max(half + root, 1.0)
                m2 = max(half - root, 1.0)
                shape = (abs(np.log(m1 / moments_mm2[r, 0]))
                         + abs(np.log(m2 / moments_mm2[r, 1]))) / 0.5
                shape = min(shape, 1.0)
                fill = min(v, 1.0)
                score = fill - 0.5 * max(np.log(v), 0.0) - 0.3 * shape * fill
                if score > best:
                    best = score
        out[r] = best
    return out


@njit(parallel=True)
def _region_evidence(bins, weights, area_px, shift, hist, pixels, unexplained, shape,
                     shape_weight):  # pragma: no cover - compiled
    """Best of (no shift, ``shift[m]`` in bins) of ``c - unexplained (1 - e) - shape_weight
    shape[m] min(c, e)`` per model (M,); the region's counts are read between bins by
    trilinear interpolation."""
    m_count, k_count = weights.shape
    nl, na, nb = hist.shape
    out = np.empty(m_count)
    for m in prange(m_count):
        best = -10.0
        for trial in range(2):
            held = 0.0
            for k in range(k_count):
                w = weights[m, k]
                if w <= 0.0:
                    continue
                pl = bins[m, k, 0] + shift[m, 0] * trial
                pa = bins[m, k, 1] + shift[m, 1] * trial
                pb = bins[m, k, 2] + shift[m, 2] * trial
                if pl < 0 or pa < 0 or pb < 0 or pl > nl - 1 or pa > na - 1 or pb > nb - 1:
                    continue
                il = min(int(pl), nl - 2)
                ia = min(int(pa), na - 2)
                ib = min(int(pb), nb - 2)
                fl = pl - il
                fa = pa - ia
                fb = pb - ib
                have = 0.0
                for dl in range(2):
                    wl = fl if dl else 1.0 - fl
                    for da in range(2):
                        wa = fa if da else 1.0 - fa
                        for db in range(2):
                            wb = fb if db else 1.0 - fb
                            have += wl * wa * wb * hist[il + dl, ia + da, ib + db]
                want = w * area_px[m]
                held += want if want < have else have
            c = held / area_px[m]
            e = min(held / pixels, 1.0)
            s = c - unexplained * (1.0 - e) - shape_weight * shape[m] * min(c, e)
            if s > best:
                best = s
        out[m] = best
    return out
