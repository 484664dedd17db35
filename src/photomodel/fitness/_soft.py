"""The ``soft`` fitness: eq. (9) with graded colour agreement, sampled at sub-pixel positions.

Same structure as the paper's fitness (:mod:`photomodel.fitness._paper`): points inside the
model vote for a pose when the images show the model's colour there, points of the band
around it vote against when they show the garment's colour, and the two cameras are
averaged. What changes, and why:

* **Colour**: the log-opponent features of :mod:`photomodel.image._features` instead of the
  hue alone, so grey, white and black fabric are matched by lightness where hue has nothing
  to say.
* **Light**: for each candidate pose and camera, an offset ``o = (o_l, o_a, o_b)`` between
  the image and the model is taken out before comparing (an exposure change shifts ``l``, a
  lamp of another colour shifts ``a`` and ``b``). Chromatic shifts are not free:
  ``wb_weight * (o_a^2 + o_b^2)`` is subtracted, so a red model does not fit a green garment
  by calling it a green lamp. The offset is the one that maximises the inner points' mean
  agreement minus that penalty (three mean-shift steps from the mean difference and from
  zero, the better end kept), not the mean difference itself: a gripper or another garment
  over part of the model disagrees and would drag a mean, and with it every other point.
* **Graded votes**: a point's agreement is ``exp(-d^2 / 2)`` with
  ``d^2 = dl^2 / sigma_l^2 + (da^2 + db^2) / sigma_c^2`` after the offsets, in [0, 1].
* **Balanced terms**: ``F_c = mean_in agreement - mean_out agreement - penalty``; both means
  run over all points of their set, so ``F`` lies in [-1, 1] and is the score. An inner
  point outside the image agrees 0 and a band point outside it agrees 1: with the offsets
  free, a model laid on a plain table matches it inside, and only the band's contrast tells
  it from the garment, so a band that leaves the image must not count as contrast.
* **Sub-pixel**: bilinear samples of smoothed feature images and of their Gaussian pyramid,
  so the fitness changes continuously with the pose, which a local refinement needs.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import Any

import numba
import numpy as np
from numpy.typing import NDArray

from photomodel.camera import StereoRig
from photomodel.fitness._prepared import PreparedModel, as_prepared
from photomodel.fitness._samples import ModelSamples, SampleSpacing, model_samples
from photomodel.fitness._soft_jacobian import soft_normal_equations
from photomodel.fitness._soft_kernels import soft_colourings_terms, soft_fitness_terms
from photomodel.geometry import pose_vectors_to_matrices
from photomodel.image import feature_pyramid, log_opponent
from photomodel.model import PhotoModel

__all__ = ["SoftFitness", "SoftMatch", "StereoFeatures"]


@dataclass(frozen=True)
class SoftMatch:
    """Colour agreement of the ``soft`` fitness.

    Attributes
    ----------
    sigma_l : float
        Lightness tolerance (natural-log units: 0.1 is about 10 % brighter or darker).
    sigma_c : float
        Tolerance of the two chroma channels.
    wb_weight : float
        Cost per squared unit of chroma offset (a colour cast the pose must assume).
    smooth_sigma_px : float
        Gaussian smoothing of the level-0 feature images against sensor noise.
    edge_mix : bool
        Expect the inner ring to show the model colour mixed, in linear intensity, with the
        table colour seen just outside (the blurred edge), a fraction ``Phi(-ring_mm /
        sigma)`` of it with ``sigma = hypot(optics blur, edge_blur_mm)``. Without it a dark
        garment's edge reads lighter in log units than its colour, and the fit shrinks the
        model and moves it away.
    edge_blur_mm : float
        Linear-intensity blur of an edge besides the optics (pixel area, rendering), mm.
    min_edge_mix : float
        A smaller mixed fraction counts as none: the coarse levels' rings lie far inside the
        blur, and a fraction of 1e-3 moves a dark garment's expected ring colour by at most
        about 0.01, a tenth of the tolerances, while the mixture costs a fifth of an
        evaluation.
    """

    sigma_l: float = 0.12
    sigma_c: float = 0.12
    wb_weight: float = 0.1
    smooth_sigma_px: float = 0.7
    edge_mix: bool = True
    edge_blur_mm: float = 0.5
    min_edge_mix: float = 1e-3

    def __post_init__(self) -> None:
        if not (self.sigma_l > 0 and self.sigma_c > 0 and self.wb_weight >= 0
                and self.smooth_sigma_px >= 0 and self.edge_blur_mm > 0
                and 0 <= self.min_edge_mix < 0.5):
            raise ValueError(f"SoftMatch: expected positive tolerances, got {self}")


class StereoFeatures:
    """Feature pyramids of one stereo pair, computed once and shared by every model and level.

    Parameters
    ----------
    rig : StereoRig
    right_bgr, left_bgr : ndarray (H, W, 3) uint8
        Camera 1 and camera 2 images (sizes checked against the calibration).
    levels : int
        Pyramid levels (level k is 2**k times coarser): the search uses levels 0-3, the
        first scan of :func:`~photomodel.locate.locate_in_features` level 4.
    match : SoftMatch, optional
    """

    def __init__(self, rig: StereoRig, right_bgr: NDArray[np.uint8],
                 left_bgr: NDArray[np.uint8], levels: int = 5,
                 match: SoftMatch | None = None) -> None:
        rig.cam1.check_image(right_bgr, "right image")
        rig.cam2.check_image(left_bgr, "left image")
        match = match or SoftMatch()
        sigma = match.smooth_sigma_px
        self._set(rig, match, (feature_pyramid(log_opponent(right_bgr, sigma), levels),
                               feature_pyramid(log_opponent(left_bgr, sigma), levels)))

    @classmethod
    def from_pyramids(cls, rig: StereoRig, match: SoftMatch,
                      pyramids: tuple[list[NDArray[np.float32]], list[NDArray[np.float32]]]
                      ) -> StereoFeatures:
        """Features made of given pyramids (camera 1's and camera 2's levels (H, W, 3)
        float32, as :func:`~photomodel.image.feature_pyramid` makes them): a pair's features
        edited (:func:`~photomodel.identify.identify_all` paints found garments over)."""
        out = cls.__new__(cls)
        out._set(rig, match, pyramids)
        return out

    def _set(self, rig: StereoRig, match: SoftMatch,
             pyramids: tuple[list[NDArray[np.float32]], list[NDArray[np.float32]]]) -> None:
        """Set the rig, the match and both cameras' feature pyramids (levels (H, W, 3))."""
        self.rig = rig
        self.match = match
        self.pyramids = pyramids
        self._cameras: dict[int, tuple[NDArray[np.float64], NDArray[np.float64]]] = {}

    @classmethod
    def blank(cls, rig: StereoRig, levels: int = 5, match: SoftMatch | None = None
              ) -> StereoFeatures:
        """Features of no stereo pair: all-zero feature pyramids of the rig's calibrated
        image sizes (the sizes ``cv2.pyrDown`` gives), for what needs a pair's rig, sizes and
        levels but not its images (:func:`~photomodel.locate.prepare_model`).

        Raises
        ------
        ValueError
            When the calibration does not give both cameras' image sizes.
        """
        sizes = (rig.cam1.image_size, rig.cam2.image_size)
        if not all(w and h for w, h in sizes):
            raise ValueError(f"rig: expected calibrated image sizes, got {sizes}")
        if levels < 1:
            raise ValueError(f"levels: expected >= 1, got {levels}")

        def zeros(w: int, h: int) -> list[NDArray[np.float32]]:
            shapes = [(h, w)]
            for _ in range(levels - 1):
                shapes.append(((shapes[-1][0] + 1) // 2, (shapes[-1][1] + 1) // 2))
            return [np.zeros((*shape, 3), dtype=np.float32) for shape in shapes]

        features = cls.__new__(cls)
        features._set(rig, match or SoftMatch(), (zeros(*sizes[0]), zeros(*sizes[1])))
        return features

    @property
    def levels(self) -> int:
        """Number of pyramid levels."""
        return len(self.pyramids[0])

    def camera_matrices(self, level: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Camera matrices (3, 3) of both cameras at ``level`` (first two rows / 2**level),
        C-contiguous float64; computed once a level (a search builds a dozen fitnesses)."""
        if level not in self._cameras:
            scale = np.diag([0.5**level, 0.5**level, 1.0])
            self._cameras[level] = (_f64(scale @ self.rig.cam1.K), _f64(scale @ self.rig.cam2.K))
        return self._cameras[level]


HAND_MM_PER_PX = 0.86
"""Garment millimetres per level-0 pixel of the hand cameras at the working distance (about
685 mm at f = 800 px): converts the pyramid's blur into the model photo's."""


DEFAULT_OPTICS_BLUR_MM = 0.5
"""Optical blur assumed until the search has estimated the scene's: a hand camera in focus
(about 0.6 pixel)."""


@functools.lru_cache(maxsize=256)
def level_spacing(level: int, base: SampleSpacing | None = None,
                  optics_blur_mm: float = DEFAULT_OPTICS_BLUR_MM) -> SampleSpacing:
    """Sample spacing for pyramid ``level``: ``base`` scaled by 2**level, and the model blurs
    matched to the level's.

    ``base.blur_mm`` is the level-0 feature smoothing; ``cv2.pyrDown`` adds about one pixel of
    its input per level, so level k has a feature blur of sqrt((4**k - 1) / 3) level-0 pixels
    on top of it. ``optics_blur_mm`` is the camera's blur of the grey levels, the same at every
    level. Kept (the arguments are immutable): a search asks for a dozen a stereo pair."""
    base = base or SampleSpacing()
    blur_px = np.sqrt((4.0**level - 1.0) / 3.0 + (base.blur_mm / HAND_MM_PER_PX) ** 2)
    return replace(base.scaled(2.0**level, blur_mm=float(blur_px * HAND_MM_PER_PX)),
                   optics_blur_mm=float(optics_blur_mm))


def _f64(a: NDArray[np.floating] | NDArray[np.integer]) -> NDArray[np.float64]:
    """``a`` as a C-contiguous float64 array."""
    return np.ascontiguousarray(a, dtype=np.float64)


def _xy_rows(points: NDArray[np.floating]) -> NDArray[np.float64]:
    """The x and y (2, N) of model-plane points (N, >= 2), by row, C-contiguous float64."""
    return np.ascontiguousarray(np.asarray(points)[:, :2].T, dtype=np.float64)


@dataclass(frozen=True)
class _SampleArrays:
    """What the kernels take of one ``ModelSamples``, in their types: the inner points' x and
    y by row (2, N_in), their colours (N_in, 3), the band's points (2, N_out) and colours
    (float64; the points by row so that the projections load them four at a time,
    :func:`~photomodel.fitness._kernels.plane_pixels`), each inner point's band point of
    the edge mixture (int64, -1: none) and the table of a fitness without it (all -1), the
    inner colours linear, the signed residual weights (``SoftFitness.residual_weights``)
    and each camera's half of them."""

    points: tuple[NDArray[np.float64], ...]
    table_out: NDArray[np.int64]
    no_table: NDArray[np.int64]
    lin_in: NDArray[np.float64]
    weights: NDArray[np.float64]
    half_weights: NDArray[np.float64]

    @property
    def xy_in(self) -> NDArray[np.float64]:
        """The inner points' x and y by row (2, N_in)."""
        return self.points[0]

    @property
    def xy_out(self) -> NDArray[np.float64]:
        """The band's points' x and y by row (2, N_out)."""
        return self.points[2]


_NO_PALETTE = np.zeros((0, 3))


def _sample_arrays(samples: ModelSamples) -> _SampleArrays:
    """:class:`_SampleArrays` of ``samples``, kept with them: a pair's search builds a dozen
    fitnesses of the same samples."""
    def make() -> _SampleArrays:
        n_in, n_out = len(samples.p_in), len(samples.p_out)
        none = np.full(n_in, -1, dtype=np.int64)
        table = samples.table_out if samples.table_out is not None else none
        weights = np.concatenate([np.full(n_in, 1.0 / n_in),
                                  np.full(n_out, -1.0 / max(n_out, 1))])
        return _SampleArrays(
            (_xy_rows(samples.p_in), _f64(samples.f_in), _xy_rows(samples.p_out),
             _f64(samples.f_out)),
            np.ascontiguousarray(table, dtype=np.int64), none, _f64(samples.lin_in),
            weights, _f64(weights / 2.0))

    return samples.kept.get("arrays", make)


class SoftFitness:
    """The ``soft`` fitness of one model at one pyramid level (see the module docstring).

    Parameters
    ----------
    model : PhotoModel
    features : StereoFeatures
    level : int
        Pyramid level to sample (0 = full resolution).
    spacing : SampleSpacing, optional
        Defaults to :func:`level_spacing` of ``level`` and ``optics_blur_mm``.
    palette_weight : float
        A sample agrees at least this fraction as well as the best of the garment's main
        colours (is it garment at all?), not only as well as its own point's colour (is it
        this part of the garment?). 0 = own colours only. A print's own pattern makes narrow
        peaks; the palette widens them to the garment's size, for the global search.
    optics_blur_mm : float
        The scene camera's optical blur, mm on the garment (ignored with ``spacing``).
    name : str
    """

    def __init__(self, model: PhotoModel | PreparedModel, features: StereoFeatures,
                 level: int = 0,
                 spacing: SampleSpacing | None = None, *, palette_weight: float = 0.0,
                 optics_blur_mm: float = DEFAULT_OPTICS_BLUR_MM, name: str = "soft") -> None:
        if not 0 <= level < features.levels:
            raise ValueError(f"level: expected 0..{features.levels - 1}, got {level}")
        self.name = name
        self.prepared = as_prepared(model)
        self.model = self.prepared.model
        self.features = features
        self.level = level
        spacing = spacing or level_spacing(level, optics_blur_mm=optics_blur_mm)
        self.samples: ModelSamples = model_samples(self.prepared, spacing)
        if not 0.0 <= palette_weight <= 1.0:
            raise ValueError(f"palette_weight: expected [0, 1], got {palette_weight}")
        self.palette_weight = float(palette_weight)
        self.palette = self.samples.palette if palette_weight > 0 else _NO_PALETTE
        self.K1, self.K2 = features.camera_matrices(level)
        m = features.match
        self._args = (1.0 / m.sigma_l**2, 1.0 / m.sigma_c**2, float(m.wb_weight))
        arrays = _sample_arrays(self.samples)
        self.edge_mix_fraction = 0.0
        self._table_out = arrays.no_table
        if m.edge_mix and self.samples.table_out is not None:
            sigma = float(np.hypot(spacing.optics_blur_mm, m.edge_blur_mm))
            fraction = 0.5 * math.erfc(spacing.ring_mm / sigma / math.sqrt(2.0))
            self.edge_mix_fraction = fraction if fraction >= m.min_edge_mix else 0.0
            self._table_out = arrays.table_out
        self._lin_in = arrays.lin_in
        self._weights = arrays.weights
        self._half_weights = arrays.half_weights    # each camera's half
        self.last_terms: NDArray[np.float64] = np.zeros((0, 2, 6))
        # The kernels' arguments, each of one fixed type (C-contiguous float64, the images
        # float32, the table int64): one compiled specialisation of every numba loop. The
        # samples' arrays are kept with them (_sample_arrays), the cameras' with the features.
        rig = features.rig
        geometry = tuple(_f64(a) for a in (rig.R, rig.T, self.K1, rig.cam1.distortion12,
                                           self.K2, rig.cam2.distortion12))
        images = tuple(np.ascontiguousarray(p[level], dtype=np.float32)
                       for p in features.pyramids)
        inv_var_l, inv_var_c, wb_weight = self._args
        self._kernel_args = (
            *geometry, *arrays.points, _f64(self.palette), self.palette_weight, *images,
            inv_var_l, inv_var_c, wb_weight, self._table_out, float(self.edge_mix_fraction),
            self._lin_in)
        self._normal_args = (
            *geometry, *arrays.points, *images, math.sqrt(inv_var_l), math.sqrt(inv_var_c),
            self._table_out, float(self.edge_mix_fraction), self._lin_in, self._half_weights,
            wb_weight)

    def score(self, fitness: float) -> float:
        """The fitness clipped to [0, 1] (it is already normalised)."""
        return float(np.clip(fitness, 0.0, 1.0))

    def __call__(self, poses: NDArray[np.float64]) -> NDArray[np.float64]:
        """Fitness (P,) of pose vectors (P, 6) = (x, y, z mm, eps1, eps2, eps3)."""
        return self.evaluate_transforms(pose_vectors_to_matrices(poses))

    def evaluate_transforms(self, T_cam1_model: NDArray[np.float64]) -> NDArray[np.float64]:
        """Fitness (P,) of transforms (P, 4, 4); per-camera terms kept in ``last_terms``."""
        T = _f64(np.reshape(T_cam1_model, (-1, 4, 4)))
        f, self.last_terms = soft_fitness_terms(T, numba.get_num_threads(), self._kernel_args)
        return f

    def evaluate_colourings(self, others: Sequence[SoftFitness],
                            T_cam1_model: NDArray[np.float64]) -> NDArray[np.float64]:
        """Fitness (1 + len(others),) of this fitness and ``others`` at one map (4, 4), each
        one's ``last_terms`` set as :meth:`evaluate_transforms` sets it.

        Where ``others`` differ from this fitness only in their colours (the same model and
        level under other camera blurs: the same sample points, stereo pair and edge table,
        no palette), each camera samples its image once for all of them
        (:func:`~photomodel.fitness._soft_kernels.soft_colourings_terms`; the sampling is a
        third or more of a level-0 evaluation); otherwise each is evaluated on its own. The
        same values either way.
        """
        group = [self, *others]
        T = _f64(np.reshape(T_cam1_model, (1, 4, 4)))
        if len(group) < 2 or not all(self._same_points(g) for g in others):
            return np.array([g.evaluate_transforms(T)[0] for g in group])
        args = [g._kernel_args for g in group]
        terms = soft_colourings_terms(
            T, self._kernel_args, np.stack([a[7] for a in args]),
            np.stack([a[9] for a in args]), np.array([a[18] for a in args]),
            np.stack([a[19] for a in args]))
        for g, t in zip(group, terms, strict=True):
            g.last_terms = t[None]
        return 0.5 * (terms[:, 0, 0] + terms[:, 1, 0])

    def _same_points(self, other: SoftFitness) -> bool:
        """Whether ``other`` differs from this fitness in its colours alone (for
        :meth:`evaluate_colourings`)."""
        mine, theirs = self._kernel_args, other._kernel_args

        def same(a: Any, b: Any) -> bool:
            return a is b or (isinstance(a, np.ndarray) and isinstance(b, np.ndarray)
                              and a.shape == b.shape and bool(np.array_equal(a, b)))

        return (self.palette_weight == 0.0 and other.palette_weight == 0.0
                and all(same(mine[i], theirs[i]) for i in (*range(7), 8, 12, 13, 17))
                and mine[14:17] == theirs[14:17])

    def kernel_args(self) -> tuple[Any, ...]:
        """The arguments with which the searches' numba loops evaluate this fitness
        (:class:`~photomodel.fitness.KernelFitness`; ``soft_fitness_values`` in numba)."""
        return self._kernel_args

    def last_offsets(self) -> NDArray[np.float64]:
        """Light offsets (2, 3), (o_l, o_a, o_b) of each camera, that the last call found for
        its first pose."""
        return self.last_terms[0, :, 3:6].copy()

    def residual_weights(self) -> NDArray[np.float64]:
        """Signed weight (N_in + N_out,) of each point's agreement in one camera's term:
        ``1 / N_in`` inside, ``-1 / N_out`` in the band (see :meth:`residuals`); the caller's
        own copy."""
        return self._weights.copy()

    def normal_equations(self, A_cam1_model: NDArray[np.float64], dA: NDArray[np.float64],
                         offsets: NDArray[np.float64], with_offsets: bool = False
                         ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """The residuals' gradient (offsets held, or with their motion) and inner metric at
        one map, from the analytic Jacobian (:mod:`photomodel.fitness._soft_jacobian`).

        Parameters
        ----------
        A_cam1_model : ndarray (4, 4)
            Map of model points into camera 1 (a pose, or a strained one).
        dA : ndarray (G, 4, 4)
            Its derivative along each of G genes.
        offsets : ndarray (2, 3)
            Light offsets of each camera, held.
        with_offsets : bool
            Add the offsets' own motion with the pose to the gradient: they maximise the
            inner points' mean agreement of the plain differences less the chroma penalty,
            so by the implicit function theorem they move by ``-H_oo^-1 H_ox`` (that
            objective's Hessian in the offsets and its cross derivative with the genes), and
            each camera's term with them by its derivative in the offsets times that. The
            result is the fitness's full gradient; the held one can point far from it where
            the band decides the fitness.

        Returns
        -------
        gradient : ndarray (G,)
            ``-sum_j w_j J_j^T r_j`` over both cameras' samples (:meth:`residuals`,
            :meth:`residual_weights`; ``w_j`` a sample's weight times its agreement
            ``exp(-|r_j|^2 / 2)``, averaged over the cameras): the fitness's gradient with
            the offsets held; with ``with_offsets``, plus the offsets' term.
        metric : ndarray (G, G)
            ``sum w_j J_j^T J_j`` over the inner samples.
        """
        return soft_normal_equations(_f64(A_cam1_model), _f64(dA), _f64(offsets),
                                     bool(with_offsets), self.normal_args())

    def normal_args(self) -> tuple[Any, ...]:
        """The arguments with which Gauss-Newton's numba loop takes :meth:`normal_equations`
        (:class:`~photomodel.fitness.KernelNormalEquations`; ``soft_normal_equations``)."""
        if self.palette_weight > 0:
            raise ValueError("normal equations: defined for the own colours only "
                             "(palette_weight 0)")
        return self._normal_args

    def residuals(self, T_cam1_model: NDArray[np.float64], offsets: NDArray[np.float64]
                  ) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
        """Scaled colour residuals of transforms (P, 4, 4) at fixed light offsets (2, 3).

        Returns ``r`` (P, 2, N_in + N_out, 3), inner points first, each channel divided by
        its tolerance (a point's agreement is ``exp(-|r|^2 / 2)``), and ``ok`` (P, 2, N_in +
        N_out), whether the sample fell inside the image. Own colours only (no palette).
        """
        from photomodel.fitness._soft_kernels import soft_residuals_kernel

        if self.palette_weight > 0:
            raise ValueError("residuals: defined for the own colours only (palette_weight 0)")
        T = np.ascontiguousarray(np.asarray(T_cam1_model, dtype=np.float64).reshape(-1, 4, 4))
        rig, s = self.features.rig, self.samples
        n = len(s.p_in) + len(s.p_out)
        r = np.empty((len(T), 2, n, 3))
        ok = np.empty((len(T), 2, n), dtype=np.bool_)
        inv_var_l, inv_var_c, _ = self._args
        soft_residuals_kernel(np.ascontiguousarray(T[:, :3, :3]),
                              np.ascontiguousarray(T[:, :3, 3]), rig.R, rig.T, self.K1,
                              rig.cam1.distortion12, self.K2, rig.cam2.distortion12, s.p_in,
                              s.f_in, s.p_out, s.f_out, self.features.pyramids[0][self.level],
                              self.features.pyramids[1][self.level], math.sqrt(inv_var_l),
                              math.sqrt(inv_var_c), self._table_out, self.edge_mix_fraction,
                              self._lin_in, np.ascontiguousarray(offsets, dtype=np.float64),
                              numba.get_num_threads(), r, ok)
        return r, ok

    def slack_sums(self, A_cam1_model: NDArray[np.float64], shifts_mm: NDArray[np.float64],
                   offsets: NDArray[np.float64], cell_in: NDArray[np.intp],
                   cell_out: NDArray[np.intp], cells: int) -> NDArray[np.float64]:
        """Per-cell sums of the agreements at one map with every point slid in the model
        plane, at fixed light offsets, for the score with patch slack
        (:func:`~photomodel.fitness.score_terms`).

        Parameters
        ----------
        A_cam1_model : ndarray (4, 4)
            Map of model points into camera 1 (a pose, or a strained one).
        shifts_mm : ndarray (S, 2)
            Slides of the points along the model's x and y, mm.
        offsets : ndarray (2, 3)
            Light offsets of each camera, held.
        cell_in, cell_out : ndarray (N_in,), (N_out,)
            Cell of each inner and band point, in ``0 .. cells - 1``.
        cells : int

        Returns
        -------
        ndarray (S, 2, 3, cells)
            For each slide, camera and cell, the sum of the inner points' agreement (0
            outside the image), of the band points' (1 outside it) and of the outline pairs'
            ``a_in (1 - a_out)`` (an inner-ring point and its band point,
            :attr:`~photomodel.fitness.ModelSamples.table_out`; 0 unless both are inside;
            a pair counts in its inner point's cell). Own colours only (no palette).
        """
        from photomodel.fitness._soft_jacobian import camera_frames
        from photomodel.fitness._soft_kernels import soft_slack_sums_kernel

        if self.palette_weight > 0:
            raise ValueError("slack_sums: defined for the own colours only (palette_weight 0)")
        rig, s = self.features.rig, self.samples
        A = np.asarray(A_cam1_model, dtype=np.float64).reshape(4, 4)
        Ms, ts, _ = camera_frames(A, np.zeros((0, 4, 4)), rig.R, rig.T)
        shifts = np.ascontiguousarray(np.asarray(shifts_mm, dtype=np.float64).reshape(-1, 2))
        out = np.empty((len(shifts), 2, 3, cells))
        inv_var_l, inv_var_c, _ = self._args
        arrays = _sample_arrays(s)    # its table_out: the outline pairs (all -1 without)
        soft_slack_sums_kernel(Ms, ts, self.K1, rig.cam1.distortion12, self.K2,
                               rig.cam2.distortion12, shifts, arrays.xy_in, s.f_in,
                               arrays.xy_out, s.f_out,
                               self.features.pyramids[0][self.level],
                               self.features.pyramids[1][self.level], inv_var_l, inv_var_c,
                               self._table_out, self.edge_mix_fraction,
                               self._lin_in, np.ascontiguousarray(offsets, dtype=np.float64),
                               arrays.table_out, np.ascontiguousarray(cell_in, dtype=np.intp),
                               np.ascontiguousarray(cell_out, dtype=np.intp), out)
        return out
