"""A simulated clothing catalogue of any size: articles ``cat-00000`` ... ``cat-99999``.

Tests and benchmarks that build model libraries of hundreds or thousands of garments need more
garments than the paper's 12. Article ``i`` is a :class:`~photomodel.sim.GarmentSpec` drawn
from a generator seeded by ``i`` alone, kept or redrawn by comparison with the articles before
it only; so ``catalogue_spec(i)`` is the same whatever catalogue size anyone asks for. Specs are
made once, in index order, and cached (the first 10,000 take about a second, all 100,000 about
half a minute); :func:`~photomodel.sim.catalogue_garment` builds any of them.

**Mix.** Every silhouette of ``GARMENT_SHAPES`` (T-shirts most often, socks least), within
the paper's model limit (width 110-250 mm, height 90-200 mm; whole millimetres, size twins to
0.1 mm) and with an aspect ratio that suits the shape. Every fabric: plain 30 %, stripes 16 %,
floral print 14 %, plaid 13 %, dots 12 %, camouflage 8 %, photo prints 7 % (a whole picture,
or mirrored repeats 25-100 mm wide). Plain and ground colours (the ground of stripes, dots and
print) are bright (35 %), muted (denim, khaki, dusty pink: 15 %), dark (navy, wine, brown:
20 %), light (white, off-white, pastels: 15 %) or grey from near black to light grey (15 %);
their hue (where there is one: greys and whites have next to none) always lies in
:data:`~photomodel.sim.PLAIN_HUES`, off the model station plane's green, as for every other
garment. Some of the articles that are not plaid or camouflage have
a hem of a contrasting colour, 8-25 mm high: 6 % of the first thousand, more later on (see
below).

**Look-alike pairs.** Every article whose index ends in 9 (``i % 10 == 9``, 10 %) is the
twin of article ``i - 1`` and differs from it in exactly one respect (:func:`lookalike_of`;
its ``description`` says so too):

- ``"colour"``: the plain or ground colour changed clearly. A bright or muted colour turns
  more than 40 degrees of hue (saturation and value kept); a dark colour becomes light and a
  light one dark (hue kept); a grey's value moves by more than 100 of 255.
- ``"size"``: both sides 0.8 times the original's (such an original is drawn at least 1.25
  times the model limit's minimum, so that its twin keeps within it).

Plaid, camouflage and photo prints (no colour parameter) always get a size twin, and so do dots
on a ground that is not bright or muted (a light/dark swap changes the colour of the dots as
well); the others get a colour twin 7 times in 10, so that the two kinds are about as
common. The twin keeps the original's fabric seed (its pattern is the same recipe) and hem.

**Distinct otherwise.** Two articles that are not a designed pair are never practically
identical. Two articles are *practically identical* when they have the same shape and fabric,
both sides within 15 % (the larger over the smaller below 1.15, each side) and

- plain, stripes, dots, print: plain or ground colours less than 40 apart in BGR (Euclidean
  distance of 0-255 values; navy (72, 36, 26) and black (30, 30, 30) are 43 apart), and the
  same hem: none, or hem colours less than 40 apart;
- photo: the same picture, the same repeat (or both whole) and the same hem;
- plaid, camouflage: never; their colours and pattern come from the fabric seed, different
  for every article (each is another tartan, another camouflage).

Each article's generator draws candidates: four of a first shape, fabric and colour kind; then
up to 32 of that shape and fabric in any colour kind and more often with a hem (half of them);
then up to 32 of each of eight further shapes and fabrics. The first candidate that, with its
twin where it has one, is practically identical to no earlier article (twins included) is
kept; plaid, always free, is the last resort. A shape and fabric whose candidates found no room
256 times in a row counts as full and is skipped. The colours and sizes without a hem fill up
first (the model limit leaves room for about a thousand plain garments of one shape), so the
share of hems among the articles that can have one grows: a quarter of the first 10,000, nine
in ten beyond 50,000; the fabric mix holds throughout. No two of all 100,000 articles break
the rule except the designed pairs (checked when the rule last changed).
"""

from __future__ import annotations

import bisect
import colorsys
import math
import re
import threading
from dataclasses import dataclass, replace
from itertools import accumulate
from typing import TypeVar

import numpy as np
from numpy.typing import NDArray

from photomodel.sim._catalogue import GarmentSpec
from photomodel.sim._garments import FABRICS, GARMENT_SHAPES
from photomodel.sim._textures import PHOTO_PRINTS, PLAIN_HUES

__all__ = [
    "MAX_CATALOGUE",
    "catalogue_names",
    "catalogue_spec",
    "lookalike_of",
]

MAX_CATALOGUE = 100_000
"""Number of articles of the simulated catalogue (``cat-00000`` ... ``cat-99999``)."""

_NAME = re.compile(r"cat-(\d{5})")
_ROOT_SEED = 0x5EEDCA7  # root of every article's generator
_SEED_OFFSET = 1_000_000  # fabric seed of article i: 1_000_000 + i (the twin keeps its original's)
_TWIN_EVERY = 10  # i % 10 == 9: the twin of article i - 1
_SAME_KIND = 4  # first candidates: of the first draw's shape, fabric and colour kind
_BATCH = 32  # then candidates of its shape and fabric in any colour kind, and of each other one
_ROUNDS = 8  # other shapes and fabrics tried before falling back to plaid
_FULL_STREAK = 256  # candidates in a row without room: that shape and fabric is full
_HEM_MM = (8.0, 25.0)  # height of a contrasting hem
_HEM_SHARE = (0.05, 0.5)  # share of candidates with a hem: first ones, later ones
_NO_HEM = (-1000.0, -1000.0, -1000.0)  # the hem colour of "no hem": far from every colour

_WIDTH_MM = (110.0, 250.0)
_HEIGHT_MM = (90.0, 200.0)
_TWIN_SCALE = 0.8
_COLOUR_TWINS = 0.7  # share of colour twins where the fabric allows one
_SAME_SIZE = 1.15  # larger over smaller side below this: "the same size"
_SAME_COLOUR_BGR = 40.0  # Euclidean BGR distance below this: "the same colour"
_EPS = 1e-9  # the generator counts a pair exactly at either limit as the same (rounding)
_MIN_HUE_TURN = 24.0  # OpenCV hue units (2 degrees each): over 40 degrees, with a margin
_MIN_GREY_STEP = 102.0  # value, 0-255

_SHAPE_WEIGHTS: dict[str, float] = {
    "tshirt": 16, "longsleeve": 12, "trousers": 12, "towel": 12, "shorts": 10, "skirt": 10,
    "dress": 10, "vest": 10, "sock": 8,
}
_ASPECT: dict[str, tuple[float, float]] = {  # width / height of the bounding box
    "tshirt": (1.0, 1.35), "longsleeve": (1.15, 1.5), "trousers": (0.65, 0.95),
    "towel": (0.8, 1.6), "shorts": (1.05, 1.45), "skirt": (0.95, 1.4), "dress": (0.75, 1.0),
    "vest": (0.8, 1.05), "sock": (0.6, 0.85),
}
_FABRIC_WEIGHTS: dict[str, float] = {
    "plain": 30, "stripes": 16, "print": 14, "plaid": 13, "dots": 12, "camo": 8, "photo": 7,
}
_COLOUR_KINDS: dict[str, float] = {"bright": 35, "muted": 15, "dark": 20, "light": 15,
                                   "grey": 15}
# OpenCV (saturation, value) ranges of each colour kind; the hue is drawn within PLAIN_HUES.
_SAT_VAL: dict[str, tuple[tuple[float, float], tuple[float, float]]] = {
    "bright": ((150.0, 255.0), (120.0, 245.0)),
    "muted": ((100.0, 150.0), (80.0, 210.0)),  # denim, khaki, dusty pink, burgundy
    "dark": ((100.0, 255.0), (30.0, 95.0)),  # navy, wine, dark brown, aubergine
    "light": ((0.0, 70.0), (205.0, 252.0)),  # white, off-white, cream, pastels
    "grey": ((0.0, 15.0), (20.0, 215.0)),  # black-ish to light grey
}
_TURNING = ("bright", "muted")  # kinds whose colour twin turns the hue (the others swap value)
_PHOTO_TILES: dict[float | None, float] = {None: 40, 25.0: 12, 35.0: 12, 50.0: 12, 70.0: 12,
                                           100.0: 12}
"""Repeat width of a photo print, mm (None: one picture over the whole garment): weights."""
_COLOURED = ("plain", "stripes", "dots", "print")  # fabrics with a plain or ground colour
_SHAPE_WORDS = {
    "tshirt": "T-shirt", "longsleeve": "long-sleeve shirt", "trousers": "trousers",
    "towel": "towel", "shorts": "shorts", "skirt": "skirt", "dress": "dress",
    "vest": "tank top", "sock": "sock",
}
_PATTERN_WORDS = {"stripes": "stripes", "dots": "dots", "print": "flowers"}
_HUE_NAMES = ((8, "red"), (20, "orange"), (34, "yellow"), (100, "turquoise"), (125, "blue"),
              (140, "violet"), (160, "purple"), (172, "pink"), (181, "red"))
_DARK_NAMES = {"red": "wine", "orange": "brown", "yellow": "olive", "blue": "navy"}

assert set(_SHAPE_WEIGHTS) == set(GARMENT_SHAPES) == set(_ASPECT)
assert set(_FABRIC_WEIGHTS) == set(FABRICS)
assert set(_COLOUR_KINDS) == set(_SAT_VAL)

_T = TypeVar("_T")


def _weighted(weights: dict[_T, float]) -> tuple[tuple[_T, ...], list[float]]:
    total = sum(weights.values())
    return tuple(weights), [c / total for c in accumulate(weights.values())]


def _pick(choice: tuple[tuple[_T, ...], list[float]], u: float) -> _T:
    """The item whose share of the cumulative weights holds ``u`` in [0, 1)."""
    items, cdf = choice
    return items[min(bisect.bisect_right(cdf, u), len(items) - 1)]


_SHAPE_CHOICE = _weighted(_SHAPE_WEIGHTS)
_FABRIC_CHOICE = _weighted(_FABRIC_WEIGHTS)
_KIND_CHOICE = _weighted(_COLOUR_KINDS)
_TILE_CHOICE = _weighted(_PHOTO_TILES)


# --- colours ---------------------------------------------------------------------------------

_HSV = tuple[float, float, float]
_BGR = tuple[int, int, int]
# Hues keep this far inside PLAIN_HUES, so that rounding to 0-255 BGR does not carry a colour
# of some chroma (over 8 of 255) out of them.
_HUE_MARGIN = 4.0
_HUE_LO = PLAIN_HUES[0] + _HUE_MARGIN
_HUE_SPAN = PLAIN_HUES[1] - PLAIN_HUES[0] - 2.0 * _HUE_MARGIN  # hues _HUE_LO + t (mod 180)


def _hue(t: float) -> float:
    """OpenCV hue of position ``t`` in [0, span) of the allowed (non-green) hue range."""
    return (_HUE_LO + t) % 180.0


def _draw_hsv(kind: str, t: float, u_s: float, u_v: float) -> _HSV:
    """OpenCV (hue, saturation, value) of a colour of ``kind`` at hue position ``t``."""
    (s0, s1), (v0, v1) = _SAT_VAL[kind]
    if kind == "light":
        u_s *= u_s  # mostly near white
    return _hue(t), s0 + (s1 - s0) * u_s, v0 + (v1 - v0) * u_v


def _twin_hsv(kind: str, hsv: _HSV, t: float, u: float) -> _HSV:
    """The colour of a colour twin: a clear change of ``hsv`` (``t``: its hue position).

    Bright and muted colours turn their hue by at least ``_MIN_HUE_TURN`` within the allowed
    range; dark ones become light, light ones dark (hue kept); greys move their value by at
    least ``_MIN_GREY_STEP``.
    """
    h, s, v = hsv
    if kind in _TURNING:
        below = max(t - _MIN_HUE_TURN, 0.0)
        above = max(_HUE_SPAN - (t + _MIN_HUE_TURN), 0.0)
        x = u * (below + above)
        return _hue(x if x < below else t + _MIN_HUE_TURN + (x - below)), s, v
    if kind == "dark":
        return h, 25.0 + 35.0 * u, 220.0 + 25.0 * u
    if kind == "light":
        return h, 120.0 + 100.0 * u, 40.0 + 40.0 * u
    step = _MIN_GREY_STEP + 10.0 * u
    return h, s, (v + step if v < 128.0 else max(v - step, 25.0))


def _bgr(hsv: _HSV) -> _BGR:
    """BGR 0-255 of an OpenCV HSV colour (hue 0-180, saturation and value 0-255)."""
    r, g, b = colorsys.hsv_to_rgb(hsv[0] / 180.0, hsv[1] / 255.0, hsv[2] / 255.0)
    return round(255 * b), round(255 * g), round(255 * r)


def _colour_words(bgr: _BGR) -> str:
    """A rough name of a colour, for people (``"navy"``, ``"pale pink"``, ``"dark grey"``)."""
    h6, s1, v1 = colorsys.rgb_to_hsv(bgr[2] / 255.0, bgr[1] / 255.0, bgr[0] / 255.0)
    h, s, v = 180.0 * h6, 255.0 * s1, 255.0 * v1
    if s < 25 or (s < 40 and v < 60):
        for limit, word in ((55, "black"), (95, "dark grey"), (170, "grey"),
                            (215, "light grey")):
            if v < limit:
                return word
        return "white" if s < 12 else "off-white"
    name = next(word for limit, word in _HUE_NAMES if h < limit)
    if v < 95:
        return _DARK_NAMES.get(name, f"dark {name}")
    if s < 80 and v > 200:
        return f"pale {name}"
    if s < 150 and v < 215:
        return f"dusty {name}"
    return name


# --- the articles ----------------------------------------------------------------------------


@dataclass(frozen=True)
class _Draw:
    """One candidate article (or its twin), before it becomes a spec."""

    shape: str
    fabric: str
    kind: str  # colour kind of a coloured fabric, else ""
    twin: str | None  # how its twin differs: "colour", "size" or None (no twin)
    hue_t: float  # hue position of the colour (see _hue)
    hsv: _HSV | None  # plain or ground colour, OpenCV HSV (coloured fabrics only)
    photo: str | None
    tile_mm: float | None
    size_mm: tuple[float, float]
    hem: tuple[float, _BGR] | None = None  # (height mm, colour) of a contrasting hem

    @property
    def bgr(self) -> _BGR | None:
        return None if self.hsv is None else _bgr(self.hsv)

    def key(self) -> tuple[float, ...] | None:
        """What must differ besides the size, (6,): the colour (BGR) of a coloured fabric, or
        for a photo print its picture and repeat as a point far from any other picture's or
        repeat's; then the hem's colour, or a point far from every colour when there is no
        hem. None for plaid and camouflage (never the same)."""
        hem = _NO_HEM if self.hem is None else self.hem[1]
        if self.hsv is not None:
            return (*_bgr(self.hsv), *hem)
        if self.fabric == "photo":
            return (1000.0 * PHOTO_PRINTS.index(self.photo or ""),
                    1000.0 * list(_PHOTO_TILES).index(self.tile_mm), 0.0, *hem)
        return None


def _draw_size(shape: str, u_h: float, u_a: float, *, shrinkable: bool) -> tuple[float, float]:
    """(width, height), whole mm, within the model limit and the shape's aspect ratios; with
    ``shrinkable``, large enough that 0.8 times it keeps within the limit."""
    grow = 1.0 / _TWIN_SCALE if shrinkable else 1.0
    w_lo, w_hi = math.ceil(_WIDTH_MM[0] * grow), math.floor(_WIDTH_MM[1])
    h_lo, h_hi = math.ceil(_HEIGHT_MM[0] * grow), math.floor(_HEIGHT_MM[1])
    a_lo, a_hi = _ASPECT[shape]
    h_min, h_max = max(h_lo, w_lo / a_hi), min(h_hi, w_hi / a_lo)
    h = h_min + (h_max - h_min) * u_h
    a_min, a_max = max(a_lo, w_lo / h), min(a_hi, w_hi / h)
    w = h * (a_min + (a_max - a_min) * u_a)
    return float(min(max(round(w), w_lo), w_hi)), float(min(max(round(h), h_lo), h_hi))


@dataclass(frozen=True)
class _Head:
    """What a batch of candidates shares: shape, fabric and, unless None, colour kind and the
    coin that chooses the twin's kind."""

    shape: str
    fabric: str
    kind: str | None
    coin: float | None


def _draw_head(gen: np.random.Generator) -> _Head:
    u = gen.random(4).tolist()
    fabric = _pick(_FABRIC_CHOICE, u[1])
    return _Head(_pick(_SHAPE_CHOICE, u[0]), fabric,
                 _pick(_KIND_CHOICE, u[2]) if fabric in _COLOURED else "", u[3])


def _draw(gen: np.random.Generator, head: _Head, paired: bool, hem_share: float) -> _Draw:
    """A candidate article of ``head``; with ``paired``, it has a twin: a colour twin where the
    fabric allows one and the coin says so (``_COLOUR_TWINS``), else a size twin. A share
    ``hem_share`` of coloured and photo ones get a contrasting hem."""
    u = gen.random(12).tolist()
    fabric = head.fabric
    kind = head.kind if head.kind is not None else _pick(_KIND_CHOICE, u[0])
    coin = head.coin if head.coin is not None else u[1]
    twin = None
    if paired:
        # A light/dark swap of a dots ground would change its dots as well (dot_fabric picks
        # their colour by the ground's lightness): only a turned hue there.
        can = fabric in _COLOURED and (fabric != "dots" or kind in _TURNING)
        twin = "colour" if can and coin < _COLOUR_TWINS else "size"
    hue_t, hsv, photo, tile_mm = 0.0, None, None, None
    if fabric in _COLOURED:
        hue_t = _HUE_SPAN * u[2]
        hsv = _draw_hsv(kind, hue_t, u[3], u[4])
    elif fabric == "photo":
        photo = PHOTO_PRINTS[min(int(u[2] * len(PHOTO_PRINTS)), len(PHOTO_PRINTS) - 1)]
        tile_mm = _pick(_TILE_CHOICE, u[3])
    size = _draw_size(head.shape, u[5], u[6], shrinkable=twin == "size")
    hem = None
    if fabric in (*_COLOURED, "photo") and u[7] < hem_share:
        hem = (float(round(_HEM_MM[0] + (_HEM_MM[1] - _HEM_MM[0]) * u[8])),
               _hem_colour(hsv, u[9:12]))
    return _Draw(head.shape, fabric, kind, twin, hue_t, hsv, photo, tile_mm, size, hem)


def _hem_colour(hsv: _HSV | None, u: list[float]) -> _BGR:
    """A hem colour that stands out from the garment's colour ``hsv`` (if any): drawn like a
    plain colour; white or near-black where that would be less than twice the same-colour
    distance from it."""
    hem = _bgr(_draw_hsv(_pick(_KIND_CHOICE, u[0]), _HUE_SPAN * u[1], u[2], u[2]))
    if hsv is not None:
        main = _bgr(hsv)
        if sum((a - b) ** 2 for a, b in zip(hem, main, strict=True)) < (2 * _SAME_COLOUR_BGR) ** 2:
            return (236, 238, 240) if hsv[2] < 128.0 else (40, 38, 38)
    return hem


def _twin_of(draw: _Draw, u: float) -> _Draw:
    """The look-alike of ``draw``: its colour changed clearly, or its size times 0.8."""
    if draw.twin == "size":
        w, h = draw.size_mm
        return replace(draw, size_mm=(round(w * _TWIN_SCALE, 1), round(h * _TWIN_SCALE, 1)))
    assert draw.hsv is not None
    return replace(draw, hsv=_twin_hsv(draw.kind, draw.hsv, draw.hue_t, u))


def _identical(a: _Draw, b: _Draw) -> bool:
    """The distinctness rule of the module docstring: are two articles practically
    identical?"""
    ka, kb = a.key(), b.key()
    if a.shape != b.shape or a.fabric != b.fabric or ka is None or kb is None:
        return False
    size = max(abs(math.log(x / y)) for x, y in zip(a.size_mm, b.size_mm, strict=True))
    colour = sum((x - y) ** 2 for x, y in zip(ka[:3], kb[:3], strict=True))
    hem = sum((x - y) ** 2 for x, y in zip(ka[3:], kb[3:], strict=True))
    return (size < math.log(_SAME_SIZE) + _EPS
            and max(colour, hem) < _SAME_COLOUR_BGR ** 2 * (1.0 + _EPS))


class _Bucket:
    """The kept articles of one (shape, fabric): rows (key / 40, log size / log 1.15) (8,), so
    that two articles are the same where both size columns and each colour's distance differ
    by less than 1."""

    def __init__(self) -> None:
        self.n = 0
        self.rows = np.zeros((64, 8))
        self.streak = 0  # candidates in a row, over all articles, that found no room

    @property
    def full(self) -> bool:
        """Whether no candidate found room for so long that the bucket counts as full."""
        return self.streak >= _FULL_STREAK

    @staticmethod
    def _row(draw: _Draw) -> NDArray[np.float64]:
        key = draw.key()
        assert key is not None
        scale = math.log(_SAME_SIZE)
        return np.array([*(k / _SAME_COLOUR_BGR for k in key),
                         *(math.log(s) / scale for s in draw.size_mm)])

    def add(self, draw: _Draw) -> None:
        if self.n == len(self.rows):
            self.rows = np.concatenate([self.rows, np.zeros_like(self.rows)])
        self.rows[self.n] = self._row(draw)
        self.n += 1

    def clashes(self, draw: _Draw) -> bool:
        """Whether ``draw`` is practically identical to a kept article."""
        if self.n == 0 or draw.key() is None:
            return False
        row, rows = self._row(draw), self.rows[:self.n]
        near = np.abs(rows[:, 6] - row[6]) < 1.0 + _EPS
        near &= np.abs(rows[:, 7] - row[7]) < 1.0 + _EPS  # both sides the same
        if not near.any():
            return False
        d2 = (rows[near, :6] - row[:6]) ** 2
        return bool(((d2[:, :3].sum(axis=1) < 1.0 + _EPS)
                     & (d2[:, 3:].sum(axis=1) < 1.0 + _EPS)).any())


class _Catalogue:
    """Specs of the first articles, grown in index order under a lock."""

    def __init__(self) -> None:
        self.specs: list[GarmentSpec] = []
        self.twins: dict[int, tuple[int, str]] = {}
        self.buckets: dict[tuple[str, str], _Bucket] = {}
        self.lock = threading.Lock()

    def upto(self, n: int) -> list[GarmentSpec]:
        with self.lock:
            while len(self.specs) < n:
                self._grow()
            return self.specs

    def _clashes(self, draw: _Draw) -> bool:
        bucket = self.buckets.get((draw.shape, draw.fabric))
        return bucket is not None and bucket.clashes(draw)

    def _keep(self, draw: _Draw) -> None:
        if draw.key() is not None:
            self.buckets.setdefault((draw.shape, draw.fabric), _Bucket()).add(draw)

    def _try(self, gen: np.random.Generator, head: _Head, paired: bool, n: int,
             same_kind: int = 0) -> tuple[_Draw, _Draw | None] | None:
        """The first of ``n`` candidates of ``head`` (only the first ``same_kind`` of its colour
        kind, and with a hem as often as ``_HEM_SHARE`` says; the others more often) that, with
        its twin, resembles no kept article; None if none does or the shape and fabric are
        full."""
        bucket = self.buckets.get((head.shape, head.fabric))
        if bucket is not None and bucket.full:
            return None
        for k in range(n):
            if k == same_kind:
                head = replace(head, kind=None, coin=None)
            draw = _draw(gen, head, paired, _HEM_SHARE[k >= same_kind])
            twin = None if draw.twin is None else _twin_of(draw, float(gen.random()))
            if not self._clashes(draw) and (twin is None or not (
                    self._clashes(twin) or _identical(draw, twin))):
                if bucket is not None:
                    bucket.streak = 0
                return draw, twin
            if bucket is not None:
                bucket.streak += 1
        return None

    def _grow(self) -> None:
        """Add article ``len(specs)``, and its twin when it has one.

        Candidates of the first draw's shape, fabric and colour kind (``_SAME_KIND``), then of
        its shape and fabric in any colour kind (``_BATCH``), then of up to ``_ROUNDS`` other
        shapes and fabrics (``_BATCH`` each); the first that, with its twin, resembles no kept
        article is kept. Plaid (always free) if none does.
        """
        i = len(self.specs)
        paired = i % _TWIN_EVERY == _TWIN_EVERY - 2
        gen = np.random.default_rng([_ROOT_SEED, i])
        head = _draw_head(gen)
        kept = self._try(gen, head, paired, _SAME_KIND + _BATCH, _SAME_KIND)
        for _ in range(_ROUNDS):
            if kept is not None:
                break
            head = _draw_head(gen)
            kept = self._try(gen, head, paired, _BATCH)
        if kept is None:
            kept = self._try(gen, _Head(head.shape, "plaid", "", 1.0), paired, 1)
            assert kept is not None  # plaid is always free, and so is its size twin
        draw, twin = kept
        self._keep(draw)
        self.specs.append(_spec(i, draw))
        if twin is not None and draw.twin is not None:
            self._keep(twin)
            self.twins[i + 1] = (i, draw.twin)
            self.specs.append(_spec(i + 1, twin, original=i))


def _spec(index: int, draw: _Draw, original: int | None = None) -> GarmentSpec:
    """The spec of article ``index`` (the twin of ``original``, if given)."""
    bgr = draw.bgr
    shape = _SHAPE_WORDS[draw.shape]
    if bgr is not None and draw.fabric == "plain":
        words = f"{_colour_words(bgr)} {shape}"
    elif bgr is not None:
        words = f"{shape}, {_PATTERN_WORDS[draw.fabric]} on {_colour_words(bgr)}"
    elif draw.fabric == "photo":
        repeat = "" if draw.tile_mm is None else f", {draw.tile_mm:g} mm repeats"
        words = f"{shape} with a photo print ({draw.photo}{repeat})"
    else:
        words = f"{shape}, {'tartan' if draw.fabric == 'plaid' else 'camouflage'}"
    if original is not None:
        words += f" (look-alike of {_name(original)}: differs only in {draw.twin})"
    if draw.hem is not None:
        words = words.replace(shape, f"{shape} with a {_colour_words(draw.hem[1])} hem", 1)
    seed_index = index if original is None else original
    return GarmentSpec(_name(index), draw.shape, draw.fabric, draw.size_mm,
                       _SEED_OFFSET + seed_index, bgr, draw.photo, words,
                       hem=draw.hem, photo_tile_mm=draw.tile_mm)


_CATALOGUE = _Catalogue()


# --- public ----------------------------------------------------------------------------------


def _name(index: int) -> str:
    """``"cat-00042"`` for 42."""
    return f"cat-{index:05d}"


def _check_index(index: int, what: str = "index") -> int:
    if (isinstance(index, bool) or not isinstance(index, (int, np.integer))
            or not 0 <= index < MAX_CATALOGUE):
        raise ValueError(f"{what}: expected an integer from 0 to {MAX_CATALOGUE - 1}, "
                         f"got {index!r}")
    return int(index)


def is_catalogue_name(name: str) -> bool:
    """Whether ``name`` is an article of the simulated catalogue, ``cat-00000`` ...
    ``cat-99999`` (five digits)."""
    return isinstance(name, str) and _NAME.fullmatch(name) is not None


def _index_of(name: str) -> int:
    m = _NAME.fullmatch(name) if isinstance(name, str) else None
    if m is None:
        raise ValueError(f"name: expected an article of the simulated catalogue, cat-00000 to "
                         f"cat-{MAX_CATALOGUE - 1:05d} (five digits), got {name!r}")
    return int(m.group(1))


def catalogue_spec(index: int) -> GarmentSpec:
    """The spec of article ``index`` of the simulated catalogue (deterministic, cached).

    Parameters
    ----------
    index : int
        0 to ``MAX_CATALOGUE - 1``; the article's name is ``f"cat-{index:05d}"``.

    Returns
    -------
    GarmentSpec
        The same whatever else was asked before; :func:`~photomodel.sim.catalogue_garment`
        builds it (``catalogue_garment("cat-00042")``).

    Raises
    ------
    ValueError
        ``index`` is not an integer from 0 to ``MAX_CATALOGUE - 1``.
    """
    i = _check_index(index)
    return _CATALOGUE.upto(i + 1)[i]


def catalogue_names(n: int) -> tuple[str, ...]:
    """Names of the first ``n`` articles: ``("cat-00000", ..., f"cat-{n - 1:05d}")``.

    Raises
    ------
    ValueError
        ``n`` is not an integer from 0 to ``MAX_CATALOGUE``.
    """
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or not (
            0 <= n <= MAX_CATALOGUE):
        raise ValueError(f"n: expected an integer from 0 to {MAX_CATALOGUE}, got {n!r}")
    return tuple(_name(i) for i in range(int(n)))


def lookalike_of(name: str) -> tuple[str, str] | None:
    """The original of a designed look-alike of the simulated catalogue, and how they differ.

    Parameters
    ----------
    name : str
        An article, ``"cat-00000"`` ... ``"cat-99999"``.

    Returns
    -------
    (str, str) or None
        (original's name, ``"colour"`` or ``"size"``) for a twin (every index ending in 9),
        None for any other article.

    Raises
    ------
    ValueError
        ``name`` is not an article of the simulated catalogue.
    """
    i = _index_of(name)
    if i % _TWIN_EVERY != _TWIN_EVERY - 1:
        return None
    _CATALOGUE.upto(i + 1)
    original, kind = _CATALOGUE.twins[i]
    return _name(original), kind
