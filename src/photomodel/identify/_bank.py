"""``DescriptorBank``: every model's descriptor in arrays, scored against a scene's regions.

For each model and each region of :func:`~photomodel.identify.scene_regions`, with the
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
from photomodel.identify._scene import Region, SceneRegions
from photomodel.model._descriptor import (
    COLOUR_BIN,
    COLOUR_GRID_SHAPE,
    ModelDescriptor,
    colour_grid_coords,
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
        grid = np.asarray(COLOUR_GRID_SHAPE)
        steps = np.stack(np.meshgrid([-1, 0, 1], [-1, 0, 1], [-1, 0, 1], indexing="ij"),
                         -1).reshape(-1, 3)
        cells0 = [self._cells(r.lab) for r in scene.regions]   # each region's bins, no shift
        palette = np.zeros(int(np.prod(grid)), dtype=bool)
        for m in np.argsort(-evidence, kind="stable")[: c.refine]:
            near = (self.bins[m][self.weights[m] > 0.01][:, None, :] + steps[None]).reshape(-1, 3)
            near = near[np.all((near >= 0) & (near < grid), axis=1)]
            palette[:] = False
            palette[np.ravel_multi_index(tuple(near.T), COLOUR_GRID_SHAPE)] = True
            best = 0.0
            for region, cells in zip(scene.regions, cells0, strict=True):
                shift = self._light_shift(m, region.mean_lab, c)
                for explained in (palette[cells], palette[self._cells(region.lab - shift)]):
                    best = max(best, self._explained_score(m, region, explained))
            out[m] = 0.5 * evidence[m] + 0.5 * best
        return np.clip(out, 0.0, 1.0)

    @staticmethod
    def _cells(lab: NDArray[np.floating]) -> NDArray[np.int64]:
        """Flat grid bins (N,) of colours (N, 3)."""
        cells = np.round(colour_grid_coords(lab)).astype(np.int64)
        return np.ravel_multi_index(tuple(cells.T), COLOUR_GRID_SHAPE)

    def _explained_score(self, m: int, region: Region, explained: NDArray[np.bool_]) -> float:
        """``min(v, 1) - 0.5 max(ln v, 0) - 0.3 shape min(v, 1)`` of model ``m`` for the
        region pixels it explains (see the module docstring)."""
        n = int(np.count_nonzero(explained))
        if n < 3:
            return 0.0
        v = n * region.mm_per_px**2 / self.area_mm2[m]
        xy = region.xy_mm[explained].astype(np.float64)
        moments = np.maximum(np.sort(np.linalg.eigvalsh(np.cov(xy.T)))[::-1], 1.0)
        shape = min(float(np.abs(np.log(moments / self.moments_mm2[m])).sum()) / 0.5, 1.0)
        return min(v, 1.0) - 0.5 * max(float(np.log(v)), 0.0) - 0.3 * shape * min(v, 1.0)

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
