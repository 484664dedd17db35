"""Exhaustive scan of a flat garment's image position, angle and depth by correlation.

The ``soft`` fitness of a pose that lies flat in camera 1 (no tilt) at depth ``z`` and
in-plane angle ``theta`` is, up to the light offsets, a sum over the model's samples of
their colours' agreement with the image at fixed pixel offsets from the model origin's
pixel: a correlation of agreement images with a kernel of the samples. This module computes
it for every pixel at once by FFT, on a grid of angles and depths, with

* **own colours, quantised**: the garment's palette (up to six main colours) gives one
  agreement image per colour; each inner sample votes in the image of its own colour, each
  band sample against the image of the garment colour next to it. A print colour that covers
  another object (red flowers against red trousers) then counts only where the model has
  that colour, not everywhere as the palette fitness counts it;
* **both cameras**: camera 2's agreement images are carried into camera 1's pixels through
  the plane at depth ``z`` (its homography, with the lens distortion), so a peak needs the
  garment at that depth in both images; camera 1's images are undistorted the same way;
* **one light offset per scan** (by default none: the garment as lit at the model
  station). Under another lamp or exposure the own colours agree nowhere and the scan is
  not trusted; :func:`relight_scan` then scans again with the offsets the scene's colours
  suggest (:mod:`photomodel.fitness._light`);
* **one kernel set for a few depths**: a garment's image at depth ``z`` is its image at
  ``z_ref`` scaled by ``z_ref / z``, so instead of a kernel per depth, each depth's
  agreement images are resampled onto a pinhole grid whose pixels are as large on the
  garment as camera 1's at ``z_ref``, the farthest depth of its group
  (``ScanConfig.depths_per_kernel``). The kernels' spectra depend on the model, the camera
  and the search box only, and are kept in the PreparedModel for the next stereo pair.

Every pixel, angle step and depth step is visited, so a garment whose fitness peak is narrow
(a small garment, half covered) is not missed as a GA misses it. The peaks, distinct in
image position or angle, are hypotheses for :func:`~photomodel.search.pyramid_search`.
"""

from __future__ import annotations

import math
from collections import OrderedDict
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
import rocket_fft  # noqa: F401  (scipy.fft inside numba: registers its overloads)
import scipy.fft
from numba import prange
from numpy.typing import ArrayLike, NDArray

from photomodel._jit import njit
from photomodel.camera import StereoRig
from photomodel.fitness._light import light_offset_candidates
from photomodel.fitness._prepared import PreparedModel, as_prepared
from photomodel.fitness._samples import ModelSamples, SampleSpacing, model_samples
from photomodel.fitness._soft import SoftFitness, StereoFeatures, level_spacing
from photomodel.geometry import facing_pose_vectors
from photomodel.model import PhotoModel

_PLANS_PER_MODEL = 3
"""Scan plans kept per model (each holds its depth groups' kernel spectra, about 3.5 MB a
group on level 4 with 45 angles): ``locate`` asks for two, the coarse scan's and level 3's."""

__all__ = ["ScanConfig", "ScanResult", "prepare_scan", "relight_scan", "scan_flat_poses",
           "scan_spacing"]


@dataclass(frozen=True)
class ScanConfig:
    """Settings of :func:`scan_flat_poses`.

    Attributes
    ----------
    level : int
        Pyramid level scanned (3: 80 x 60 pixels for a 640 x 480 camera).
    theta_step_deg : float
        Step of the in-plane angle grid.
    z_step : float
        Relative step of the depth grid (0.08: each depth 8 % beyond the last). Depth moves
        a garment's image little (the peaks of neighbouring depths lie on one camera ray);
        the refinement after the scan walks along the ray. The grid's last depth can lie
        beyond the box (925 mm for 500-900 mm); it sets its group's kernel scale and is not
        scanned (its peaks would lie outside the box).
    depths_per_kernel : int
        Consecutive depths that share one set of kernels (the group's farthest depth's;
        nearer depths are scanned at up to ``(1 + z_step)**(depths_per_kernel - 1)``
        coarser grids). Sharing saves most of the kernels' Fourier transforms; with more
        depths a set the nearest depths' grids get too coarse for a print's peak.
    hypotheses : int
        Peaks returned.
    candidates : int
        Distinct peaks ranked again by the ``soft`` fitness of the scanned level (own
        colours, light offsets free; one evaluation each) before the best ``hypotheses`` of
        them are returned. The scan sees no light offsets, so a print whose colours are
        close to the table's can rank the table first; the fitness takes the table's tint
        out.
    min_separation : float
        Two peaks of about the same angle are distinct when their camera rays differ by more
        than this (x/z and y/z; 0.04 is 27 mm at 685 mm).
    min_angle_separation_deg : float
        ... or when their angles differ by more than this.
    trusted_score : float
        Below this best score the peaks are not trusted alone (:func:`relight_scan` looks
        again, and ``locate`` runs its GA beside them when that is not trusted either). The
        scan has no light offsets: under another lamp or exposure the garment's
        own colours agree nowhere and the best peak is noise.
    relight : int
        Light offsets guessed from the scene's colours that :func:`relight_scan` scans
        with when a scan is not trusted (0: none).
    detail_level : int, optional
        Level whose sample points make the kernels and whose ``soft`` fitness ranks the
        candidates (None: ``level``). A scan of level 4 (40 x 30 pixels) with the sample
        points of level 3 and their colours blurred as level 4's: level 4's own points lie
        16 mm apart and a sock has none inside; a print's colours average there as in the
        image. :func:`~photomodel.locate.locate_in_features` looks with such a scan first.
    rank_margin : float
        A trusted scan drops the hypotheses whose re-ranking fitness lies more than this
        below the best one's: each costs an evolution strategy on level 3, and one that far
        below has not won.
    """

    level: int = 3
    theta_step_deg: float = 4.0
    z_step: float = 0.08
    depths_per_kernel: int = 3
    hypotheses: int = 3
    candidates: int = 12
    min_separation: float = 0.04
    min_angle_separation_deg: float = 17.0
    trusted_score: float = 0.065
    relight: int = 2
    rank_margin: float = 0.3
    detail_level: int | None = None

    def __post_init__(self) -> None:
        if not (self.level >= 0 and self.relight >= 0 and self.rank_margin >= 0
                and (self.detail_level is None or 0 <= self.detail_level <= self.level)
                and self.theta_step_deg > 0
                and self.z_step > 0 and 1 <= self.hypotheses <= self.candidates
                and self.min_separation >= 0 and self.depths_per_kernel >= 1
                and self.min_angle_separation_deg >= 0 and self.trusted_score >= 0):
            raise ValueError(f"ScanConfig: expected positive steps and counts, got {self}")


@dataclass(frozen=True)
class ScanResult:
    """Peaks of :func:`scan_flat_poses`, best first by the scanned level's ``soft`` fitness.

    Attributes
    ----------
    poses : ndarray (N, 6)
        Pose vectors (x, y, z mm, eps1, eps2, eps3) of the garment lying flat on a plane
        that faces the rig (:attr:`~photomodel.camera.StereoRig.R_cam1_facing`).
    scores : ndarray (N,)
        Their correlation scores: mean inner agreement minus mean band agreement, both
        cameras averaged (the ``soft`` fitness without light offsets, at grid resolution).
    maps : int
        Angle-depth pairs scanned.
    trusted : bool
        Whether the best score reaches ``ScanConfig.trusted_score``.
    light_offsets : ndarray (N, 3)
        The light offset each peak was scanned with (zero: the model station's light; see
        ``ScanConfig.relight``).
    """

    poses: NDArray[np.float64]
    scores: NDArray[np.float64]
    maps: int
    trusted: bool
    light_offsets: NDArray[np.float64] = field(default_factory=lambda: np.zeros((0, 3)))


def scan_flat_poses(model: PhotoModel | PreparedModel, features: StereoFeatures,
                    lower: NDArray[np.float64],
                    upper: NDArray[np.float64], config: ScanConfig | None = None, *,
                    light_offset: ArrayLike | None = None) -> ScanResult:
    """Scan every image position of camera 1 over a grid of angles and depths.

    The kernels' products and the peak search run on numba's threads (``NUMBA_NUM_THREADS``),
    with the same peaks on any number of them.

    Parameters
    ----------
    model : PhotoModel
    features : StereoFeatures
        Both images' feature pyramids (``config.level`` must exist).
    lower, upper : ndarray (6,)
        Search box of pose vectors (a ``SearchSpace``'s bounds): the depths and angles
        scanned; positions outside it are dropped.
    config : ScanConfig, optional
    light_offset : array (3,), optional
        Light offset (image minus model, log-opponent ``l, a, b``) the garment's colours are
        looked for with (:func:`~photomodel.fitness.light_offset_candidates`); default none,
        the light of the model station.

    Returns
    -------
    ScanResult
    """
    c = config or ScanConfig()
    if not 0 <= c.level < features.levels:
        raise ValueError(f"level: expected 0..{features.levels - 1}, got {c.level}")
    lower, upper = np.asarray(lower, dtype=np.float64), np.asarray(upper, dtype=np.float64)
    shift = np.zeros(3) if light_offset is None else np.asarray(light_offset, dtype=np.float64)
    if shift.shape != (3,):
        raise ValueError(f"light_offset: expected 3 values, got {shift.shape}")
    return _scan(as_prepared(model), features, lower, upper, c, shift)


def relight_scan(model: PhotoModel | PreparedModel, features: StereoFeatures,
                 lower: NDArray[np.float64],
                 upper: NDArray[np.float64], config: ScanConfig | None = None,
                 keep: ScanResult | None = None) -> ScanResult | None:
    """Scan again, for a scan that was not trusted, with the scene's likeliest light offsets.

    The ``config.relight`` offsets come from
    :func:`~photomodel.fitness.light_offset_candidates`. Parameters are those of
    :func:`scan_flat_poses`, and ``keep``: the plain scan, whose peaks compete with the
    relit ones in the ranking (under a dim lamp the plain scan's best score can be too low to
    trust while its peaks lie on the garment and the relit scans' best lie on the table).

    Returns
    -------
    ScanResult or None
        The peaks of the trusted relit scans (and of ``keep``), ranked again by the scanned
        level's fitness (light offsets free), with the offset each was scanned with; None
        when no relit scan is trusted (the garment's colours agree nowhere under any of
        them).
    """
    c = config or ScanConfig()
    model = as_prepared(model)
    samples = model_samples(model, scan_spacing(c))
    relit = [scan_flat_poses(model, features, lower, upper, c, light_offset=offset)
             for _, offset in light_offset_candidates(samples.f_in,
                                                      features.pyramids[0][c.level],
                                                      count=c.relight)] if c.relight else []
    relit = [r for r in relit if r.trusted]
    if not relit:
        return None
    peaks = relit if keep is None else [*relit, keep]
    merged = ScanResult(np.concatenate([r.poses for r in peaks]),
                        np.concatenate([r.scores for r in peaks]), sum(r.maps for r in peaks),
                        True, np.concatenate([r.light_offsets for r in peaks]))
    return _ranked(model, features, c, merged, margin=np.inf)


def prepare_scan(model: PhotoModel | PreparedModel, features: StereoFeatures,
                 lower: NDArray[np.float64],
                 upper: NDArray[np.float64], config: ScanConfig | None = None) -> None:
    """Build and keep what :func:`scan_flat_poses` with ``config`` needs of ``model``.

    That is, beside the images: its kernels' spectra for each depth group and the depths'
    pinhole grids. They depend on the model, the rig, the image size and the box (``lower``,
    ``upper``) only; a scan builds them at its first use, and
    :func:`~photomodel.locate.prepare_model` builds them before the model's first stereo pair
    instead. ``features`` gives the rig and the image size; its images are not read.
    """
    c = config or ScanConfig()
    if not 0 <= c.level < features.levels:
        raise ValueError(f"level: expected 0..{features.levels - 1}, got {c.level}")
    model = as_prepared(model)
    labels = _labelled(model, features, c)
    _scan_plan(model, features, np.asarray(lower, dtype=np.float64),
               np.asarray(upper, dtype=np.float64), c, labels)


def _scan(model: PreparedModel, features: StereoFeatures, lower: NDArray[np.float64],
          upper: NDArray[np.float64], c: ScanConfig, shift: NDArray[np.float64]
          ) -> ScanResult:
    """One scan of :func:`scan_flat_poses`, the garment's colours shifted by ``shift``."""
    labels = _labelled(model, features, c)
    palette, weights, colours = labels.samples.palette, labels.weights, labels.colours
    rig = features.rig
    targets, weights32 = (palette[colours] + shift).astype(np.float32), weights.astype(np.float32)
    agree1, agree2 = (_agreements(p[c.level], targets, weights32) for p in features.pyramids)
    thetas = _angle_grid(lower[5], upper[5], c.theta_step_deg)
    plan = _scan_plan(model, features, lower, upper, c, labels)
    peaks = np.concatenate([np.zeros((0, 5)),
                            *(_group_peaks(group, agree1, agree2, thetas) for group in plan)])
    scanned = sum(len(group.depths) for group in plan)
    peaks = peaks[np.lexsort(-peaks.T[::-1])]    # best score first (ties: farther, ...)
    found = _distinct_peaks(peaks, lower, upper, c, scanned * len(thetas))
    # The scan's grid is square to camera 1; a garment on the table faces the rig.
    found = replace(found, poses=facing_pose_vectors(found.poses, rig.R_cam1_facing),
                    light_offsets=np.tile(shift, (len(found.poses), 1)))
    if len(found.poses) <= c.hypotheses:
        return found
    return _ranked(model, features, c, found,
                   margin=c.rank_margin if found.trusted else np.inf)


@dataclass(frozen=True)
class _Labels:
    """A scan's samples with each one's palette colour (see :func:`_labelled`)."""

    samples: ModelSamples
    weights: NDArray[np.float64]
    label_in: NDArray[np.intp]
    label_out: NDArray[np.intp]
    colours: NDArray[np.intp]


def _labelled(model: PreparedModel, features: StereoFeatures, c: ScanConfig) -> _Labels:
    """The samples a scan with ``c`` correlates, each labelled with its nearest palette
    colour (the match's colour weights), and the colours used; the labels kept per samples
    and colour tolerances (every pair's scans ask for the same)."""
    samples = model_samples(model, scan_spacing(c))
    m = features.match

    def make() -> tuple[NDArray[np.float64], NDArray[np.intp], NDArray[np.intp],
                        NDArray[np.intp]]:
        weights = np.array([1 / m.sigma_l**2, 1 / m.sigma_c**2, 1 / m.sigma_c**2])
        label_in = _nearest(samples.f_in, samples.palette, weights)
        label_out = _nearest(samples.f_out, samples.palette, weights)
        return weights, label_in, label_out, np.unique(np.concatenate([label_in, label_out]))

    return _Labels(samples, *samples.kept.get(("labels", float(m.sigma_l), float(m.sigma_c)),
                                              make))


@dataclass(frozen=True)
class _GroupPlan:
    """What a scan needs of one depth group besides the images: the kernels' spectra (A, C,
    H, W // 2 + 1) and FFT ``shape`` (H, W), and for each of its ``depths`` (D,) inside the
    box: its pinhole grid's size ``sizes`` (D, 2), both cameras' remap maps ``maps`` (D, 4,
    h, w) (camera 1's u, v, camera 2's u, v; -1 beyond a depth's size) and its pixels' rays
    (x/z, y/z) ``rays`` (D, h, w, 2)."""

    kernels: NDArray[np.complex64]
    shape: tuple[int, int]
    depths: NDArray[np.float64]
    sizes: NDArray[np.intp]
    maps: NDArray[np.float32]
    rays: NDArray[np.float64]


def _scan_plan(model: PreparedModel, features: StereoFeatures, lower: NDArray[np.float64],
               upper: NDArray[np.float64], c: ScanConfig, labels: _Labels) -> list[_GroupPlan]:
    """The depth groups of a scan with ``c`` (samples ``labels``) that have depths inside the
    box (see :func:`_group_peaks`). They depend on the model, the rig, the image size and the
    box only, and are kept in the PreparedModel (at most ``_PLANS_PER_MODEL``; the grids also
    with :func:`_depth_grids`): a cell looks for one garment in many stereo pairs, and the
    kernels' spectra would otherwise be about half of each scan's time."""
    m = features.match
    K1 = features.camera_matrices(c.level)[0]
    h, w = features.pyramids[0][c.level].shape[:2]
    rig_key = features.rig.calibration_key
    key = (c, m, rig_key, K1.tobytes(), h, w, lower.tobytes(), upper.tobytes())
    return model.kept.recent(
        "scan plans", key,
        lambda: _make_plan(model, features, lower, upper, c, labels, K1, (h, w)),
        _PLANS_PER_MODEL)


def _make_plan(model: PreparedModel, features: StereoFeatures, lower: NDArray[np.float64],
               upper: NDArray[np.float64], c: ScanConfig, labels: _Labels,
               K1: NDArray[np.float64], size: tuple[int, int]) -> list[_GroupPlan]:
    """:func:`_scan_plan`'s groups, built (``K1``: camera 1's matrix at the scanned level,
    ``size`` its image's (rows, columns))."""
    samples, label_in, label_out, colours = (labels.samples, labels.label_in, labels.label_out,
                                             labels.colours)
    h, w = size
    scale = 0.5**c.level
    rig = features.rig
    zs = _depth_grid(lower[2], upper[2], c.z_step)
    thetas = _angle_grid(lower[5], upper[5], c.theta_step_deg)
    radius_mm = max(np.linalg.norm(samples.p_in[:, :2], axis=1).max(),
                    np.linalg.norm(samples.p_out[:, :2], axis=1).max())
    points = [(samples.p_in[:, :2], label_in, 1.0 / len(label_in)),
              (samples.p_out[:, :2], label_out, -1.0 / len(label_out))]
    rig_key = rig.calibration_key
    plan = []
    for first in range(0, len(zs), c.depths_per_kernel):
        # The group's depths are scanned on pinhole grids whose pixels are as large on the
        # garment as camera 1's are at the group's farthest depth: one set of kernels.
        z_ref = zs[min(first + c.depths_per_kernel, len(zs)) - 1]
        reach = int(np.ceil(radius_mm * K1[0, 0] / z_ref)) + 2
        shape = (scipy.fft.next_fast_len(h + reach), scipy.fft.next_fast_len(w + reach))
        group = []    # (z, its pinhole grid's rays and both cameras' remap maps)
        for z in zs[first:first + c.depths_per_kernel]:
            if z > upper[2]:    # the grid's last depth: its peaks would all lie outside the box
                continue
            K_z = K1.copy()
            K_z[:2] *= z / z_ref
            h_z, w_z = int(np.ceil(h * z / z_ref)), int(np.ceil(w * z / z_ref))
            group.append((float(z), _depth_grids(rig, rig_key, scale, K_z, h_z, w_z, float(z))))
        if not group:
            continue
        kernels = _conj_spectra(
            _kernels(points, colours, thetas, K1[0, 0] / z_ref, K1[1, 1] / z_ref, shape))
        sizes = np.array([rays.shape[:2] for _, (rays, _, _) in group], dtype=np.intp)
        rows, cols = sizes.max(axis=0)
        maps = np.full((len(group), 4, rows, cols), -1.0, dtype=np.float32)
        rays2 = np.zeros((len(group), rows, cols, 2))
        for d, (_, (rays, maps1, maps2)) in enumerate(group):
            for k, part in enumerate((*maps1, *maps2)):
                maps[d, k, :sizes[d, 0], :sizes[d, 1]] = part
            rays2[d, :sizes[d, 0], :sizes[d, 1]] = rays[..., :2]
        plan.append(_GroupPlan(kernels, shape, np.array([z for z, _ in group]), sizes, maps,
                               rays2))
    return plan


def _group_peaks(group: _GroupPlan, agree1: NDArray[np.float32], agree2: NDArray[np.float32],
                 thetas: NDArray[np.float64]) -> NDArray[np.float64]:
    """The local maxima (N, 5: score, z, angle, ray x, ray y) of each depth of a group that
    shares one set of kernel spectra (:class:`_GroupPlan`): both cameras' agreement images
    ``agree1``, ``agree2`` (C, h, w) carried onto each depth's pinhole grid and correlated
    with every angle's kernels, the group's depths in one batch; depth by depth, each map's
    in the order of the angles. Four compiled calls a group, whatever its depths."""
    both = np.zeros((len(group.depths), len(agree1), *group.shape), dtype=np.float32)
    _carried(agree1, agree2, group.maps, group.sizes, both)
    found = _correlated_maxima(_planes_rfft2(both), group.kernels, *group.shape, group.sizes,
                               _PER_MAP)
    return _peak_rows(found, group.depths, thetas, group.rays)


def _ranked(model: PreparedModel, features: StereoFeatures, c: ScanConfig, found: ScanResult,
            margin: float) -> ScanResult:
    """The best ``c.hypotheses`` peaks of ``found`` by the scanned level's ``soft`` fitness
    (light offsets free), without those more than ``margin`` below the best one's."""
    fitness = SoftFitness(model, features, _detail(c))(found.poses)
    best = np.argsort(-fitness, kind="stable")[:c.hypotheses]
    best = best[fitness[best] >= fitness[best[0]] - margin]
    return ScanResult(found.poses[best], found.scores[best], found.maps, found.trusted,
                      found.light_offsets[best])


def _detail(c: ScanConfig) -> int:
    """The level of ``c``'s sample points and ranking (``detail_level``, else ``level``)."""
    return c.level if c.detail_level is None else c.detail_level


def scan_spacing(c: ScanConfig) -> SampleSpacing:
    """The spacing of the samples a scan with ``c`` correlates: the sample points of level
    ``c.detail_level`` (else ``c.level``), the colours blurred as the scanned level's."""
    spacing = level_spacing(_detail(c))
    if _detail(c) == c.level:
        return spacing
    return replace(spacing, blur_mm=level_spacing(c.level).blur_mm)


def _kept(store: OrderedDict[Any, Any], key: Any, make: Callable[[], Any], limit: int) -> Any:
    """``store[key]``, made by ``make()`` when missing; the ``limit`` last used are kept."""
    if key in store:
        store.move_to_end(key)
    else:
        store[key] = make()
        while len(store) > limit:
            store.popitem(last=False)
    return store[key]


def _nearest(colours: NDArray[np.float64], palette: NDArray[np.float64],
             weights: NDArray[np.float64]) -> NDArray[np.intp]:
    """Index of each colour's nearest palette colour (weighted squared distance)."""
    d2 = (((colours[:, None, :] - palette[None, :, :]) ** 2) * weights).sum(axis=-1)
    return np.argmin(d2, axis=1)


@njit
def _agreements(image, colours, weights):  # pragma: no cover - compiled
    """``exp(-d^2 / 2)`` of every pixel's feature (H, W, 3) float32 to each of ``colours``
    (C, 3), ``d^2`` weighted by ``weights`` (3,): (C, H, W) float32."""
    H, W = image.shape[:2]
    out = np.empty((colours.shape[0], H, W), dtype=np.float32)
    for k in range(colours.shape[0]):
        for r in range(H):
            for c in range(W):
                d0 = image[r, c, 0] - colours[k, 0]
                d1 = image[r, c, 1] - colours[k, 1]
                d2 = image[r, c, 2] - colours[k, 2]
                s = d0 * d0 * weights[0] + d1 * d1 * weights[1] + d2 * d2 * weights[2]
                out[k, r, c] = np.exp(np.float32(-0.5) * s)
    return out


_GRIDS: OrderedDict[tuple[Any, ...], tuple[NDArray[np.float64], tuple[NDArray[np.float32], ...],
                                             tuple[NDArray[np.float32], ...]]] = OrderedDict()
_GRIDS_KEPT = 64


def _depth_grids(rig: StereoRig, rig_key: tuple[bytes, ...], scale: float,
                 K_z: NDArray[np.float64], h_z: int, w_z: int, z: float
                 ) -> tuple[NDArray[np.float64], tuple[NDArray[np.float32], ...],
                            tuple[NDArray[np.float32], ...]]:
    """The pixel rays (h_z, w_z, 3) of the pinhole grid ``K_z`` and the positions in both
    cameras' images (pixels ``* scale``; :func:`_carried`'s maps) of its pixels at depth
    ``z``: they depend on the rig and the search box only, so the last ``_GRIDS_KEPT`` are
    kept."""
    def make() -> tuple[NDArray[np.float64], tuple[NDArray[np.float32], ...],
                        tuple[NDArray[np.float32], ...]]:
        rays = _pixel_rays(K_z, h_z, w_z)
        P = (rays * z).reshape(-1, 3)
        return (rays, _remap_maps(rig.cam1.project(P) * scale, h_z, w_z),
                _remap_maps(rig.cam2.project(P @ rig.R.T + rig.T) * scale, h_z, w_z))

    return _kept(_GRIDS, (rig_key, scale, K_z.tobytes(), h_z, w_z, z), make, _GRIDS_KEPT)


def _pixel_rays(K: NDArray[np.float64], h: int, w: int) -> NDArray[np.float64]:
    """Rays (h, w, 3) with z = 1 of every pixel of a pinhole camera ``K``."""
    u, v = np.meshgrid(np.arange(w, dtype=np.float64), np.arange(h, dtype=np.float64))
    return np.stack([(u - K[0, 2]) / K[0, 0], (v - K[1, 2]) / K[1, 1], np.ones_like(u)], axis=-1)


def _remap_maps(uv: NDArray[np.float64], h: int, w: int
                ) -> tuple[NDArray[np.float32], NDArray[np.float32]]:
    """The maps (u, v), each (h, w) float32, of pixel positions (h * w, 2); NaN (behind the
    camera) -> -1."""
    uv = np.nan_to_num(uv, nan=-1.0)
    return (uv[:, 0].reshape(h, w).astype(np.float32), uv[:, 1].reshape(h, w).astype(np.float32))


def _depth_grid(z_min: float, z_max: float, step: float) -> NDArray[np.float64]:
    """Depths from ``z_min`` in relative steps, the last within a step of ``z_max`` (it can
    lie beyond it: it then sets its kernel group's scale only, and is not scanned)."""
    n = int(np.ceil(np.log(z_max / z_min) / np.log1p(step))) + 1
    return z_min * (1.0 + step) ** np.arange(n) if z_max > z_min else np.array([z_min])


def _angle_grid(eps3_min: float, eps3_max: float, step_deg: float) -> NDArray[np.float64]:
    """In-plane angles (rad) spanning the eps3 bounds, ``step_deg`` apart and centred."""
    lo, hi = 2 * np.arcsin(eps3_min), 2 * np.arcsin(eps3_max)
    step = np.deg2rad(step_deg)
    n = int(np.floor((hi - lo) / step)) + 1
    return (lo + hi) / 2 + (np.arange(n) - (n - 1) / 2) * step


def _kernels(points: list[tuple[NDArray[np.float64], NDArray[np.intp], float]],
             colours: NDArray[np.intp], thetas: NDArray[np.float64], fx: float, fy: float,
             shape: tuple[int, int]) -> NDArray[np.float32]:
    """Correlation kernels (A, C, H, W): each sample's weight splatted bilinearly at its pixel
    offset from the model origin (periodic), per angle and colour."""
    slot = np.full(colours.max() + 1, -1, dtype=np.int64)
    slot[colours] = np.arange(len(colours))
    out = np.zeros((len(thetas), len(colours), *shape), dtype=np.float32)
    for p, label, weight in points:
        _splat(out, np.ascontiguousarray(p, dtype=np.float64), slot[label], weight,
               np.cos(thetas), np.sin(thetas), fx, fy)
    return out


@njit
def _splat(out, p, slot, weight, cos, sin, fx, fy):  # pragma: no cover - compiled
    """Add ``weight`` at each point's rotated, scaled pixel offset, bilinearly and modulo the
    kernel's size, into ``out[angle, slot[point]]``."""
    H = out.shape[2]
    W = out.shape[3]
    for a in range(cos.shape[0]):
        for i in range(p.shape[0]):
            du = fx * (cos[a] * p[i, 0] - sin[a] * p[i, 1])
            dv = fy * (sin[a] * p[i, 0] + cos[a] * p[i, 1])
            iu = np.floor(du)
            iv = np.floor(dv)
            fu = du - iu
            fv = dv - iv
            c0 = int(iu) % W
            c1 = (int(iu) + 1) % W
            r0 = int(iv) % H
            r1 = (int(iv) + 1) % H
            k = slot[i]
            out[a, k, r0, c0] += weight * (1.0 - fu) * (1.0 - fv)
            out[a, k, r0, c1] += weight * fu * (1.0 - fv)
            out[a, k, r1, c0] += weight * (1.0 - fu) * fv
            out[a, k, r1, c1] += weight * fu * fv


@njit(parallel=True, fastmath=True)
def _carried(agree1, agree2, maps, sizes, out):  # pragma: no cover - compiled
    """``out[d, k, :h, :w]`` = the mean of both cameras' agreement images ``agree1``,
    ``agree2`` (C, H, W) carried onto depth ``d``'s grid (``sizes[d]`` = (h, w)): each
    bilinearly interpolated at its camera's pixel positions ``maps[d]`` (camera 1's u, v,
    camera 2's u, v), a pixel outside the image counting 0 (as ``cv2.remap`` with a constant
    border 0 does, to 1e-7). One call for every depth and colour of a group, the grids' rows
    on numba's threads."""
    C, H, W = agree1.shape
    rows = maps.shape[2]
    for m in prange(maps.shape[0] * rows):
        d, r = m // rows, m % rows
        if r >= sizes[d, 0]:
            continue
        for c in range(sizes[d, 1]):
            for k in range(C):
                out[d, k, r, c] = 0.0
            for cam in range(2):
                img = agree1 if cam == 0 else agree2
                u = maps[d, 2 * cam, r, c]
                v = maps[d, 2 * cam + 1, r, c]
                if not (u > -1.0 and v > -1.0 and u < W and v < H):
                    continue
                x0 = int(math.floor(u))
                y0 = int(math.floor(v))
                fu = u - x0
                fv = v - y0
                for dy in range(2):
                    y = y0 + dy
                    if y < 0 or y >= H:
                        continue
                    wy = 0.5 * (fv if dy else 1.0 - fv)
                    for dx in range(2):
                        x = x0 + dx
                        if x < 0 or x >= W:
                            continue
                        weight = np.float32(wy * (fu if dx else 1.0 - fu))
                        for k in range(C):
                            out[d, k, r, c] += weight * img[k, y, x]


_PER_MAP = 4
"""Local maxima kept per (depth, angle) map."""


@njit
def _peak_rows(found, depths, thetas, rays):  # pragma: no cover - compiled
    """The positive rows of :func:`_correlated_maxima`'s ``found`` (D, A, per_map, 3) as peaks
    (N, 5: score, z, angle, ray x, ray y), depth by depth, each depth's maps in the order of
    the angles and each map's best first; ``rays`` (D, h, w, 2) each depth's pixel rays."""
    D, A, per_map = found.shape[0], found.shape[1], found.shape[2]
    n = 0
    for d in range(D):
        for a in range(A):
            for k in range(per_map):
                if found[d, a, k, 2] > 0:
                    n += 1
    out = np.empty((n, 5))
    i = 0
    for d in range(D):
        for a in range(A):
            for k in range(per_map):
                if found[d, a, k, 2] > 0:
                    v = int(found[d, a, k, 0])
                    u = int(found[d, a, k, 1])
                    out[i, 0] = found[d, a, k, 2]
                    out[i, 1] = depths[d]
                    out[i, 2] = thetas[a]
                    out[i, 3] = rays[d, v, u, 0]
                    out[i, 4] = rays[d, v, u, 1]
                    i += 1
    return out


@njit(parallel=True)
def _planes_rfft2(x):  # pragma: no cover - compiled
    """``scipy.fft.rfft2`` of every plane of ``x`` (D, C, H, W) float32, the planes on
    numba's threads (Rocket-FFT: the same PocketFFT as ``scipy.fft``, the same spectra to
    the bit)."""
    D, C, H, W = x.shape
    out = np.empty((D, C, H, W // 2 + 1), dtype=np.complex64)
    for m in prange(D * C):
        f = scipy.fft.rfft2(x[m // C, m % C])
        for i in range(H):
            for j in range(W // 2 + 1):
                out[m // C, m % C, i, j] = f[i, j]
    return out


@njit
def _conj_spectra(x):  # pragma: no cover - compiled
    """The complex conjugate of ``scipy.fft.rfft2`` of every plane of ``x`` (A, C, H, W)
    float32: (A, C, H, W // 2 + 1) complex64, the same spectra to the bit (Rocket-FFT: the
    same PocketFFT). On one thread: a model's kernels take a few milliseconds, and on a busy
    machine waiting for numba's threads can take longer than that."""
    A, C, H, W = x.shape
    out = np.empty((A, C, H, W // 2 + 1), dtype=np.complex64)
    for a in range(A):
        for k in range(C):
            f = scipy.fft.rfft2(x[a, k])
            for i in range(H):
                for j in range(W // 2 + 1):
                    out[a, k, i, j] = np.conj(f[i, j])
    return out


@njit(parallel=True, fastmath=True)
def _correlated_maxima(spectra, kernels, H, W, sizes, per_map):  # pragma: no cover - compiled
    """Rows (D, A, per_map, 3) of (row, column, value) of the highest local maxima of each
    map ``irfft2(sum_k spectra[d, k] * kernels[a, k], s=(H, W))`` (``spectra`` (D, C, H,
    W // 2 + 1), ``kernels`` (A, C, H, W // 2 + 1)), best first, value 0 where a map has
    fewer; map ``(d, a)`` is cropped to its depth's ``sizes[d]`` (rows, columns), its edge
    repeated beyond them.

    One task an angle on numba's threads: its products for every depth, then each depth's
    inverse transform (Rocket-FFT: the same PocketFFT as ``scipy.fft``, the same maps to the
    bit) and its maxima; neither the sums nor the maps are kept. The products run along the
    spectra's rows, which vectorises (an angle's kernels, 40-80 kB, stay in cache for the
    depths)."""
    D, C, _, Wh = spectra.shape
    A = kernels.shape[0]
    out = np.zeros((D, A, per_map, 3))
    for a in prange(A):
        _angle_maxima(spectra, kernels, np.int64(a), H, W, sizes, out)
    return out


@njit(fastmath=True)
def _angle_maxima(spectra, kernels, a, H, W, sizes, out):  # pragma: no cover - compiled
    """Angle ``a``'s part of :func:`_correlated_maxima`: ``out[:, a]``."""
    D, C, _, Wh = spectra.shape
    acc = np.zeros((D, H, Wh), dtype=spectra.dtype)
    for d in range(D):
        for k in range(C):
            for i in range(H):
                for j in range(Wh):
                    acc[d, i, j] += spectra[d, k, i, j] * kernels[a, k, i, j]
    for d in range(D):
        f = scipy.fft.irfft2(acc[d], s=(H, W))
        _map_maxima(f, sizes[d, 0], sizes[d, 1], out[d, a])


@njit
def _map_maxima(f, H, W, best):  # pragma: no cover - compiled
    """Fill ``best`` (per_map, 3) with (row, column, value) of the highest 3 x 3 local
    maxima of map ``f`` cropped to (``H``, ``W``), its edge repeated beyond them, best
    first; rows of value 0 stay where it has fewer."""
    per_map = best.shape[0]
    for r in range(H):
        for c in range(W):
            v = f[r, c]
            if v <= best[per_map - 1, 2]:
                continue
            is_max = True
            for dr in range(-1, 2):
                rr = min(max(r + dr, 0), H - 1)
                for dc in range(-1, 2):
                    if f[rr, min(max(c + dc, 0), W - 1)] > v:
                        is_max = False
            if not is_max:
                continue
            k = per_map - 1
            while k > 0 and best[k - 1, 2] < v:
                for i in range(3):
                    best[k, i] = best[k - 1, i]
                k -= 1
            best[k, 0] = r
            best[k, 1] = c
            best[k, 2] = v


def _distinct_peaks(peaks: NDArray[np.float64], lower: NDArray[np.float64],
                    upper: NDArray[np.float64], c: ScanConfig, maps: int) -> ScanResult:
    """The best ``c.candidates`` of ``peaks`` (N, 5: score, z, angle, ray x, ray y; best
    first), distinct in camera ray or angle, inside the box, as pose vectors; trusted by the
    best one's score."""
    p = np.asarray(peaks, dtype=np.float64).reshape(-1, 5)
    xyz = np.column_stack([p[:, 3] * p[:, 1], p[:, 4] * p[:, 1], p[:, 1]])
    inside = np.all((xyz >= lower[:3]) & (xyz <= upper[:3]), axis=1)
    kept = p[inside][_greedy_distinct(np.ascontiguousarray(p[inside]), c.min_separation,
                                       math.radians(c.min_angle_separation_deg),
                                       c.candidates)]
    z = kept[:, 1]
    poses = np.column_stack([kept[:, 3] * z, kept[:, 4] * z, z, np.zeros((len(kept), 2)),
                             np.sin(kept[:, 2] / 2)])
    scores = kept[:, 0]
    return ScanResult(poses, scores, maps, bool(len(scores) and scores[0] >= c.trusted_score))


@njit
def _greedy_distinct(peaks, min_separation, min_angle, count):  # pragma: no cover - compiled
    """Rows of ``peaks`` (N, 5: score, z, angle, ray x, ray y; best first) kept greedily:
    each unless a kept one lies within ``min_separation`` in camera ray and ``min_angle``
    in angle; at most ``count``."""
    kept = np.empty(count, dtype=np.intp)
    n = 0
    for i in range(peaks.shape[0]):
        if n >= count:
            break
        distinct = True
        for j in range(n):
            k = kept[j]
            if (math.hypot(peaks[i, 3] - peaks[k, 3], peaks[i, 4] - peaks[k, 4]) <= min_separation
                    and abs(peaks[i, 2] - peaks[k, 2]) <= min_angle):
                distinct = False
                break
        if distinct:
            kept[n] = i
            n += 1
    return kept[:n]
