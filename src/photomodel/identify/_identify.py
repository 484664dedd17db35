"""``identify``: which model of a library lies on the table, and where, or none.

For one stereo pair and a library of any size:

1. **Shared work, once**: the images' log-opponent feature pyramids
   (:class:`~photomodel.fitness.StereoFeatures`), used by every model and stage, and the
   garment-like regions beside the table with the table's stereo depth
   (:func:`~photomodel.fitness.scene_regions`).
2. **Screening** (:class:`~photomodel.identify.DescriptorBank`): every model's descriptor,
   stored in the library's index, is scored against the regions (colours at the light the
   region suggests, area, shape): milliseconds for thousands of models, no model file read.
3. **Verifying**: the best-screened models are located with the default ``soft`` method
   (:func:`~photomodel.locate.locate_in_features`), best first, each with its own seed derived
   from the call's seed, the model's name and the attempt. How many adapts to the evidence:
   those within ``candidate_margin`` of the best screening evidence (at least
   ``min_evidence``), at most ``max_candidates``, those whose coarse scan
   (:data:`~photomodel.locate.COARSE_SCAN`) is trusted first (``trusted_first``: their colours
   agree somewhere at the station's light), at most
   ``untrusted_candidates`` of the others, and once one is found with at least
   ``sure_score`` only those that the screen could not tell from it (within
   ``evidence_margin`` of its evidence). While none is found that surely, the next
   best-screened models whose coarse scan is trusted are verified too, up to rank
   ``wide_candidates`` (a garment partly hidden, or merged with an occluder into one region,
   screens lower). A model is loaded and prepared only when it is a candidate
   (:class:`~photomodel.identify.PreparedModels` keeps the recent ones).
4. **Decide**: a candidate is found when its score reaches ``min_score``, the threshold
   calibrated on simulated scenes and stored with the package
   (:func:`~photomodel.locate.load_threshold`), and its outline shows where its inside
   agrees (``min_visible_outline``); the found one with the highest score is the answer,
   otherwise none of the models is on the table. The runner-up is the next best located
   candidate.
5. **Second look**: when no candidate reaches ``min_score``, the first ``retry_candidates``
   are searched again with fresh seeds (``retries`` times) with ``locate``'s retry
   configuration; each keeps its better result.

The score is ``locate``'s (:func:`~photomodel.fitness.score_terms`), in [0, 1]: the mean of
the ``soft`` fitness at level 0 (about the share of the model's points that agree with both
images once the band around the outline is accounted for) and the outline evidence (how much
of the outline both cameras see as an edge), each 20 mm patch of the model free to slide by
up to 1 mm (cloth beside a fold is pulled out of place).
"""

from __future__ import annotations

import time
import zlib
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from photomodel.camera import StereoRig
from photomodel.fitness import (
    PreparedModel,
    ScanResult,
    SceneConfig,
    SceneRegions,
    StereoFeatures,
    as_prepared,
    scan_flat_poses,
    scene_regions,
)
from photomodel.identify._bank import BankConfig, DescriptorBank
from photomodel.identify._labels import LabelCheck
from photomodel.locate import (
    COARSE_SCAN,
    LocateResult,
    LocateSettings,
    load_threshold,
    locate_in_features,
)
from photomodel.model import ModelDescriptor, PhotoModel, describe_model
from photomodel.search import SearchSpace

__all__ = ["Candidate", "IdentifyConfig", "IdentifyResult", "identify", "identify_in_features",
           "identify_with_bank", "model_descriptor"]


@dataclass(frozen=True)
class IdentifyConfig:
    """Settings of :func:`identify`.

    Attributes
    ----------
    min_score : float or None
        Score from which the best model counts as found; None: the stored, calibrated
        threshold (:func:`~photomodel.locate.load_threshold`).
    max_candidates : int
        Most models verified by a pose search.
    min_evidence : float
        Screening evidence below which a model is never verified.
    candidate_margin : float
        Models whose evidence is more than this below the best model's are not verified.
    evidence_margin : float
        Once a model is found, further models are verified only within this of its evidence
        (look-alikes the screen cannot tell apart).
    untrusted_candidates : int
        Most candidates whose scan is not trusted (their colours agree nowhere at the
        station's light) that are located (searched with relit scans and the GA, slower): the
        best-screened ones; a scene without a library garment ends after these.
    retries : int
        Further searches with fresh seeds while none reaches ``min_score``.
    retry_candidates : int
        Models searched again in a second look (the best-screened).
    bank : BankConfig
        Settings of the screening scores.
    scene : SceneConfig
        Settings of the scene's regions.
    trusted_first : bool
        Locate the candidates whose scan is trusted first (best-screened first), the others
        only while none is found.
    shown_candidates : int
        Best-screened models listed in the answer's ``candidates`` beside those searched.
    min_visible_outline : float
        A candidate counts as found only when its outline shows where its inside agrees
        (:attr:`~photomodel.locate.LocateResult.visible_outline` at least this): a model
        lying inside a larger region of its colours (a look-alike, or a garment that is
        not in the library) scores up to about 0.5 with about 0.3-0.5 here, the garment
        itself, even half hidden, 0.65 or more.
    sure_score : float
        A found candidate scoring at least this ends the search early (the margins above);
        a weaker find lets the remaining and the wider candidates be verified too, and the
        best found wins.
    wide_candidates : int
        When none of the candidates is found, the best-screened models up to this rank are
        verified too (a garment partly hidden, or lying against an occluder in one region,
        screens lower than in full view).
    wide_trusted_only : bool
        Verify only those of the wider candidates whose coarse scan is trusted.
    coarse_min_score : float or None
        Passed to :func:`~photomodel.locate.locate_in_features` (None: its default).
    """

    min_score: float | None = None
    max_candidates: int = 6
    min_evidence: float = 0.05
    candidate_margin: float = 0.35
    evidence_margin: float = 0.15
    untrusted_candidates: int = 2
    retries: int = 1
    retry_candidates: int = 1
    bank: BankConfig = field(default_factory=BankConfig)
    scene: SceneConfig = field(default_factory=SceneConfig)
    trusted_first: bool = True
    shown_candidates: int = 10
    min_visible_outline: float = 0.58
    sure_score: float = 0.6
    wide_candidates: int = 24
    wide_trusted_only: bool = True
    coarse_min_score: float | None = None

    def __post_init__(self) -> None:
        if self.min_score is not None and not 0.0 <= self.min_score <= 1.0:
            raise ValueError(f"min_score: expected a score in [0, 1], got {self.min_score}")
        if self.max_candidates < 1:
            raise ValueError(f"max_candidates: expected >= 1, got {self.max_candidates}")
        if not 0.0 <= self.min_evidence <= 1.0:
            raise ValueError(f"min_evidence: expected [0, 1], got {self.min_evidence}")
        if self.candidate_margin < 0 or self.evidence_margin < 0:
            raise ValueError("candidate_margin, evidence_margin: expected >= 0, got "
                             f"{self.candidate_margin}, {self.evidence_margin}")
        if self.untrusted_candidates < 0:
            raise ValueError(f"untrusted_candidates: expected >= 0, got "
                             f"{self.untrusted_candidates}")
        if self.retries < 0 or self.retry_candidates < 1:
            raise ValueError(f"retries: expected >= 0 and retry_candidates >= 1, got "
                             f"{self.retries}, {self.retry_candidates}")
        if not 0.0 <= self.min_visible_outline <= 1.0 or not 0.0 <= self.sure_score <= 1.0:
            raise ValueError("min_visible_outline, sure_score: expected [0, 1], got "
                             f"{self.min_visible_outline}, {self.sure_score}")
        if self.wide_candidates < 0:
            raise ValueError(f"wide_candidates: expected >= 0, got {self.wide_candidates}")
        if self.shown_candidates < 0:
            raise ValueError(f"shown_candidates: expected >= 0, got {self.shown_candidates}")


@dataclass(frozen=True)
class Candidate:
    """One model's part in an identification.

    Attributes
    ----------
    model : str
    evidence : float
        Screening evidence in [0, 1].
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
        searched (an empty library, or no garment-like region in view).
    found : bool
        ``best`` reaches ``min_score``: that model is on the table at ``best.T_cam1_model``.
    min_score : float
        The threshold applied.
    runner_up : Candidate or None
        The next best located candidate.
    candidates : tuple of Candidate
        The models searched and the next best-screened (``shown_candidates``), by
        decreasing screening evidence.
    seconds : float
        Wall time of the whole identification (features and labels included).
    label : LabelCheck or None
        The label read in the pair, the model it names and whether that is ``model``
        (:class:`~photomodel.Identifier` reads labels; docs/method/labels.md); None when
        none was read (or labels were not read). It never changes the answer above.
    """

    best: LocateResult | None
    found: bool
    min_score: float
    runner_up: Candidate | None
    candidates: tuple[Candidate, ...]
    seconds: float
    label: LabelCheck | None = None

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
        (``{"model", "score"}``, both null without one), ``min_score``, ``candidates``
        (the best-screened models' evidence and score, null when not searched) and ``label``
        (:meth:`LabelCheck.to_json_dict`, null when no label was read).
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
        out["label"] = None if self.label is None else self.label.to_json_dict()
        return out


def _model_rng(base: int, name: str, attempt: int) -> np.random.Generator:
    return np.random.default_rng([base, zlib.crc32(name.encode("utf-8")), attempt])


def model_descriptor(model: PreparedModel) -> ModelDescriptor:
    """The descriptor of a prepared model, computed once and kept with it."""
    return model.kept.get("descriptor", lambda: describe_model(model.model))


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
        models keep what their searches build, their descriptor included.
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
    prepared = [as_prepared(m) for m in models]
    bank = DescriptorBank([m.name for m in prepared], [model_descriptor(m) for m in prepared])
    return identify_with_bank(bank, prepared.__getitem__, features, config=config, space=space,
                              rng=rng, t0=t0)


def identify_with_bank(
    bank: DescriptorBank,
    prepared: Callable[[int], PreparedModel],
    features: StereoFeatures,
    *,
    config: IdentifyConfig | None = None,
    space: SearchSpace | None = None,
    rng: int | np.random.Generator | None = None,
    t0: float | None = None,
    regions: SceneRegions | None = None,
    enough: Callable[[list[LocateResult]], bool] | None = None,
) -> IdentifyResult:
    """:func:`identify_in_features` with the library's descriptors already in a bank, each
    model prepared only when it is verified: ``prepared(i)`` gives bank entry ``i``'s model
    (:class:`~photomodel.Identifier` loads it from the library then); ``regions``: the
    pair's :func:`scene_regions` when the caller has them (with ``config.scene`` and the
    search box's depths); ``enough``: asked after each verification with every result
    located so far (verification order), True ends the verifying."""
    t0 = time.perf_counter() if t0 is None else t0
    c = config or IdentifyConfig()
    min_score = load_threshold().min_score if c.min_score is None else c.min_score
    space = space or SearchSpace.from_ranges(R_cam1_plane=features.rig.R_cam1_facing)
    base = int(np.random.default_rng(rng).integers(0, 2**62))
    if regions is None:
        regions = scene_regions(features, (float(space.lower[2]), float(space.upper[2])),
                                c.scene)
    evidence: NDArray[np.float64] = bank.evidence(regions, c.bank)
    order = np.argsort(-evidence, kind="stable")
    top = float(evidence[order[0]]) if len(order) else 0.0
    floor = max(c.min_evidence, top - c.candidate_margin)
    chosen = [int(i) for i in order[: c.max_candidates] if evidence[i] >= floor]
    settings = LocateSettings(retries=0) if c.coarse_min_score is None else \
        LocateSettings(retries=0, coarse_min_score=c.coarse_min_score)
    located: dict[int, LocateResult] = {}
    scans: dict[int, ScanResult] = {}
    models: dict[int, PreparedModel] = {}
    done = [False]

    def accepted(r: LocateResult) -> bool:
        return r.score >= min_score and not r.visible_outline < c.min_visible_outline

    def found(at_least: float = 0.0) -> int | None:
        ok = [i for i in located if accepted(located[i]) and located[i].score >= at_least]
        return max(ok, key=lambda i: located[i].score, default=None)

    def verify(i: int, attempt: int) -> None:
        if i not in models:
            models[i] = prepared(i)
        r = locate_in_features(models[i], features, space=space,
                               rng=_model_rng(base, bank.names[i], attempt),
                               min_score=min_score, t0=time.perf_counter(),
                               settings=settings, second_look=attempt > 0,
                               coarse=scans.get(i))
        if i not in located or r.score > located[i].score:
            located[i] = r
        if enough is not None and enough(list(located.values())):
            done[0] = True

    def scan(i: int) -> ScanResult:
        if i not in scans:
            models[i] = prepared(i)
            scans[i] = scan_flat_poses(models[i], features, space.lower, space.upper,
                                       COARSE_SCAN)
        return scans[i]

    def verify_in_turn(group: list[int], *, only_until_found: bool = False,
                       trusted_only: bool = False) -> None:
        for i in group:
            if done[0]:
                break
            hit = found(c.sure_score)      # a weak find does not stop the search
            if hit is not None and (only_until_found
                                    or evidence[i] < evidence[hit] - c.evidence_margin):
                break     # the rest look less like the scene than the one found
            if not trusted_only or scan(i).trusted:
                verify(i, 0)

    trusted = [i for i in chosen if scan(i).trusted or not c.trusted_first]
    verify_in_turn(trusted)
    verify_in_turn([i for i in chosen if i not in trusted][: c.untrusted_candidates],
                   only_until_found=True)   # their colours agree nowhere: only while none
    if found(c.sure_score) is None:   # a hidden or merged garment screens lower: look on
        verify_in_turn([int(i) for i in order[len(chosen): c.wide_candidates]
                        if evidence[i] >= c.min_evidence], trusted_only=c.wide_trusted_only)
    for attempt in range(1, 1 + c.retries):
        if found() is not None or done[0]:
            break
        for i in [i for i in chosen if i in located][: c.retry_candidates]:
            verify(i, attempt)
    shown = [int(i) for i in order if int(i) in located]
    shown += [int(i) for i in order[: len(chosen) + c.shown_candidates] if int(i) not in located]
    shown.sort(key=lambda i: -evidence[i])
    candidates = tuple(Candidate(bank.names[i], float(evidence[i]), located.get(i))
                       for i in shown)
    hit = found()
    ranked = sorted((c_ for c_ in candidates if c_.result is not None),
                    key=lambda c_: (c_.model != (None if hit is None else bank.names[hit]),
                                    -float(c_.result.score)))  # type: ignore[union-attr]
    best = ranked[0].result if ranked else None
    runner_up = ranked[1] if len(ranked) > 1 else None
    is_found = hit is not None
    return IdentifyResult(best, bool(is_found), float(min_score), runner_up, candidates,
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
