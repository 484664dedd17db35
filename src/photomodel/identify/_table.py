"""The whole table: every library garment in a stereo pair, which lies on which, and the order
to pick them in.

1. **Find, explain, repeat**: identify the best garment (:func:`identify_with_bank`); paint
   the pixels it explains (inside its outline, where the image agrees with its colours) with
   the table's colour in both cameras' feature pyramids, and identify again on what is left,
   until nothing is found or the foreground left unexplained is smaller than a garment
   (:attr:`TableConfig.min_unexplained_mm2`). A second garment of the same model is found
   like any other, once the first is painted over.
2. **Appearance maps**: each found garment's colours are laid into camera 1's and camera 2's
   view at its pose (:class:`Appearance`: every pixel of a pyramid level traced onto the
   garment's plane and into its model photo) and compared with the images after a light
   offset (the median difference): a map of where the image shows this garment.
3. **Who lies on whom**: where two garments' outlines overlap, the one whose colours the
   images show there lies on top (the mean agreement difference over the overlap, both
   cameras, beyond :attr:`TableConfig.layer_margin`); an overlap the colours cannot settle
   (look-alike colours) counts both ways, so neither is picked before the other is gone.
4. **Visible fraction**: the share of a garment's area that camera 1 sees, inside the image
   and not under a found garment.
5. **Pick order**: garments nothing lies on, best seen (visible fraction, then score) first;
   then, as if those were gone, the next ones, and so on.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import Any

import cv2
import numpy as np
from numpy.typing import NDArray

from photomodel.fitness import (
    PreparedModel,
    SampleDrawer,
    StereoFeatures,
    border_band,
    scene_regions,
)
from photomodel.identify._bank import DescriptorBank
from photomodel.identify._identify import IdentifyConfig, identify_with_bank
from photomodel.locate import LocateResult, load_threshold
from photomodel.model import HAND_MM_PER_PX
from photomodel.search import SearchSpace

__all__ = ["Appearance", "TableConfig", "TableGarment", "TableResult", "identify_all"]


@dataclass(frozen=True)
class TableConfig:
    """Settings of :func:`identify_all`.

    Attributes
    ----------
    level : int
        Pyramid level of the appearance maps (1: about 1.7 mm a pixel on the table).
    agree : float
        Agreement from which a pixel shows a garment (painted over before the next search).
    layer_margin : float
        Mean agreement difference over an overlap that settles which garment is on top.
    min_overlap_px : int
        Overlaps smaller than this (pixels of ``level``, camera 1) are not contacts.
    max_garments : int
        Most garments reported.
    min_unexplained_mm2 : float
        Foreground left unexplained below this area ends the search without another look.
    hidden_min_score : float
        Score from which a search's best counts as a candidate (a garment half under others
        scores about half what it would in full view); :attr:`min_agreement` and the
        threshold per visible share decide.
    min_agreement : float
        Least mean agreement over the part of a candidate that no earlier garment explains
        (cloth that is not in the library lying on it lowers it: a garment with two fifths
        under a foreign one agrees about 0.45 at its true pose).
    min_visible : float
        Least share of a candidate's area that no earlier garment explains.
    same_place_mm : float
        A candidate of a model already found within this distance is that garment again.
    coarse_min_score : float
        Score from which a locate's search from the coarse scan ends its work (a single
        garment needs 0.6; a garment partly under others scores less at its true pose, and a
        second full search would cost a locate more).
    min_new_foreground : float
        A candidate scoring under the threshold needs at least this share of its area on
        foreground (pixels unlike the table) that no earlier garment covers: a weak match
        fitted into the gaps between found garments explains nothing new. (A garment of the
        table's colours is no foreground; it must then score as a single garment would.)
    unknown_on_mm2 : float
        Foreground inside a garment's outline that neither it nor any found garment shows
        (cloth that is not in the library, or a garment not found, lying on it), from which
        it waits in the pick order behind garments without.
    """

    level: int = 1
    agree: float = 0.35
    layer_margin: float = 0.04
    min_overlap_px: int = 12
    max_garments: int = 8
    min_unexplained_mm2: float = 2500.0
    hidden_min_score: float = 0.2
    min_agreement: float = 0.3
    min_visible: float = 0.2
    same_place_mm: float = 20.0
    min_new_foreground: float = 0.1
    coarse_min_score: float = 0.45
    unknown_on_mm2: float = 1500.0


@dataclass(frozen=True)
class TableGarment:
    """One garment found on the table.

    Attributes
    ----------
    instance : int
        Its number in this answer (0 = found first).
    result : LocateResult
        Its model, pose and score.
    visible_fraction : float
        Share of its area camera 1 sees (in the image, not under a found garment), [0, 1].
    lies_on : tuple of int
        Instances it lies on (covers some of).
    covered_by : tuple of int
        Instances lying on it.
    pick_rank : int
        Its place in the pick order (0 = first).
    unknown_on_mm2 : float
        Foreground inside its outline that neither it nor another found garment shows:
        something not found may lie on it, mm^2 on the table (camera 1).
    """

    instance: int
    result: LocateResult
    visible_fraction: float
    lies_on: tuple[int, ...]
    covered_by: tuple[int, ...]
    pick_rank: int
    unknown_on_mm2: float = 0.0

    @property
    def model(self) -> str:
        return self.result.model

    def to_json_dict(self) -> dict[str, Any]:
        """``locate --json``'s object of its pose plus ``instance``, ``visible_fraction``,
        ``covered_by`` and ``lies_on`` (instances: indices into ``garments``), ``rank``
        (its place in the pick order, 0 first) and ``unknown_on_mm2``."""
        out = self.result.to_json_dict()
        out.update(instance=self.instance, visible_fraction=self.visible_fraction,
                   covered_by=list(self.covered_by), lies_on=list(self.lies_on),
                   rank=self.pick_rank, unknown_on_mm2=round(self.unknown_on_mm2, 1))
        return out


@dataclass(frozen=True)
class TableResult:
    """Every library garment found in a stereo pair (:func:`identify_all`).

    Attributes
    ----------
    garments : tuple of TableGarment
        In the order found.
    pick_order : tuple of int
        Instances, first to pick first.
    min_score : float
    unexplained_mm2 : float
        Foreground area no found garment explains (distractors, unknown garments).
    seconds : float
    """

    garments: tuple[TableGarment, ...]
    pick_order: tuple[int, ...]
    min_score: float
    unexplained_mm2: float
    seconds: float

    @property
    def first(self) -> TableGarment | None:
        """The garment to pick first, None on an empty table."""
        return self.garments[self.pick_order[0]] if self.pick_order else None

    def to_json_dict(self) -> dict[str, Any]:
        """The ``identify --all --json`` object (docs/contracts.md): ``identify --json``'s
        keys for the garment to pick first (``model`` null on an empty table; ``runner_up``
        the next to pick), plus ``garments`` (each one's object, :meth:`TableGarment.
        to_json_dict`), ``pick_order`` (instances), ``count`` and ``unexplained_mm2``."""
        first = self.first
        if first is not None:
            out = first.result.to_json_dict()
        else:
            out = {"model": None, "found": False, "T_cam1_model": None, "position_mm": None,
                   "quat_wxyz": None, "theta_deg": None, "fitness": None, "score": 0.0}
        nxt = self.garments[self.pick_order[1]] if len(self.pick_order) > 1 else None
        out.update(
            seconds=self.seconds, min_score=self.min_score,
            runner_up={"model": None if nxt is None else nxt.model,
                       "score": None if nxt is None else nxt.result.score},
            candidates=[{"model": g.model, "evidence": None, "score": g.result.score}
                        for g in self.garments],
            garments=[g.to_json_dict() for g in self.garments],
            pick_order=list(self.pick_order), count=len(self.garments),
            unexplained_mm2=self.unexplained_mm2)
        return out


# ----------------------------------------------------------------------------- appearance

class _Rays:
    """Undistorted viewing rays (h, w, 3) of every pixel of one camera at one pyramid level,
    made once a rig and level."""

    def __init__(self, features: StereoFeatures, level: int) -> None:
        self.level = level
        self.rays: list[NDArray[np.float64]] = []
        for camera, K, image in zip((features.rig.cam1, features.rig.cam2),
                                    features.camera_matrices(level),
                                    (p[level] for p in features.pyramids), strict=True):
            h, w = image.shape[:2]
            u, v = np.meshgrid(np.arange(w, dtype=np.float64), np.arange(h, dtype=np.float64))
            pts = np.stack([u.ravel(), v.ravel()], axis=1).reshape(-1, 1, 2)
            xy = cv2.undistortPoints(pts, K, camera.dist).reshape(h, w, 2)
            self.rays.append(np.concatenate([xy, np.ones((h, w, 1))], axis=2))


_RAYS: dict[tuple[int, int, tuple[int, ...]], tuple[Any, _Rays]] = {}
_RAYS_KEPT = 4


def _rays(features: StereoFeatures, level: int) -> _Rays:
    """The :class:`_Rays` of a rig and level, made once (the last few rigs kept)."""
    shapes = tuple(s for p in features.pyramids for s in p[level].shape[:2])
    key = (id(features.rig), level, shapes)
    held = _RAYS.get(key)
    if held is None or held[0] is not features.rig:      # an id reused by another rig
        if len(_RAYS) >= _RAYS_KEPT:
            _RAYS.pop(next(iter(_RAYS)))
        held = _RAYS[key] = (features.rig, _Rays(features, level))
    return held[1]


@dataclass
class Appearance:
    """Where the images show one found garment, per camera at one pyramid level.

    Attributes
    ----------
    inside : list of ndarray (h, w) bool
        Pixels inside the garment's outline at its pose (camera 1, camera 2).
    agreement : list of ndarray (h, w) float32
        How well each pixel's colour agrees with the garment's there, [0, 1] (0 outside).
    area_px : float
        The outline's area in camera 1, pixels of the level, the part outside the image
        included.
    """

    inside: list[NDArray[np.bool_]] = field(default_factory=list)
    agreement: list[NDArray[np.float32]] = field(default_factory=list)
    area_px: float = 0.0

    def shows(self, threshold: float) -> list[NDArray[np.bool_]]:
        """Pixels where the images show this garment (inside, agreement >= threshold)."""
        return [i & (a >= threshold) for i, a in zip(self.inside, self.agreement, strict=True)]


def _drawer(prepared: PreparedModel) -> SampleDrawer:
    return prepared.kept.get("table_drawer", lambda: SampleDrawer(prepared))


def appearance(prepared: PreparedModel, A_cam1_model: NDArray[np.float64],
               features: StereoFeatures, rays: _Rays,
               hidden: list[NDArray[np.bool_]] | None = None) -> Appearance:
    """The :class:`Appearance` of a model at the map ``A_cam1_model`` (4, 4; a pose, or a pose
    with its fitted strain) in a stereo pair's features. The light offset is measured where
    ``hidden`` (pixels of other garments, camera 1 and 2) is False, when enough is left."""
    rig = features.rig
    level = rays.level
    drawer = _drawer(prepared)
    model = prepared.model
    match = features.match
    mm_per_px = HAND_MM_PER_PX * 2**level
    colours = prepared.kept.get(("table_colours", level), lambda: drawer.colours(
        0.0, max(0.5, 0.5 * mm_per_px * drawer.px_per_mm)))
    mask = model.mask.astype(np.float32)
    out = Appearance()
    outline = np.asarray(model.outline_mm, dtype=np.float64)
    for c, A in enumerate((A_cam1_model, rig.T_cam2_cam1 @ A_cam1_model)):
        camera = (rig.cam1, rig.cam2)[c]
        image = features.pyramids[c][level]
        h, w = image.shape[:2]
        corners = camera.project(outline @ A[:3, :3].T + A[:3, 3]) * 0.5**level
        inside = np.zeros((h, w), bool)
        agreement = np.zeros((h, w), np.float32)
        if c == 0:
            x, y = corners[:, 0], corners[:, 1]
            out.area_px = float(0.5 * abs(np.dot(x, np.roll(y, 1)) - np.dot(y, np.roll(x, 1))))
        finite = corners[np.isfinite(corners).all(axis=1)]
        if len(finite):
            u0, v0 = np.floor(finite.min(axis=0)).astype(int) - 2
            u1, v1 = np.ceil(finite.max(axis=0)).astype(int) + 3
            u0, v0, u1, v1 = max(u0, 0), max(v0, 0), min(u1, w), min(v1, h)
            if u1 > u0 and v1 > v0:
                M = A[:3, [0, 1, 3]]
                q = rays.rays[c][v0:v1, u0:u1] @ np.linalg.inv(M).T
                with np.errstate(divide="ignore", invalid="ignore"):
                    xy = q[..., :2] / q[..., 2:3]
                uv = drawer.crop_pixels(np.where(np.isfinite(xy), xy, -1e9)).astype(np.float32)
                mu, mv = uv[..., 0], uv[..., 1]
                seen = cv2.remap(mask, mu, mv, cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT,
                                 borderValue=0.0) >= 0.5
                seen &= q[..., 2] > 0
                if seen.any():
                    model_f = cv2.remap(colours, mu, mv, cv2.INTER_LINEAR,
                                        borderMode=cv2.BORDER_REPLICATE)
                    diff = image[v0:v1, u0:u1] - model_f
                    own = seen if hidden is None else seen & ~hidden[c][v0:v1, u0:u1]
                    offset = np.median(diff[own if np.count_nonzero(own) >= 20 else seen],
                                       axis=0)
                    e = diff - offset
                    d2 = (e[..., 0] ** 2 / match.sigma_l**2
                          + (e[..., 1] ** 2 + e[..., 2] ** 2) / match.sigma_c**2)
                    agreement[v0:v1, u0:u1] = np.where(seen, np.exp(-0.5 * d2), 0.0)
                    inside[v0:v1, u0:u1] = seen
        out.inside.append(inside)
        out.agreement.append(agreement)
    return out


# ----------------------------------------------------------------------------- painting

def _table_colour(image: NDArray[np.float32], border: int = 4) -> NDArray[np.float32]:
    """The median feature of an image's border band: the table's colour."""
    return np.median(border_band(image, border), axis=0).astype(np.float32)


def painted(features: StereoFeatures, masks: list[NDArray[np.bool_]], level: int
            ) -> StereoFeatures:
    """A copy of ``features`` with the pixels of ``masks`` (camera 1, camera 2; pixels of
    ``level``) painted with the table's colour at every pyramid level."""
    pyramids: tuple[list[NDArray[np.float32]], list[NDArray[np.float32]]] = ([], [])
    for c in (0, 1):
        grown = cv2.dilate(masks[c].astype(np.uint8), np.ones((3, 3), np.uint8))
        for k, image in enumerate(features.pyramids[c]):
            h, w = image.shape[:2]
            m = cv2.resize(grown, (w, h), interpolation=cv2.INTER_NEAREST if k <= level
                           else cv2.INTER_AREA) > 0
            copy = image.copy()
            copy[m] = _table_colour(image)
            pyramids[c].append(copy)
    return StereoFeatures.from_pyramids(features.rig, features.match, pyramids)


# ----------------------------------------------------------------------------- layering

def _on_top(a: Appearance, b: Appearance, config: TableConfig) -> tuple[int, float]:
    """+1 when ``a`` lies on ``b``, -1 when ``b`` lies on ``a``, 0 when their outlines do not
    overlap, 2 when they overlap and the colours cannot say which is on top; and the mean
    agreement difference over the overlap (positive: ``a`` looks on top)."""
    if np.count_nonzero(a.inside[0] & b.inside[0]) < config.min_overlap_px:
        return 0, 0.0
    diffs = []
    for c in (0, 1):
        both = a.inside[c] & b.inside[c]
        if both.any():
            diffs.append(float(np.mean(a.agreement[c][both] - b.agreement[c][both])))
    d = float(np.mean(diffs))
    if d > config.layer_margin:
        return 1, d
    if d < -config.layer_margin:
        return -1, d
    return 2, d


def pick_order(covered_by: list[set[int]], visible: list[float], score: list[float],
               lean: list[float] | None = None, wait: list[bool] | None = None) -> list[int]:
    """Instances in the order to pick them: among those nothing left lies on, the best seen
    (visible fraction, then score) first, those that must ``wait`` (something unknown may
    lie on them) after the others; a set that covers itself all round (colours that could
    not settle an overlap) is broken at the garment whose unsettled overlaps lean most
    towards it lying on top (``lean``: the sum of their agreement differences), then the
    best seen."""
    lean = lean or [0.0] * len(visible)
    wait = wait or [False] * len(visible)
    left = set(range(len(visible)))
    order: list[int] = []
    while left:
        free = [i for i in left if not (covered_by[i] & left)]
        if free:
            best = max(free, key=lambda i: (not wait[i], visible[i], score[i]))
        else:
            best = max(left, key=lambda i: (lean[i], not wait[i], visible[i], score[i]))
        order.append(best)
        left.remove(best)
    return order


# ----------------------------------------------------------------------------- the search

def identify_all(
    bank: DescriptorBank,
    prepared: Callable[[int], PreparedModel],
    features: StereoFeatures,
    *,
    config: IdentifyConfig | None = None,
    table: TableConfig | None = None,
    space: SearchSpace | None = None,
    rng: int | np.random.Generator | None = None,
    t0: float | None = None,
) -> TableResult:
    """Every garment of the library in a stereo pair (see the module docstring).

    Parameters
    ----------
    bank : DescriptorBank
        The library's descriptors; ``prepared(i)`` gives entry ``i``'s prepared model.
    prepared : callable
    features : StereoFeatures
    config : IdentifyConfig, optional
        Each round's identification.
    table : TableConfig, optional
    space : SearchSpace, optional
    rng : int, Generator or None
    t0 : float, optional
        ``time.perf_counter()`` when the work began.

    Returns
    -------
    TableResult
    """
    t0 = time.perf_counter() if t0 is None else t0
    c = config or IdentifyConfig()
    tc = table or TableConfig()
    space = space or SearchSpace.from_ranges(R_cam1_plane=features.rig.R_cam1_facing)
    gen = np.random.default_rng(rng)
    level = min(tc.level, features.levels - 1)
    rays = _rays(features, level)
    regions = scene_regions(features, (float(space.lower[2]), float(space.upper[2])), c.scene)
    found: list[tuple[LocateResult, Appearance]] = []
    explained = [np.zeros(p[level].shape[:2], bool) for p in features.pyramids]
    names = {n: i for i, n in enumerate(bank.names)}
    current = features
    unexplained_mm2 = _unexplained_mm2(regions, explained, level)
    h1, w1 = explained[0].shape
    foreground = cv2.resize(regions.foreground.astype(np.uint8), (w1, h1),
                            interpolation=cv2.INTER_NEAREST) > 0
    min_score = c.min_score if c.min_score is not None else load_threshold().min_score
    # every screened candidate of a round is verified (a find does not end the round: a
    # garment lying on the one found may share its colours, and painting would hide it)
    hidden = replace(c, min_score=min(min_score, tc.hidden_min_score),
                     min_visible_outline=min(c.min_visible_outline, 0.4), evidence_margin=1.0,
                     coarse_min_score=tc.coarse_min_score)
    # after the first round, what is left is known foreground: its own candidates only, once
    later = replace(hidden, wide_candidates=0, retries=0)
    judge = _Judge(prepared, names, features, rays, foreground, min_score, tc)

    def enough(located: list[LocateResult]) -> bool:
        """Whether the candidates located so far leave too little unexplained for another."""
        now, shown = judge(found, explained, located)
        return (len(now) >= tc.max_garments
                or _unexplained_mm2(regions, shown, level) < tc.min_unexplained_mm2)

    while len(found) < tc.max_garments and unexplained_mm2 >= tc.min_unexplained_mm2:
        result = identify_with_bank(bank, prepared, current,
                                    config=hidden if current is features else later, space=space,
                                    rng=int(gen.integers(0, 2**62)),
                                    regions=regions if current is features else None,
                                    enough=enough)
        if not result.found:
            break
        # every candidate the round located, best first: several garments a round
        now, explained = judge(found, explained, [cand.result for cand in result.candidates
                                                  if cand.result is not None])
        if len(now) == len(found):
            break
        found = now
        current = painted(features, explained, level)
        # what the found garments show, not their whole outlines: a garment lying wholly on
        # a found one is inside its outline but still unexplained
        unexplained_mm2 = _unexplained_mm2(regions, explained, level)
    unknown = _unknown_on(found, explained, foreground, regions, tc)
    return _table_result(found, tc, min_score, unexplained_mm2, unknown, t0)


@dataclass
class _Judge:
    """Judges a round's located candidates (best first) after the garments of earlier rounds:
    :func:`_accepted` and, under the threshold, :func:`_new_foreground`; each candidate's
    appearance map made once."""

    prepared: Callable[[int], PreparedModel]
    names: dict[str, int]
    features: StereoFeatures
    rays: _Rays
    foreground: NDArray[np.bool_]
    min_score: float
    tc: TableConfig
    looks: dict[int, tuple[LocateResult, Appearance]] = field(default_factory=dict)

    def __call__(self, found: list[tuple[LocateResult, Appearance]],
                 explained: list[NDArray[np.bool_]], located: list[LocateResult]
                 ) -> tuple[list[tuple[LocateResult, Appearance]], list[NDArray[np.bool_]]]:
        """The garments found with ``located`` accepted in turn after ``found``, and the
        pixels they explain (camera 1, camera 2; ``explained`` by ``found`` before)."""
        tc = self.tc
        now, shown = list(found), list(explained)
        for best in sorted((r for r in located if r.found), key=lambda r: -r.score):
            if len(now) >= tc.max_garments:
                break
            covered = [np.zeros_like(e) for e in shown]
            for _, seen in now:
                covered = [a | b for a, b in zip(covered, seen.inside, strict=True)]
            held = self.looks.get(id(best))
            if held is None or held[0] is not best:     # (the result kept: its id stays its)
                held = self.looks[id(best)] = (best, appearance(
                    self.prepared(self.names[best.model]), best.A_cam1_model, self.features,
                    self.rays, covered))
            look = held[1]
            taken = _taken(look, now)
            if not _accepted(best, look, taken, now, self.min_score, tc) or (
                    best.score < self.min_score
                    and _new_foreground(look, taken, self.foreground) < tc.min_new_foreground):
                continue
            now.append((best, look))
            shown = [e | s for e, s in zip(shown, look.shows(tc.agree), strict=True)]
        return now, shown


def _accepted(best: LocateResult, look: Appearance, explained: list[NDArray[np.bool_]],
              found: list[tuple[LocateResult, Appearance]], min_score: float,
              tc: TableConfig) -> bool:
    """Whether a round's best is a garment: not one found already, enough of it seen apart
    from the garments found before, agreeing there, and its score reaching the threshold
    once scaled to the share of it that is free."""
    for r, _ in found:
        if r.model == best.model and float(np.linalg.norm(
                r.T_cam1_model[:3, 3] - best.T_cam1_model[:3, 3])) < tc.same_place_mm:
            return False
    agreements, free_px = [], 0
    for c in (0, 1):
        free = look.inside[c] & ~explained[c]
        if c == 0:
            free_px = int(np.count_nonzero(free))
        if free.any():
            agreements.append(float(look.agreement[c][free].mean()))
    share = free_px / max(look.area_px, 1.0)
    if share < tc.min_visible or not agreements or np.mean(agreements) < tc.min_agreement:
        return False
    return best.score >= min_score * min(1.0, share)


def _taken(look: Appearance, found: list[tuple[LocateResult, Appearance]]
           ) -> list[NDArray[np.bool_]]:
    """Pixels of a candidate that a garment found before explains at least as well (inside
    it, agreeing as much): the rest is the candidate's own, also where it lies on a found
    garment wholly."""
    out = []
    for c in (0, 1):
        best = np.zeros_like(look.agreement[c])
        inside = np.zeros_like(look.inside[c])
        for _, seen in found:
            best = np.maximum(best, np.where(seen.inside[c], seen.agreement[c], 0.0))
            inside |= seen.inside[c]
        out.append(inside & (best >= look.agreement[c]))
    return out


def _new_foreground(look: Appearance, covered: list[NDArray[np.bool_]],
                    foreground: NDArray[np.bool_]) -> float:
    """Share of a candidate's area (camera 1) on foreground no earlier garment covers."""
    return float(np.count_nonzero(look.inside[0] & foreground & ~covered[0])) / max(
        look.area_px, 1.0)


def _unexplained_mm2(regions: Any, explained: list[NDArray[np.bool_]], level: int) -> float:
    """Foreground area of camera 1 (the scene's) that no found garment explains, mm^2."""
    fg = regions.foreground
    if not np.isfinite(regions.table_depth_mm) or not fg.any() or not regions.regions:
        return 0.0
    h, w = fg.shape
    grown = cv2.dilate(explained[0].astype(np.uint8), np.ones((5, 5), np.uint8))
    done = cv2.resize(grown, (w, h), interpolation=cv2.INTER_AREA) > 0
    mm_per_px = regions.regions[0].mm_per_px
    return float(np.count_nonzero(fg & ~done) * mm_per_px**2)


def _unknown_on(found: list[tuple[LocateResult, Appearance]],
                explained: list[NDArray[np.bool_]], foreground: NDArray[np.bool_],
                regions: Any, tc: TableConfig) -> list[float]:
    """Per found garment, the foreground inside its outline (camera 1) that no found
    garment shows, mm^2: blobs of it, the outline's rim of blur left out."""
    if not found or not regions.regions:
        return [0.0] * len(found)
    h, w = foreground.shape
    mm_per_px = regions.regions[0].mm_per_px * regions.foreground.shape[1] / w
    kernel = np.ones((3, 3), np.uint8)
    out = []
    for _, look in found:
        inside = cv2.erode(look.inside[0].astype(np.uint8), kernel, iterations=2) > 0
        odd = (inside & foreground & ~explained[0]).astype(np.uint8)
        odd = cv2.morphologyEx(odd, cv2.MORPH_OPEN, kernel)
        out.append(float(np.count_nonzero(odd)) * mm_per_px**2)
    return out


def _table_result(found: list[tuple[LocateResult, Appearance]], tc: TableConfig,
                  min_score: float, unexplained_mm2: float, unknown: list[float], t0: float
                  ) -> TableResult:
    n = len(found)
    covered_by: list[set[int]] = [set() for _ in range(n)]   # for the pick: unsure both ways
    under: list[set[int]] = [set() for _ in range(n)]        # surely on it: hides some of it
    lean = [0.0] * n
    for i in range(n):
        for j in range(i + 1, n):
            rel, d = _on_top(found[i][1], found[j][1], tc)
            if rel == 2:
                lean[i] += d
                lean[j] -= d
            if rel in (1, 2):
                covered_by[j].add(i)
            if rel in (-1, 2):
                covered_by[i].add(j)
            if rel == 1:
                under[j].add(i)
            elif rel == -1:
                under[i].add(j)
    visible = []
    for i, (_, look) in enumerate(found):
        seen = look.inside[0].copy()
        for j in under[i]:
            seen &= ~found[j][1].inside[0]
        visible.append(min(1.0, float(np.count_nonzero(seen)) / max(look.area_px, 1.0)))
    scores = [r.score for r, _ in found]
    order = pick_order(covered_by, visible, scores, lean,
                       [u >= tc.unknown_on_mm2 for u in unknown])
    rank = {inst: k for k, inst in enumerate(order)}
    garments = tuple(
        TableGarment(i, found[i][0], visible[i],
                     tuple(sorted(j for j in range(n) if i in covered_by[j])),
                     tuple(sorted(covered_by[i])), rank[i], unknown[i])
        for i in range(n))
    return TableResult(garments, tuple(order), float(min_score), unexplained_mm2,
                       time.perf_counter() - t0)
