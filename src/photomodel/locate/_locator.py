"""``Locator``: one photo-model prepared for one rig, then called once per stereo pair."""

from __future__ import annotations

import os
import time
from collections.abc import Callable
from dataclasses import replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from photomodel.camera import StereoRig
from photomodel.errors import InputError
from photomodel.fitness import PreparedModel, ScanConfig, StereoFeatures
from photomodel.geometry import eps_from_rotation
from photomodel.locate._locate import (
    COARSE_SCAN,
    LocateResult,
    LocateSettings,
    Method,
    locate_in_features,
    locate_paper,
    paper_method,
)
from photomodel.locate._prepare import prepare_model
from photomodel.locate._scale import locate_unknown_scale
from photomodel.locate._threshold import load_threshold
from photomodel.model import PhotoModel, resampled_model, scale_known
from photomodel.search import Optimizer, PyramidConfig, SearchSpace

__all__ = ["Locator"]


class Locator:
    """Find one photo-model's pose ``T_cam1_model`` in stereo pairs of one rig.

    Made once per model and rig: it prepares the model for the rig (its samples at every
    pyramid level and camera blur, its scans' kernels) and reads the threshold, so that each
    call pays for the search only. Calls may run in several threads at once.

    Parameters
    ----------
    model : PhotoModel
    rig : StereoRig
        Camera 1 is the reference (the paper's right camera).
    space : SearchSpace, optional
        The pose search box. Default: the paper's experiment (x within +-255 mm, y within
        +-195 mm, z 500-900 mm, in-plane angle +-53 deg, tilt +-10 deg from the table that
        faces the rig).
    method : {"default", "paper"} or PaperMethod
        ``"default"``: the ``soft`` fitness searched coarse to fine; ``"paper"``: the paper's
        fitness and binary GA (:class:`~photomodel.locate.PaperMethod` for its variants).
    min_score : float, optional
        Score in [0, 1] from which the garment counts as found. Default: the threshold file
        ``threshold`` (default method) or the paper method's ``min_score``.
    threshold : path, optional
        Threshold file to read the default method's ``min_score`` from (default:
        :func:`~photomodel.locate.threshold_path`: the user's calibrated file, else the
        package's).

    A model of unknown scale (``photomodel build --scale unknown``) is located with its
    scale searched (:func:`~photomodel.locate.locate_unknown_scale`) until a call finds it;
    the Locator then keeps that scale (:attr:`scale`), and later calls are ordinary. Every
    result of such a model carries ``scale``.

    Examples
    --------
    >>> locate = Locator(model, rig)                       # doctest: +SKIP
    >>> result = locate(right, left, rng=0)                # doctest: +SKIP
    >>> result.found, result.position_mm                   # doctest: +SKIP
    """

    def __init__(self, model: PhotoModel | PreparedModel, rig: StereoRig,
                 space: SearchSpace | None = None, method: Method = "default", *,
                 min_score: float | None = None,
                 threshold: str | os.PathLike[str] | None = None) -> None:
        prepared = model if isinstance(model, PreparedModel) else None
        model = prepared.model if prepared is not None else model
        if not isinstance(model, PhotoModel):
            raise TypeError(f"model: expected a PhotoModel, got {type(model).__name__}")
        if not isinstance(rig, StereoRig):
            raise TypeError(f"rig: expected a StereoRig, got {type(rig).__name__}")
        self.model = model
        self.nominal: PhotoModel | None = None if scale_known(model) else model
        self.scale: float | None = None
        self.rig = rig
        self.space = space or SearchSpace.from_ranges(R_cam1_plane=rig.R_cam1_facing)
        self.method = method
        self._paper = paper_method(method)
        if min_score is not None and not 0.0 <= min_score <= 1.0:
            raise ValueError(f"min_score: expected a score in [0, 1], got {min_score}")
        if min_score is None:
            min_score = (self._paper.min_score if self._paper is not None
                         else load_threshold(threshold).min_score)
        self.min_score = float(min_score)
        if self.nominal is not None and self._paper is not None:
            raise ValueError("method: a model of unknown scale needs the default method")
        self.prepared = prepared or PreparedModel(model)
        if self._paper is None and self.nominal is None:
            self._prepare()

    def _prepare(self) -> None:
        """Prepare the model for the rig's image size (skipped when the calibration does not
        give it: the first stereo pair prepares it then)."""
        w, h = self.rig.cam1.image_size
        w2, h2 = self.rig.cam2.image_size
        if not (w and h and w2 and h2):
            return
        self.prepare(StereoFeatures.blank(self.rig))

    def prepare(self, features: StereoFeatures) -> bool:
        """Prepare the model for ``features``' rig and image size (done once; see
        :func:`~photomodel.locate.prepare_model`). True when anything was built."""
        return prepare_model(self.prepared, features, space=self.space,
                             scans=(COARSE_SCAN, ScanConfig()))

    def __call__(self, right_bgr: NDArray[np.uint8], left_bgr: NDArray[np.uint8],
                 rng: int | np.random.Generator | None = None, *,
                 start: NDArray[np.float64] | None = None,
                 progress: Callable[[Optimizer], None] | None = None) -> LocateResult:
        """The pose of the model in one stereo pair.

        Parameters
        ----------
        right_bgr, left_bgr : ndarray (H, W, 3) uint8
            Camera 1 and camera 2 images (BGR, as :func:`~photomodel.read_image` gives).
        rng : int, Generator or None
            Seed of the stochastic search.
        start : ndarray (4, 4), optional
            A pose ``T_cam1_model`` (mm) near the answer, e.g. the last frame's: the search
            starts there instead of scanning the whole box (default method only); the
            caller falls back to a full search when the result is not found.
        progress : callable, optional
            Called with the optimiser after each generation (paper methods: a progress
            bar).

        Returns
        -------
        LocateResult
        """
        self.rig.cam1.check_image(right_bgr, "right image")
        self.rig.cam2.check_image(left_bgr, "left image")
        t0 = time.perf_counter()
        if self._paper is not None:
            if start is not None:
                raise ValueError("start: a start pose needs the default method")
            return locate_paper(self.model, self.rig, right_bgr, left_bgr, self._paper,
                                space=self.space, min_score=self.min_score, rng=rng,
                                progress=progress, t0=t0)
        features = StereoFeatures(self.rig, right_bgr, left_bgr)
        return self.locate_features(features, rng, start=start, t0=t0)

    def locate_features(self, features: StereoFeatures,
                        rng: int | np.random.Generator | None = None, *,
                        start: NDArray[np.float64] | None = None, **options: Any
                        ) -> LocateResult:
        """The default method on a stereo pair already turned into features (shared by
        several models: :class:`~photomodel.Identifier`). ``options`` are those of
        :func:`~photomodel.locate.locate_in_features` (``settings``, ``scan``,
        ``second_look``, ``t0``, ``min_score``)."""
        if self._paper is not None:
            raise ValueError("locate_features: the paper's method works on images, not "
                             "features")
        options.setdefault("min_score", self.min_score)
        if self.nominal is not None and self.scale is None:
            result = locate_unknown_scale(self.nominal, features, space=self.space, rng=rng,
                                          min_score=options["min_score"],
                                          t0=options.get("t0"))
            if result.found and result.scale is not None:
                self.scale = result.scale
                self.model = resampled_model(self.nominal, result.scale)
                self.prepared = PreparedModel(self.model)
            return result
        if start is not None:
            T = np.asarray(start, dtype=np.float64)
            if T.shape != (4, 4) or not np.all(np.isfinite(T)):
                raise InputError("start", f"expected a finite 4 x 4 pose, got shape {T.shape}")
            x0 = np.concatenate([T[:3, 3], eps_from_rotation(T[:3, :3])])
            seed = self.space.clip(x0[None])[0]
            options.update(settings=LocateSettings(
                retries=0, coarse_scan=None, pyramid=replace(PyramidConfig(), coarse_level=2)),
                seeds=[seed])
        result = locate_in_features(self.prepared, features, space=self.space, rng=rng,
                                    **options)
        return result if self.scale is None else replace(result, scale=self.scale)

    def __repr__(self) -> str:
        method = self.method if isinstance(self.method, str) else "PaperMethod(...)"
        return (f"Locator({self.model.name!r}, method={method!r}, "
                f"min_score={self.min_score:.3f})")
