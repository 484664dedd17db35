"""``identify``: which model of a library lies on the table, and where, or none.

For one stereo pair and a list of photo-models:

1. **Shared work, once**: the images' log-opponent feature pyramids
   (:class:`~photomodel.fitness.StereoFeatures`), used by every model and stage.
2. **Drop early** (:func:`~photomodel.identify.colour_evidence`): models whose colours the
   images lack cannot be the answer; the ``max_candidates`` models with the most colour
   evidence (at least ``min_evidence``) go on. This costs milliseconds per model, far less
   than a pose search.
3. **Locate each candidate** (those whose scan is trusted first; the others only while none
   of those is found: ``trusted_first``) with the default ``soft`` method
   (:func:`~photomodel.locate.locate_in_features`: a correlation scan of flat poses on the
   coarsest level, then local refinement of its peaks down to level 0), each with its own
   seed derived from the call's seed, the model's name and the attempt (a model's search does
   not depend on which others are in the library).
4. **Decide**: the candidate with the highest score is the answer when its score reaches
   ``min_score``, the threshold calibrated on simulated scenes and stored with the package
   (:func:`~photomodel.identify.load_threshold`); otherwise none of the models is on the
   table. The runner-up is the next best located candidate.
5. **Second look**: when no candidate reaches ``min_score``, the candidates are searched
   again with fresh seeds (``retries`` times), each keeping its better result, with
   ``locate``'s retry configuration (GA beside the same scan peaks, more restarts; the scan
   is computed once per candidate). The scan sees the garment as lit at the model station
   and misses it now and then under other light; a scene with a library garment then scores
   low once, not twice, while a scene without one costs the extra searches and stays below
   the threshold.

The score is ``locate``'s (:func:`~photomodel.fitness.score_terms`), in [0, 1]: the mean of
the ``soft`` fitness at level 0 (about the share of the model's points that agree with both
images once the band around the outline is accounted for) and the outline evidence (how much
of the outline both cameras see as an edge), each 20 mm patch of the model free to slide by
up to 1 mm (cloth beside a fold is pulled out of place).
"""

from __future__ import annotations

import time
import zlib
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from photomodel.camera import StereoRig
from photomodel.fitness import (
    PreparedModel,
    ScanResult,
    StereoFeatures,
    as_prepared,
    scan_flat_poses,
)
from photomodel.identify._screen import ScreenConfig, colour_evidence
from photomodel.locate import LocateResult, locate_in_features
from photomodel.locate._threshold import load_threshold
from photomodel.model import PhotoModel
from photomodel.search import SearchSpace

__all__ = ["Candidate", "IdentifyConfig", "IdentifyResult", "identify", "identify_in_features"]


@dataclass(frozen=True)
class IdentifyConfig:
    """Settings of :func:`identify`.

    Attributes
    ----------
    min_score : float or None
        Score from which the best model counts as found; None: the stored, calibrated
        threshold (:func:`~photomodel.identify.load_threshold`).
    max_candidates : int
        Most models that go on to the pose search (by colour evidence).
    min_evidence : float
        Colour evidence below which a model is dropped without a search.
    retries : int
        Further searches of the candidates, with fresh seeds, while none reaches
        ``min_score``.
    screen : ScreenConfig
        Settings of the colour evidence.
    trusted_first : bool
        Search the candidates whose scan is trusted (its best peak reaches
        ``ScanConfig.trusted_score``) first, and the others only while none of those reaches
        ``min_score``. An untrusted scan means the model's own colours agree nowhere in the
        images, and its search then runs the slower GA; under the station's light
        that is a model that is not there. Under another lamp every scan is untrusted and
        every candidate is searched, as without this.
    """

    min_score: float | None = None
    max_candidates: int = 3
    min_evidence: float = 0.2
    retries: int = 1
    screen: ScreenConfig = field(default_factory=ScreenConfig)
    trusted_first: bool = True

    def __post_init__(self) -> None:
        if self.min_score is not None and not 0.0 <= self.min_score <= 1.0:
            raise ValueError(f"min_score: expected a score in [0, 1], got {self.min_score}")
        if self.max_candidates < 1:
            raise ValueError(f"max_candidates: expected >= 1, got {self.max_candidates}")
        if not 0.0 <= self.min_evidence <= 1.0:
            raise ValueError(f"min_evidence: expected [0, 1], got {self.min_evidence}")
        if self.retries < 0:
            raise ValueError(f"retries: expected >= 0, got {self.retries}")


@dataclass(frozen=True)
class Candidate:
    """One model's part in an identification.

    Attributes
    ----------
    model : str
    evidence : float
        Colour evidence in [0, 1].
    result : LocateResult or None
        Its pose search, or None when it was dropped before one.
    """

    model: str
    evidence: float
    result: LocateResult | None = None

    @property
    def score(self) -> float | None:
        """The located score, None when not searched."""
        return None if self.result is None else self.result.score


@dataclass(frozen=True)
class IdentifyResult:
    """The answer of :func:`identify`.

    Attributes
    ----------
    best : LocateResult or None
        The located model with the highest score (found or not); None when no model was
        searched (an empty library, or none with colour evidence).
    found : bool
        ``best`` reaches ``min_score``: that model is on the table at ``best.T_cam1_model``.
    min_score : float
        The threshold applied.
    runner_up : Candidate or None
        The next best located candidate.
    candidates : tuple of Candidate
        Every model, by decreasing colour evidence.
    seconds : float
        Wall time of the whole identification (features included).
    """

    best: LocateResult | None
    found: bool
    min_score: float
    runner_up: Candidate | None
    candidates: tuple[Candidate, ...]
    seconds: float

    @property
    def model(self) -> str | None:
        """Name of the identified model, None when none is on the table."""
        return self.best.model if self.found and self.best is not None else None

    @property
    def score(self) -> float:
        """Score of the best located model (0 when none was searched)."""
        return 0.0 if self.best is None else self.best.score

    def to_json_dict(self) -> dict[str, Any]:
        """The ``identify --json`` object (docs/contracts.md).

        Same keys as ``locate --json`` for the best model; when none is on the table,
        ``"model": null``, ``"found": false`` and the pose fields null, with ``score`` (and
        ``best_candidate``) telling how close the best one came. Plus ``runner_up``
        (``{"model", "score"}``, both null without one), ``min_score`` and ``candidates``
        (each model's colour evidence and score, null when not searched).
        """
        if self.best is not None and self.found:
            out = self.best.to_json_dict()
            out["seconds"] = self.seconds
        else:
            out = {"model": None, "found": False, "T_cam1_model": None, "position_mm": None,
                   "quat_wxyz": None, "theta_deg": None,
                   "fitness": None if self.best is None else self.best.fitness,
                   "score": self.score, "seconds": self.seconds,
                   "best_candidate": None if self.best is None else self.best.model}
        out["runner_up"] = {"model": None if self.runner_up is None else self.runner_up.model,
                            "score": None if self.runner_up is None else self.runner_up.score}
        out["min_score"] = self.min_score
        out["candidates"] = [{"model": c.model, "evidence": c.evidence, "score": c.score}
                             for c in self.candidates]
        return out


def _model_rng(base: int, name: str, attempt: int) -> np.random.Generator:
    return np.random.default_rng([base, zlib.crc32(name.encode("utf-8")), attempt])


def identify_in_features(
    models: Sequence[PhotoModel | PreparedModel],
    features: StereoFeatures,
    *,
    config: IdentifyConfig | None = None,
    space: SearchSpace | None = None,
    rng: int | np.random.Generator | None = None,
    t0: float | None = None,
) -> IdentifyResult:
    """Identify the model on the table in a stereo pair already turned into features.

    Parameters
    ----------
    models : sequence of PhotoModel or PreparedModel
        The library (names should be unique; the first of equal names wins ties); prepared
        models keep what their searches build (:class:`~photomodel.Identifier`).
    features : StereoFeatures
    config : IdentifyConfig, optional
    space : SearchSpace, optional
        Pose search space of every model (default: the paper's experiment, the tilt measured
        from the table that faces the rig, as in :func:`~photomodel.locate.locate`).
    rng : int, Generator or None
        Seed of the searches.
    t0 : float, optional
        ``time.perf_counter()`` when the work began (default: now).

    Returns
    -------
    IdentifyResult
    """
    t0 = time.perf_counter() if t0 is None else t0
    models = [as_prepared(m) for m in models]
    c = config or IdentifyConfig()
    min_score = load_threshold().min_score if c.min_score is None else c.min_score
    space = space or SearchSpace.from_ranges(R_cam1_plane=features.rig.R_cam1_facing)
    base = int(np.random.default_rng(rng).integers(0, 2**62))
    evidence: NDArray[np.float64] = colour_evidence(models, features, c.screen)
    order = np.argsort(-evidence, kind="stable")
    chosen = [int(i) for i in order[: c.max_candidates] if evidence[i] >= c.min_evidence]
    located: dict[int, LocateResult] = {}
    scans: dict[int, ScanResult] = {}

    def one_found() -> bool:
        return bool(located) and max(r.score for r in located.values()) >= min_score

    for attempt in range(1 + c.retries):
        if one_found():
            break
        for i in chosen:
            if i not in scans:
                scans[i] = scan_flat_poses(models[i], features, space.lower, space.upper)
        order_now = sorted(chosen, key=lambda i: not (c.trusted_first and scans[i].trusted))
        for i in order_now:
            if c.trusted_first and not scans[i].trusted and one_found():
                break    # a trusted candidate is found; the rest's colours agree nowhere
            r = locate_in_features(models[i], features, space=space,
                                   rng=_model_rng(base, models[i].name, attempt),
                                   min_score=min_score, t0=time.perf_counter(), retries=0,
                                   scan=scans[i], second_look=attempt > 0)
            if i not in located or r.score > located[i].score:
                located[i] = r
    candidates = tuple(Candidate(models[int(i)].name, float(evidence[i]), located.get(int(i)))
                       for i in order)
    ranked = sorted((c_ for c_ in candidates if c_.result is not None),
                    key=lambda c_: -float(c_.result.score))  # type: ignore[union-attr]
    best = ranked[0].result if ranked else None
    runner_up = ranked[1] if len(ranked) > 1 else None
    found = best is not None and best.score >= min_score
    return IdentifyResult(best, bool(found), float(min_score), runner_up, candidates,
                          time.perf_counter() - t0)


def identify(
    models: Sequence[PhotoModel],
    rig: StereoRig,
    right_bgr: NDArray[np.uint8],
    left_bgr: NDArray[np.uint8],
    *,
    config: IdentifyConfig | None = None,
    space: SearchSpace | None = None,
    rng: int | np.random.Generator | None = None,
) -> IdentifyResult:
    """Which of ``models`` lies on the table, and its pose ``T_cam1_model``, or none.

    Parameters
    ----------
    models : sequence of PhotoModel
        The model library (:meth:`photomodel.library.ModelLibrary.load`).
    rig : StereoRig
        Camera 1 is the reference (the paper's right camera).
    right_bgr, left_bgr : ndarray (H, W, 3) uint8
        Images of camera 1 and camera 2; sizes are checked against the calibration.
    config : IdentifyConfig, optional
    space : SearchSpace, optional
    rng : int, Generator or None

    Returns
    -------
    IdentifyResult
        See the module docstring for the steps.
    """
    t0 = time.perf_counter()
    features = StereoFeatures(rig, right_bgr, left_bgr)
    return identify_in_features(models, features, config=config, space=space, rng=rng, t0=t0)
