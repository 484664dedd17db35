"""``Tracker``: a garment's pose at camera rate while the hand or the garment moves.

Per stereo pair (a frame), with its timestamp:

1. **Predict** the pose from the last measured ones (:class:`ConstantVelocity`, SE(3)).
2. **Track**: take feature pyramids of two windows only, around the predicted outline in each
   camera (:class:`~photomodel.track.WindowFeatures`), reduced ``2**d`` times when the hand
   is close (the garment then covers ``4**d`` times the pixels; level ``j`` of the reduced
   windows has the resolution on the garment that the model's level-``j`` samples were drawn
   for), and refine the pose with the strain by Gauss-Newton on the ``soft`` fitness at
   sample levels 1 and 0 (:func:`~photomodel.search.gauss_newton_refine`), from the
   prediction.
3. **Test for a loss**: too little of the garment inside the images, too little agreement of
   its visible part (the inner points' agreement less the band's, over the points inside
   the images), or a pose farther from the prediction than the motion allows. Each reports
   ``lost`` with the reason and hands the frame to detection.
4. **Detect** (the first frame, and after a loss): a full locate
   (:class:`~photomodel.locate.Locator`), first a local search from the last pose when
   there is one, then the whole search box; when the hand is close, a second box drawn for
   the near range (``TrackerConfig.near_z_mm``) first. A frame with no detection is
   ``lost`` and has no pose. A detection where the last velocity predicts the garment
   keeps that velocity (a garment still moving after a loss); elsewhere it starts at rest.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import NDArray

from photomodel.camera import StereoRig
from photomodel.errors import InputError
from photomodel.fitness import NO_SLACK, SoftFitness, StereoFeatures, score_terms
from photomodel.geometry import (
    eps_from_rotation,
    pose_vectors_to_matrices,
    rotation_angle_deg,
    strained_matrices,
)
from photomodel.locate import LocateResult, Locator
from photomodel.model import PhotoModel
from photomodel.search import GaussNewtonConfig, SearchResult, SearchSpace, gauss_newton_refine
from photomodel.track._motion import ConstantVelocity
from photomodel.track._result import TrackResult
from photomodel.track._roi import Window, WindowFeatures, window_of_points

__all__ = ["Tracker", "TrackerConfig"]

WORKING_DISTANCE_MM = 685.0
"""Distance at which the model's level-0 samples match a hand camera's level-0 pixels."""


@dataclass(frozen=True)
class TrackerConfig:
    """Settings of :class:`Tracker`.

    Attributes
    ----------
    fps : float
        Frame rate assumed for frames given without a timestamp.
    levels : tuple of int
        Sample levels refined in a tracked frame, coarse to fine.
    fallback_levels : tuple of int
        Levels refined again from the prediction when the first refinement fails a loss
        test (a prediction farther off than the fine level's basin); empty: none.
    score_level : int
        Sample level of the reported score (the rigid score, no patch slack).
    margin_mm : float
        The windows reach this far (mm on the garment) beyond the predicted outline.
    min_visible : float
        Lost when less than this share of the model's points lies inside both images.
    min_contrast : float
        Lost when the visible part's inner agreement less its band's (both cameras' mean)
        is below this.
    max_jump_mm, max_jump_deg : float
        Lost when the tracked pose lies farther than this from the prediction (position, and
        rotation angle).
    detect_x_mm, detect_y_mm : (float, float)
        Detection's position ranges in camera 1 (the default box): the whole field of view
        at the working distance, so that a garment entering the view is found.
    near_z_mm : (float, float)
        Depth range of the second search box of detection, for a hand close above the
        garment.
    near_below_mm : float
        Detection searches the near box first when the last pose lay nearer than this.
    gauss_newton : GaussNewtonConfig
        The refinement's settings in a tracked frame.
    motion : ConstantVelocity
        The motion model's settings (a fresh copy per tracker).
    """

    fps: float = 30.0
    levels: tuple[int, ...] = (0,)
    fallback_levels: tuple[int, ...] = (1, 0)
    score_level: int = 1
    margin_mm: float = 15.0
    min_visible: float = 0.2
    min_contrast: float = 0.5
    max_jump_mm: float = 40.0
    max_jump_deg: float = 20.0
    detect_x_mm: tuple[float, float] = (-420.0, 420.0)
    detect_y_mm: tuple[float, float] = (-330.0, 330.0)
    near_z_mm: tuple[float, float] = (250.0, 560.0)
    near_below_mm: float = 520.0
    gauss_newton: GaussNewtonConfig = field(
        default_factory=lambda: GaussNewtonConfig(max_iterations=12, converged_steps=5.0,
                                                  min_gain=1e-4))
    motion: ConstantVelocity = field(default_factory=ConstantVelocity)

    def __post_init__(self) -> None:
        if not (self.fps > 0 and math.isfinite(self.fps)):
            raise ValueError(f"fps: expected a positive frame rate, got {self.fps}")
        if not self.levels or min(self.levels) < 0 or list(self.levels) != sorted(
                self.levels, reverse=True):
            raise ValueError(f"levels: expected levels >= 0, coarse to fine, got {self.levels}")
        if self.fallback_levels and (min(self.fallback_levels) < 0 or list(
                self.fallback_levels) != sorted(self.fallback_levels, reverse=True)):
            raise ValueError(f"fallback_levels: expected levels >= 0, coarse to fine, got "
                             f"{self.fallback_levels}")
        if self.score_level < 0:
            raise ValueError(f"score_level: expected >= 0, got {self.score_level}")
        if not 0.0 <= self.min_visible <= 1.0:
            raise ValueError(f"min_visible: expected [0, 1], got {self.min_visible}")
        if self.margin_mm < 0 or self.max_jump_mm <= 0 or self.max_jump_deg <= 0:
            raise ValueError("margin_mm >= 0, max_jump_mm > 0 and max_jump_deg > 0 expected")
        lo, hi = self.near_z_mm
        if not 0 < lo < hi:
            raise ValueError(f"near_z_mm: expected 0 < LO < HI, got {self.near_z_mm}")


@dataclass
class _State:
    """What a tracked frame starts from."""

    T: NDArray[np.float64]
    strain: NDArray[np.float64]
    blur_mm: float


class Tracker:
    """Follow one photo-model's pose ``T_cam1_model`` through a stereo sequence.

    Parameters
    ----------
    model : PhotoModel
    rig : StereoRig
    space : SearchSpace, optional
        Detection's search box (default: the Locator's, widened to ``config.detect_x_mm``
        and ``detect_y_mm``).
    config : TrackerConfig, optional
    min_score : float, optional
        Detection's threshold (default: the calibrated one, as ``Locator``).

    Examples
    --------
    >>> track = Tracker(model, rig)                               # doctest: +SKIP
    >>> for right, left, t in frames:                              # doctest: +SKIP
    ...     r = track(right, left, t_s=t)
    ...     print(r.frame, r.mode, r.position_mm if r.found else None)
    """

    def __init__(self, model: PhotoModel, rig: StereoRig, space: SearchSpace | None = None,
                 *, config: TrackerConfig | None = None, min_score: float | None = None
                 ) -> None:
        self.config = config or TrackerConfig()
        c = self.config
        space = space or SearchSpace.from_ranges(x_mm=c.detect_x_mm, y_mm=c.detect_y_mm,
                                                 R_cam1_plane=rig.R_cam1_facing)
        self.locator = Locator(model, rig, space, min_score=min_score)
        self._near: Locator | None = None
        self.rig = rig
        self.motion = replace(self.config.motion)
        self._track_space = SearchSpace.from_ranges(
            x_mm=(-2000.0, 2000.0), y_mm=(-2000.0, 2000.0), z_mm=(100.0, 2000.0),
            theta_deg=140.0, tilt_deg=20.0, R_cam1_plane=rig.R_cam1_facing)
        self.reset()

    @property
    def model(self) -> PhotoModel:
        return self.locator.model

    @property
    def min_score(self) -> float:
        """Detection's threshold."""
        return self.locator.min_score

    def reset(self) -> None:
        """Start over: the next frame is frame 0 and is detected."""
        self._frame = 0
        self._t_last: float | None = None
        self._state: _State | None = None
        self._last_seen: _State | None = None
        self.motion.reset()

    def _near_locator(self) -> Locator:
        if self._near is None:
            lo, hi = self.config.near_z_mm
            c = self.config
            space = SearchSpace.from_ranges(c.detect_x_mm, c.detect_y_mm, (lo, hi),
                                            R_cam1_plane=self.rig.R_cam1_facing)
            self._near = Locator(self.model, self.rig, space, min_score=self.min_score)
        return self._near

    def __call__(self, right_bgr: NDArray[np.uint8], left_bgr: NDArray[np.uint8],
                 t_s: float | None = None, rng: int | np.random.Generator | None = None,
                 *, predicted: NDArray[np.float64] | None = None) -> TrackResult:
        """The pose in the next frame of the sequence.

        Parameters
        ----------
        right_bgr, left_bgr : ndarray (H, W, 3) uint8
            Camera 1's and camera 2's images.
        t_s : float, optional
            The frame's time, s (default: the frame index over ``config.fps``). A time that
            does not advance restarts the tracking (noted in the result).
        rng : int, Generator or None
            Seed of a detection's search.
        predicted : ndarray (4, 4), optional
            ``T_cam1_model`` the caller expects in this frame, mm (a moving hand: the last
            pose carried by the arm's known motion). Used instead of the motion model's
            prediction: where the refinement starts, what the jump test compares with, and
            where a detection looks first.

        Returns
        -------
        TrackResult
        """
        t0 = time.perf_counter()
        self.rig.cam1.check_image(right_bgr, "right image")
        self.rig.cam2.check_image(left_bgr, "left image")
        frame = self._frame
        note = None
        if t_s is None:
            t = frame / self.config.fps if self._t_last is None else (
                self._t_last + 1.0 / self.config.fps)
        else:
            t = float(t_s)
            if not math.isfinite(t):
                raise InputError("t_s", f"expected a finite time in s, got {t_s!r}")
            if self._t_last is not None and t <= self._t_last:
                note = (f"t_s {t:g} s does not advance from {self._t_last:g} s: tracking "
                        "restarted")
                self._state = None
                self.motion.reset()
        self._frame += 1
        self._t_last = t
        T_given = None if predicted is None else _checked_pose(predicted, "predicted")
        result: TrackResult | None = None
        if self._state is not None:
            result, why = self._track(right_bgr, left_bgr, t, frame, t0, T_given)
            if result is None:
                note = why
                self._state = None
        if result is None:
            result = self._detect(right_bgr, left_bgr, t, frame, t0, rng, T_given)
        if note is not None:
            result = replace(result, note=note)
        return replace(result, seconds=time.perf_counter() - t0)

    # -- tracked frames ------------------------------------------------------------------

    def _level_offset(self, z_mm: float) -> int:
        """Image reduction ``d`` (a power of two) at which the garment at depth ``z_mm`` has
        about the working distance's resolution."""
        return max(0, int(np.floor(np.log2(WORKING_DISTANCE_MM / max(z_mm, 1.0)) + 0.5)))

    def _windows(self, T: NDArray[np.float64], strain: NDArray[np.float64], d: int,
                 points: NDArray[np.float64]) -> tuple[Window, Window] | None:
        A = strained_matrices(_pose_vector(T)[None], strain)[0]
        uv1, uv2 = self.rig.project_poses(A, points)
        z = max(float(T[2, 3]), 1.0)
        margin = self.config.margin_mm * float(self.rig.cam1.K[0, 0]) / z
        c = self.config
        align = 2 ** (d + max((*c.levels, *c.fallback_levels, c.score_level)) + 1)
        w1 = window_of_points(uv1, self.rig.cam1.image_size, margin, align)
        w2 = window_of_points(uv2, self.rig.cam2.image_size, margin, align)
        return None if w1 is None or w2 is None else (w1, w2)

    def _track(self, right: NDArray[np.uint8], left: NDArray[np.uint8], t: float, frame: int,
               t0: float, T_given: NDArray[np.float64] | None
               ) -> tuple[TrackResult | None, str]:
        assert self._state is not None
        c = self.config
        state = self._state
        T_pred = self.motion.predict(t) if T_given is None else T_given
        assert T_pred is not None
        d = self._level_offset(float(T_pred[2, 3]))
        windows = self._windows(T_pred, state.strain, d, _thinned(self._outline(state)))
        if windows is None:
            return None, "lost: the garment's predicted outline lies outside the images"
        deepest = max((*c.levels, *c.fallback_levels, c.score_level))
        features = WindowFeatures(self.rig, right, left, windows, levels=deepest + 1,
                                  level_offset=d)
        why = ""
        evaluations = 0
        for levels in (c.levels, c.fallback_levels):
            if not levels:
                continue
            search, fitness, evaluations = self._refine(features, T_pred, state, levels,
                                                        evaluations)
            x = search.x
            strain = np.asarray(search.strain, dtype=np.float64)
            T = pose_vectors_to_matrices(x[None])[0]
            A = strained_matrices(x[None], strain)[0]
            why, visible = self._loss(fitness, A, T, T_pred, windows)
            if not why:
                break
        if why:
            return None, why
        score_fitness = SoftFitness(self.locator.prepared, features, c.score_level,
                                    optics_blur_mm=state.blur_mm)
        terms = score_terms(score_fitness, A, NO_SLACK)
        self._state = _State(T, strain, state.blur_mm)
        self._last_seen = self._state
        self.motion.update(T, t)
        result = replace(search, evaluations=evaluations,
                         stop_reason=f"tracked: {search.stop_reason}")
        base = LocateResult(self.model.name, True, T, float(search.fitness), terms.score,
                            time.perf_counter() - t0, result, terms.edge_evidence,
                            terms.visible_outline)
        return _tracked(base, "track", frame, t, visible), ""

    def _outline(self, state: _State) -> NDArray[np.float64]:
        return _outline_points(self.locator, state.blur_mm)

    def _refine(self, features: WindowFeatures, T_pred: NDArray[np.float64], state: _State,
                levels: tuple[int, ...], evaluations: int
                ) -> tuple[SearchResult, SoftFitness, int]:
        """Gauss-Newton with the strain at ``levels`` in turn, from the prediction."""
        x = _pose_vector(T_pred)
        strain = state.strain
        for level in levels:
            fitness = SoftFitness(self.locator.prepared, features, level,
                                  optics_blur_mm=state.blur_mm)
            search = gauss_newton_refine(fitness, x, self._track_space, level=level,
                                         config=self.config.gauss_newton, strain=strain)
            x, strain = search.x, np.asarray(search.strain, dtype=np.float64)
            evaluations += search.evaluations
        return search, fitness, evaluations

    def _loss(self, fitness: SoftFitness, A: NDArray[np.float64], T: NDArray[np.float64],
              T_pred: NDArray[np.float64], windows: tuple[Window, Window]
              ) -> tuple[str, float]:
        """Why a tracked pose is lost ("" when it is not), and its visible share."""
        c = self.config
        visible, contrast = _visible_agreement(fitness, A, windows)
        jump_mm = float(np.linalg.norm(T[:3, 3] - T_pred[:3, 3]))
        jump_deg = rotation_angle_deg(T[:3, :3], T_pred[:3, :3])
        why = ""
        if visible < c.min_visible:
            why = f"lost: {visible:.0%} of the garment inside the images"
        elif contrast < c.min_contrast:
            why = f"lost: the visible part agrees too little ({contrast:.2f})"
        elif jump_mm > c.max_jump_mm or jump_deg > c.max_jump_deg:
            why = (f"lost: the pose jumped {jump_mm:.1f} mm, {jump_deg:.1f} deg from the "
                   "prediction")
        return why, visible

    # -- detection ------------------------------------------------------------------------

    def _detect(self, right: NDArray[np.uint8], left: NDArray[np.uint8], t: float,
                frame: int, t0: float, rng: int | np.random.Generator | None,
                T_given: NDArray[np.float64] | None = None) -> TrackResult:
        features = StereoFeatures(self.rig, right, left)
        gen = np.random.default_rng(rng)
        last = self._last_seen
        if last is not None and T_given is not None:
            last = _State(T_given, last.strain, last.blur_mm)
        best: LocateResult | None = None
        for locator, start in self._detections(last):
            r = locator.locate_features(features, gen, start=start, t0=t0)
            if best is None or r.score > best.score:
                best = r
            if r.found:
                break
        assert best is not None
        T_pred = self.motion.predict(t) if T_given is None else T_given
        if T_pred is None or not self._close(best.T_cam1_model, T_pred):
            self.motion.reset()      # put down elsewhere: its old velocity says nothing
        if not best.found:
            self._state = None
            return _tracked(replace(best, found=False), "lost", frame, t, math.nan)
        blur = best.optics_blur_mm if best.optics_blur_mm is not None else 0.5
        strain = best.strain if best.strain is not None else np.zeros(3)
        self._state = _State(best.T_cam1_model, strain, blur)
        self._last_seen = self._state
        self.motion.update(best.T_cam1_model, t)
        points = _outline_points(self.locator, blur)
        visible = _inside_share(self.rig, best.A_cam1_model, points)
        return _tracked(best, "detect", frame, t, visible)

    def _close(self, T: NDArray[np.float64], T_pred: NDArray[np.float64]) -> bool:
        """Whether a detected pose lies where the motion went on (within the jump limits of
        the prediction): then the velocity is kept."""
        c = self.config
        return (float(np.linalg.norm(T[:3, 3] - T_pred[:3, 3])) <= c.max_jump_mm
                and rotation_angle_deg(T[:3, :3], T_pred[:3, :3]) <= c.max_jump_deg)

    def _detections(self, last: _State | None) -> list[tuple[Locator, NDArray[np.float64] | None]]:
        """The searches of a detection, in turn: from the last pose, then the boxes."""
        near_first = last is not None and float(last.T[2, 3]) < self.config.near_below_mm
        boxes = [self._near_locator(), self.locator] if near_first else [self.locator]
        if last is None:
            boxes = [self.locator, self._near_locator()]
        steps: list[tuple[Locator, NDArray[np.float64] | None]] = []
        if last is not None:
            steps.append((boxes[0], last.T))
        steps.extend((box, None) for box in boxes)
        return steps

    def __repr__(self) -> str:
        return f"Tracker({self.model.name!r}, frame={self._frame})"


def _tracked(result: LocateResult, mode: str, frame: int, t: float, visible: float
             ) -> TrackResult:
    fields = {k: getattr(result, k) for k in LocateResult.__dataclass_fields__}
    return TrackResult(**fields, mode=mode, frame=frame, t_s=t,  # type: ignore[arg-type]
                       visible=visible)


def _checked_pose(T: NDArray[np.float64], name: str) -> NDArray[np.float64]:
    """``T`` as a finite (4, 4) rigid transform, or :class:`InputError` naming ``name``."""
    A = np.asarray(T, dtype=np.float64)
    if A.shape != (4, 4) or not np.isfinite(A).all():
        raise InputError(name, f"expected a finite (4, 4) pose, got shape {A.shape}")
    R = A[:3, :3]
    if not np.allclose(R @ R.T, np.eye(3), atol=1e-6) or np.linalg.det(R) <= 0:
        raise InputError(name, "its rotation part is not a rotation")
    return A


def _pose_vector(T: NDArray[np.float64]) -> NDArray[np.float64]:
    return np.concatenate([T[:3, 3], eps_from_rotation(T[:3, :3])])


def _outline_points(locator: Locator, blur_mm: float) -> NDArray[np.float64]:
    """The model's band points at level 0 (N, 3), mm: its outline, a ring's width out."""
    from photomodel.fitness import level_spacing, model_samples

    samples = model_samples(locator.prepared, level_spacing(0, optics_blur_mm=blur_mm))
    return np.asarray(samples.p_out, dtype=np.float64)


def _thinned(points: NDArray[np.float64], most: int = 400) -> NDArray[np.float64]:
    """Every k-th of ``points`` (N, ...), at most about ``most`` of them."""
    return points[:: max(1, len(points) // most)]


def _inside_share(rig: StereoRig, A: NDArray[np.float64], points: NDArray[np.float64]
                  ) -> float:
    """Share of ``points`` (N, 3) that the map ``A`` puts inside both whole images."""
    uv1, uv2 = rig.project_poses(A, points)
    inside = np.ones(len(points), dtype=bool)
    for uv, (w, h) in ((uv1, rig.cam1.image_size), (uv2, rig.cam2.image_size)):
        inside &= (uv[:, 0] >= 0) & (uv[:, 0] <= w - 1) & (uv[:, 1] >= 0) & (uv[:, 1] <= h - 1)
    return float(np.mean(inside)) if len(points) else 0.0


def _visible_agreement(fitness: SoftFitness, A: NDArray[np.float64],
                       windows: tuple[Window, Window]) -> tuple[float, float]:
    """Share of the inner points inside both windows, and the visible part's inner agreement
    less its band's (both cameras' mean; points outside a window count 0 inside, 1 in the
    band, in the fitness's sums)."""
    fitness.evaluate_transforms(A[None])
    terms = fitness.last_terms[0]                  # per camera: (fitness, S_in, S_out, ...)
    rig = fitness.features.rig
    s = fitness.samples
    shares = []
    for points in (_thinned(s.p_in), _thinned(s.p_out)):
        uv1, uv2 = rig.project_poses(A, points)
        cams = []
        for uv, w in ((uv1, windows[0]), (uv2, windows[1])):
            ok = ((uv[:, 0] >= w.x0) & (uv[:, 0] <= w.x1 - 1) & (uv[:, 1] >= w.y0)
                  & (uv[:, 1] <= w.y1 - 1))
            cams.append(float(np.mean(ok)) if len(points) else 0.0)
        shares.append(cams)
    (in1, in2), (out1, out2) = shares
    visible = min(in1, in2)
    contrast = []
    for cam, (fin, fout) in enumerate(((in1, out1), (in2, out2))):
        if fin <= 0.0:
            contrast.append(0.0)
            continue
        s_in = float(terms[cam, 1]) / fin
        s_out = (float(terms[cam, 2]) - (1.0 - fout)) / fout if fout > 0 else 0.0
        contrast.append(s_in - s_out)
    return visible, float(np.mean(contrast))
