"""The whole table: several garments piled up, distractors beside or on them, and the truth.

A :class:`TableLayout` is what lies on the table: catalogue garments (:class:`TableGarment`) in
their stacking order, bottom to top, and distractors (:class:`TableDistractor`: foreign
garments, boxes, trays, tape, a gripper held above). It is settled: each resting thing lies one
cloth thickness (:data:`CLOTH_THICKNESS_MM`) above the highest thing under it, so its layer is
1 + the highest layer among the earlier things whose footprints (silhouettes in the table plane,
:mod:`photomodel.sim._footprint`) it overlaps by at least :data:`MIN_OVERLAP_MM2`, or 0 on the
bare table. The table frame's z axis points into the table (:func:`hand_table_pose`), so a layer
``L`` lies at ``z = -L * CLOTH_THICKNESS_MM``. Cloth never lies on objects; objects rest on the
cloth under them and are drawn over all cloth (they are tall, and drawn like the single-garment
scenes draw them).

:meth:`TableLayout.render` renders both hand cameras in one pass each and returns, per garment,
its pose, layer, visible fraction in each camera and the garments lying on it
(:class:`GarmentTruth`). :meth:`TableLayout.without` and :meth:`TableLayout.moved` give the
table after a pick (the things above fall onto what is left under them), for a cell that looks
again. :func:`random_table` draws a pile; :func:`simulate_table` draws a whole shot of one
under given conditions (what ``photomodel simulate --table N`` writes).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from photomodel.camera import PinholeCamera, StereoRig
from photomodel.sim._conditions import Conditions, expose
from photomodel.sim._footprint import Footprint, footprint, union
from photomodel.sim._garments import Garment
from photomodel.sim._mesh import Wrinkles, field_of_view_radius, make_wrinkles
from photomodel.sim._objects import OBJECT_KINDS, gripper, make_object
from photomodel.sim._render import (
    DEFAULT_LIGHT_DIR,
    Layer,
    _check_transform,
    render_view_linear,
)
from photomodel.sim._rigs import hand_stereo_rig, hand_table_pose
from photomodel.sim._scenes import (
    POSITION_RANGE_MM,
    THETA_RANGE_DEG,
    _footprint_mm,
    _foreign_garment,
    _inside_both,
    _radius_mm,
    _tilt,
    garment_placement,
)
from photomodel.sim._tables import make_table
from photomodel.sim._textures import PlaneTexture, RngLike

__all__ = [
    "CLOTH_THICKNESS_MM",
    "MAX_TABLE_GARMENTS",
    "MIN_OVERLAP_MM2",
    "MIN_TABLE_GARMENTS",
    "GarmentTruth",
    "TableDistractor",
    "TableGarment",
    "TableLayout",
    "TableShot",
    "random_table",
    "simulate_table",
]

CLOTH_THICKNESS_MM = 1.5
"""Height of one layer of the pile, mm: a garment lies this much above the one under it (a
folded-flat T-shirt is 1-3 mm thick). It keeps every garment's true pose on its own plane and
gives each camera the parallax of a real pile, small beside the 685 mm working distance."""

MIN_OVERLAP_MM2 = 25.0
"""Least footprint overlap, mm^2, for one thing to lie on another: smaller contacts (edges that
touch within a cell or two) neither lift it nor count as covering."""

MIN_TABLE_GARMENTS = 2
MAX_TABLE_GARMENTS = 6
"""Garments on a simulated table: from :data:`MIN_TABLE_GARMENTS` to this many."""

_OVERLAP_PROBABILITY = 0.65  # a garment after the first is placed over earlier ones
_SAME_MODEL_PROBABILITY = 0.15  # a garment after the first repeats a model already there
_REACH = (0.3, 1.0)  # centre distance from the garment under it, in sums of their radii
_ON_PILE_PROBABILITY = {"garment": 0.5, "object": 0.25}  # a distractor lies on the pile
_GAP_MM = 10.0  # least gap between a garment placed apart and everything else
_OBJECT_GAP_MM = 30.0  # least gap between an object beside the pile and anything else
_MIN_COVER_SHARE = 0.04  # an overlapping placement covers at least this share of something
_TRIES = 400


@dataclass(frozen=True)
class TableGarment:
    """A catalogue garment lying on the table.

    Parameters
    ----------
    instance : int
        Its number on this table (unique; two garments of one model are two instances).
    garment : Garment
        The catalogue garment (its ``name`` is the model's name).
    T_table_garment : ndarray (4, 4)
        Pose of the garment frame in the table frame, mm; its z is ``-layer *``
        :data:`CLOTH_THICKNESS_MM` (the table's z points into the table).
    layer : int
        Height in cloth layers, 0 = on the bare table.
    wrinkles : Wrinkles, optional
        Its folds (None: flat).
    """

    instance: int
    garment: Garment
    T_table_garment: NDArray[np.float64]
    layer: int
    wrinkles: Wrinkles | None = None

    @property
    def model(self) -> str:
        """The garment's model (catalogue) name."""
        return self.garment.name


@dataclass(frozen=True)
class TableDistractor:
    """A thing on the table that is not a catalogue garment.

    Parameters
    ----------
    kind : str
        ``"garment"`` (a garment not in the catalogue), one of :data:`OBJECT_KINDS`, or
        ``"gripper"`` (held above the table, not resting on it).
    parts : tuple of Layer
        Its layers in its own frame (z into the table, origin on the surface under it).
    T_table_distractor : ndarray (4, 4)
        Pose of its frame in the table frame, mm (z set by its layer when it rests).
    layer : int
        Height in cloth layers of what it rests on (0 = the bare table); -1 for the gripper.
    """

    kind: str
    parts: tuple[Layer, ...]
    T_table_distractor: NDArray[np.float64]
    layer: int = 0

    @property
    def resting(self) -> bool:
        """Whether it lies on the table or the pile (False for a gripper held above)."""
        return self.kind != "gripper"

    @property
    def is_cloth(self) -> bool:
        return self.kind == "garment"

    def placed(self) -> list[Layer]:
        """Its layers in the table frame."""
        return [dataclasses.replace(p, T_plane_item=self.T_table_distractor @ p.T_plane_item)
                for p in self.parts]


@dataclass(frozen=True)
class GarmentTruth:
    """What the simulator knows about one garment of a rendered table.

    Parameters
    ----------
    instance : int
    model : str
    T_cam1_model : ndarray (4, 4)
        Pose of the garment frame in camera 1's frame, mm (at its layer's height).
    layer : int
        0 = on the bare table.
    visible_fraction : (float, float)
        Share of the garment's area camera 1 and camera 2 see: inside the image and hidden by
        nothing drawn over it, [0, 1].
    covered_by : tuple of int
        Instances of the catalogue garments lying on it (overlapping its footprint by at least
        :data:`MIN_OVERLAP_MM2`, at a higher layer), in stacking order.
    covered_by_distractors : tuple of int
        Indices into the shot's distractors of those resting on it.
    """

    instance: int
    model: str
    T_cam1_model: NDArray[np.float64]
    layer: int
    visible_fraction: tuple[float, float]
    covered_by: tuple[int, ...]
    covered_by_distractors: tuple[int, ...] = ()

    def to_json_dict(self, names: dict[int, str] | None = None) -> dict[str, Any]:
        """``{"instance", "model", "T_cam1_model", "layer", "visible_fraction", "covered_by",
        "covered_by_instances"}``: the truth file's entry of the garment; ``covered_by`` names
        the models lying on it (``names``: instance -> model of the table's garments),
        ``covered_by_instances`` tells two of one model apart."""
        names = names or {}
        return {"instance": self.instance, "model": self.model,
                "T_cam1_model": self.T_cam1_model.tolist(), "layer": self.layer,
                "visible_fraction": list(self.visible_fraction),
                "covered_by": [names.get(i, str(i)) for i in self.covered_by],
                "covered_by_instances": list(self.covered_by)}


@dataclass(frozen=True)
class TableShot:
    """A stereo shot of a table, with its truth (:meth:`TableLayout.render`).

    Parameters
    ----------
    right_bgr, left_bgr : ndarray (H, W, 3) uint8
        Camera 1's and camera 2's images.
    garments : tuple of GarmentTruth
        Every catalogue garment, bottom to top (the layout's order).
    distractors : tuple of dict
        JSON-ready facts of each distractor: ``kind``, ``x_mm``, ``y_mm``, ``theta_deg``
        (placement on the table), ``layer`` (-1: held above) and ``covers`` (instances of the
        garments it rests on).
    """

    right_bgr: NDArray[np.uint8]
    left_bgr: NDArray[np.uint8]
    garments: tuple[GarmentTruth, ...]
    distractors: tuple[dict[str, Any], ...] = ()

    @property
    def pick_first(self) -> GarmentTruth | None:
        """The garment to pick first: nothing lies on it (no garment and, if there is such a
        garment, no distractor either), best seen by camera 1, the higher on a tie; None on
        an empty table."""
        free = [g for g in self.garments if not g.covered_by]
        clear = [g for g in free if not g.covered_by_distractors] or free
        if not clear:
            return None
        return max(clear, key=lambda g: (g.visible_fraction[0], g.layer, -g.instance))

    def to_json_dict(self) -> dict[str, Any]:
        """The scene's truth: ``model``, ``T_cam1_model`` and ``visible_fraction`` of
        :attr:`pick_first` (as a single-garment scene has them; null on an empty table),
        ``table`` (the number of garments), ``garments`` (:meth:`GarmentTruth.to_json_dict`,
        bottom to top), ``pick_first`` (its instance) and ``distractors``."""
        first = self.pick_first
        return {"model": None if first is None else first.model,
                "T_cam1_model": None if first is None else first.T_cam1_model.tolist(),
                "visible_fraction": None if first is None else list(first.visible_fraction),
                "table": len(self.garments),
                "pick_first": None if first is None else first.instance,
                "garments": [g.to_json_dict({h.instance: h.model for h in self.garments})
                             for g in self.garments],
                "distractors": [dict(d) for d in self.distractors]}


def _with_height(T: NDArray[np.float64], layer: int) -> NDArray[np.float64]:
    out = np.array(T, dtype=np.float64)
    out[2, 3] = -max(layer, 0) * CLOTH_THICKNESS_MM
    return out


def _garment_footprint(g: TableGarment) -> Footprint | None:
    return footprint(g.garment.texture, g.T_table_garment)


def _distractor_footprint(d: TableDistractor) -> Footprint | None:
    if not d.resting:
        return None
    parts = [f for f in (footprint(p.texture, p.T_plane_item) for p in d.placed())
             if f is not None]
    return union(parts)


def _in_image_fraction(camera: PinholeCamera, T_cam_item: NDArray[np.float64],
                       texture: PlaneTexture, spacing_mm: float = 2.0) -> float:
    """Share of a flat item's area (alpha-weighted) that projects inside the image."""
    step = max(1, round(spacing_mm / texture.mm_per_px))
    alpha = texture.alpha[::step, ::step]
    v, u = np.nonzero(alpha > 0.0)
    weight = alpha[v, u].astype(np.float64)
    xy = texture.mm_from_px(np.column_stack([u * step, v * step]).astype(np.float64))
    p = xy @ T_cam_item[:3, :2].T + T_cam_item[:3, 3]
    ahead = p[:, 2] > 1e-6
    with np.errstate(divide="ignore", invalid="ignore"):
        radius = np.hypot(p[:, 0], p[:, 1]) / p[:, 2]
    ok = ahead & (radius <= field_of_view_radius(camera))
    uv = camera.project(p[ok])
    inside = ((uv[:, 0] >= -0.5) & (uv[:, 0] <= camera.width_px - 0.5)
              & (uv[:, 1] >= -0.5) & (uv[:, 1] <= camera.height_px - 0.5))
    return float(weight[ok][inside].sum() / max(weight.sum(), 1e-12))


@dataclass(frozen=True)
class TableLayout:
    """What lies on the table: a settled pile of garments and the distractors.

    Build one with :func:`random_table`, or by hand and :meth:`settled`.

    Parameters
    ----------
    garments : tuple of TableGarment
        The catalogue garments in stacking order, bottom to top.
    surface : PlaneTexture
        The table surface (:func:`make_table`), kept so that every look sees the same table.
    distractors : tuple of TableDistractor
        Foreign garments, objects and a gripper, in the order they were put down.
    light_dir_table : (float, float, float)
        Direction towards the light in the table frame (z into the table).
    """

    garments: tuple[TableGarment, ...]
    surface: PlaneTexture
    distractors: tuple[TableDistractor, ...] = ()
    light_dir_table: tuple[float, float, float] = DEFAULT_LIGHT_DIR

    @property
    def instances(self) -> tuple[int, ...]:
        """The garments' instances, bottom to top."""
        return tuple(g.instance for g in self.garments)

    def garment(self, instance: int) -> TableGarment:
        """The garment of an instance; ValueError naming the ones there when it is not."""
        for g in self.garments:
            if g.instance == instance:
                return g
        raise ValueError(f"instance: no garment {instance} on the table; there are "
                         f"{', '.join(map(str, self.instances)) or 'none'}")

    def without(self, instance: int) -> TableLayout:
        """The table after the garment ``instance`` is taken away: what lay on it falls onto
        what is under it (settled again)."""
        self.garment(instance)
        kept = tuple(g for g in self.garments if g.instance != instance)
        return dataclasses.replace(self, garments=kept).settled()

    def moved(self, instance: int, T_table_garment: ArrayLike, *,
              on_top: bool = False) -> TableLayout:
        """The table after the garment ``instance`` moved to ``T_table_garment`` (4, 4), mm.

        Its place in the stacking order stays (what lay over it still does where it still
        overlaps), or with ``on_top`` it lies over everything; the table is settled again,
        which sets its height (the z of ``T_table_garment`` is replaced).
        """
        T = _check_transform(T_table_garment, "T_table_garment")
        self.garment(instance)
        garments = list(self.garments)
        k = self.instances.index(instance)
        moved = dataclasses.replace(garments[k], T_table_garment=T.copy())
        if on_top:
            del garments[k]
            garments.append(moved)
            top = max((g.layer for g in self.garments), default=0)
            top = max([top] + [d.layer for d in self.distractors if d.is_cloth])
            moved = dataclasses.replace(moved, layer=top + 1)
            garments[-1] = moved
        else:
            garments[k] = moved
        return dataclasses.replace(self, garments=tuple(garments)).settled()

    def settled(self) -> TableLayout:
        """The same things, each resting one cloth thickness above the highest thing under it.

        Cloth (garments and foreign garments) is taken in its present order (layer, then
        garments before foreign ones, then list order) and each put on what was put before
        it; objects then rest on the cloth under them. Garments come back bottom to top.
        """
        cloth: list[tuple[tuple[float, int, int], str, int]] = []
        for k, g in enumerate(self.garments):
            cloth.append(((g.layer, 0, k), "g", k))
        for k, d in enumerate(self.distractors):
            if d.is_cloth:
                cloth.append(((d.layer, 1, k), "d", k))
        cloth.sort(key=lambda c: c[0])
        garment_prints = [_garment_footprint(g) for g in self.garments]
        distractor_prints = [_distractor_footprint(d) for d in self.distractors]
        layers_g: dict[int, int] = {}
        layers_d: dict[int, int] = {}
        below: list[tuple[Footprint | None, int]] = []
        order: list[int] = []
        for _, what, k in cloth:
            fp = garment_prints[k] if what == "g" else distractor_prints[k]
            layer = 1 + max((lay for other, lay in below
                             if fp is not None and other is not None
                             and fp.overlap_mm2(other) >= MIN_OVERLAP_MM2), default=-1)
            below.append((fp, layer))
            if what == "g":
                layers_g[k] = layer
                order.append(k)
            else:
                layers_d[k] = layer
        for k, d in enumerate(self.distractors):
            fp = distractor_prints[k]
            if d.resting and not d.is_cloth:
                layers_d[k] = 1 + max((lay for other, lay in below
                                       if fp is not None and other is not None
                                       and fp.overlap_mm2(other) >= MIN_OVERLAP_MM2),
                                      default=-1)
        garments = tuple(dataclasses.replace(
            self.garments[k], layer=layers_g[k],
            T_table_garment=_with_height(self.garments[k].T_table_garment, layers_g[k]))
            for k in order)
        distractors = tuple(
            dataclasses.replace(d, layer=layers_d[k], T_table_distractor=_with_height(
                d.T_table_distractor, layers_d[k])) if k in layers_d else d
            for k, d in enumerate(self.distractors))
        return dataclasses.replace(self, garments=garments, distractors=distractors)

    def covered_by(self) -> dict[int, tuple[tuple[int, ...], tuple[int, ...]]]:
        """Per instance: (instances of the garments lying on it, indices of the distractors
        resting on it), from the footprints and layers."""
        prints = [_garment_footprint(g) for g in self.garments]
        dprints = [_distractor_footprint(d) for d in self.distractors]
        out = {}
        for g, fp in zip(self.garments, prints, strict=True):
            over = tuple(h.instance for h, hp in zip(self.garments, prints, strict=True)
                         if h.layer > g.layer and fp is not None and hp is not None
                         and fp.overlap_mm2(hp) >= MIN_OVERLAP_MM2)
            on = tuple(k for k, (d, dp) in enumerate(zip(self.distractors, dprints,
                                                         strict=True))
                       if d.resting and d.layer > g.layer and fp is not None
                       and dp is not None and fp.overlap_mm2(dp) >= MIN_OVERLAP_MM2)
            out[g.instance] = (over, on)
        return out

    def _items(self) -> tuple[list[Layer], list[int]]:
        """Layers in drawing order and the index of each garment's layer among them."""
        cloth: list[tuple[tuple[int, int, int], list[Layer], int]] = []
        for k, g in enumerate(self.garments):
            layer = Layer(g.garment.texture, g.T_table_garment, g.wrinkles)
            cloth.append(((g.layer, 0, k), [layer], k))
        for k, d in enumerate(self.distractors):
            if d.is_cloth:
                cloth.append(((d.layer, 1, k), d.placed(), -1))
        cloth.sort(key=lambda c: c[0])
        items: list[Layer] = []
        index = [0] * len(self.garments)
        for _, parts, k in cloth:
            if k >= 0:
                index[k] = len(items)
            items.extend(parts)
        objects = sorted((d for d in self.distractors if d.resting and not d.is_cloth),
                         key=lambda d: d.layer)
        for d in [*objects, *(d for d in self.distractors if not d.resting)]:
            items.extend(d.placed())
        return items, index

    def render(self, rig: StereoRig, T_cam1_table: ArrayLike,
               conditions: Conditions | None = None, rng: RngLike = None) -> TableShot:
        """Both hand cameras' images of the table, and every garment's truth.

        Parameters
        ----------
        rig : StereoRig
        T_cam1_table : ndarray (4, 4)
            Pose of the table frame in camera 1's frame, mm (:func:`hand_table_pose`, or any
            other look).
        conditions : Conditions, optional
            Light, lens response, noise (the layout holds the table, its contents and the
            light's direction); default: the paper's.
        rng : int or Generator, optional
            Seed or generator of the sensor noise.

        Returns
        -------
        TableShot
            Visible fractions from the render (one pass per camera tracks every garment):
            the share of each garment's area inside the image (from its silhouette) times the
            share of its image that nothing drawn later hides.
        """
        conditions = Conditions() if conditions is None else conditions
        T_cam1_table = _check_transform(T_cam1_table, "T_cam1_table")
        gen = np.random.default_rng(rng)
        items, index = self._items()
        images = []
        fractions = np.zeros((len(self.garments), 2))
        for c, (camera, T_cam_cam1) in enumerate(((rig.cam1, np.eye(4)),
                                                  (rig.cam2, rig.T_cam2_cam1))):
            T_cam_table = T_cam_cam1 @ T_cam1_table
            view = render_view_linear(camera, T_cam_table, self.surface, items, track=index,
                                      light_dir_plane=self.light_dir_table)
            images.append(expose(view.image, camera, conditions, gen))
            for k, g in enumerate(self.garments):
                seen = float(view.coverages[k].sum())
                unhidden = float(view.visibles[k].sum()) / seen if seen > 0 else 0.0
                inside = _in_image_fraction(camera, T_cam_table @ g.T_table_garment,
                                            g.garment.texture)
                fractions[k, c] = min(max(inside * unhidden, 0.0), 1.0)
        covers = self.covered_by()
        truths = tuple(GarmentTruth(
            g.instance, g.model, T_cam1_table @ g.T_table_garment, g.layer,
            (float(fractions[k, 0]), float(fractions[k, 1])), covers[g.instance][0],
            covers[g.instance][1]) for k, g in enumerate(self.garments))
        facts = []
        for k, d in enumerate(self.distractors):
            T = d.T_table_distractor
            facts.append({"kind": d.kind, "x_mm": float(T[0, 3]), "y_mm": float(T[1, 3]),
                          "theta_deg": float(np.degrees(np.arctan2(T[1, 0], T[0, 0]))),
                          "layer": d.layer if d.resting else -1,
                          "covers": [g.instance for g in self.garments
                                     if k in covers[g.instance][1]]})
        return TableShot(images[0], images[1], truths, tuple(facts))


# --- random piles ---------------------------------------------------------------------------


def _choose_models(pool: Sequence[Garment], n: int, gen: np.random.Generator,
                   same_model_allowed: bool) -> list[Garment]:
    chosen: list[int] = []
    for _ in range(n):
        fresh = [k for k in range(len(pool)) if k not in chosen]
        repeat = chosen and same_model_allowed and (
            not fresh or gen.random() < _SAME_MODEL_PROBABILITY)
        options = chosen if repeat else fresh
        chosen.append(options[int(gen.integers(len(options)))])
    return [pool[k] for k in chosen]


def _overlaps(fp: Footprint, others: Sequence[Footprint]) -> list[float]:
    return [fp.overlap_mm2(o) for o in others]


def _place_garment(garment: Garment, placed: list[Footprint], gen: np.random.Generator,
                   rig: StereoRig, T_cam1_table: NDArray[np.float64],
                   overlap: bool) -> tuple[NDArray[np.float64], Footprint] | None:
    """An in-plane placement that keeps the garment inside both images and, with ``overlap``,
    lies over one or more placed garments (covering a share of one), else clear of them."""
    outline = _footprint_mm(garment.texture)
    radius = _radius_mm(garment.texture)
    half = (POSITION_RANGE_MM[0] / 2, POSITION_RANGE_MM[1] / 2)
    clear = None if overlap else union([f.dilated(_GAP_MM) for f in placed])
    for _ in range(_TRIES):
        theta = gen.uniform(*THETA_RANGE_DEG)
        if overlap:
            anchor = placed[int(gen.integers(len(placed)))]
            centre = anchor.centre_mm
            reach = gen.uniform(*_REACH) * (radius + anchor.radius_mm)
            direction = gen.uniform(-np.pi, np.pi)
            x, y = centre[0] + reach * np.cos(direction), centre[1] + reach * np.sin(direction)
        else:
            x, y = gen.uniform(-half[0], half[0]), gen.uniform(-half[1], half[1])
        T = garment_placement(float(x), float(y), float(theta))
        if not _inside_both(rig, T_cam1_table @ T, outline):
            continue
        fp = footprint(garment.texture, T)
        if fp is None:
            continue
        if overlap:
            shares = [a / min(fp.area_mm2, o.area_mm2)
                      for a, o in zip(_overlaps(fp, placed), placed, strict=True)]
            if max(shares) < _MIN_COVER_SHARE:
                continue
        elif clear is not None and fp.overlap_mm2(clear) > 0.0:
            continue
        return T, fp
    return None


def _place_distractor(parts: list[Layer], cloth: list[Footprint], objects: list[Footprint],
                      gen: np.random.Generator, on_pile: bool, gap_mm: float,
                      anchor: Footprint | None = None
                      ) -> tuple[NDArray[np.float64], Footprint] | None:
    """A placement on the pile (over part of the cloth, or of ``anchor``; clear of objects)
    or beside it (at least ``gap_mm`` from everything)."""
    half = (POSITION_RANGE_MM[0] / 2, POSITION_RANGE_MM[1] / 2)
    base = union([f for f in (footprint(p.texture, p.T_plane_item) for p in parts)
                  if f is not None])
    radius = base.radius_mm if base is not None else 50.0
    avoid = union(objects) if on_pile else union([f.dilated(gap_mm) for f in cloth + objects])
    for _ in range(_TRIES):
        angle = gen.uniform(-180.0, 180.0)
        if on_pile:
            target = anchor if anchor is not None else cloth[int(gen.integers(len(cloth)))]
            centre = target.centre_mm
            reach = gen.uniform(0.4, 0.9) * (radius + target.radius_mm)
            direction = gen.uniform(-np.pi, np.pi)
            x, y = centre[0] + reach * np.cos(direction), centre[1] + reach * np.sin(direction)
        else:
            x, y = gen.uniform(-half[0], half[0]), gen.uniform(-half[1], half[1])
        T = garment_placement(float(x), float(y), float(angle))
        prints = [f for f in (footprint(p.texture, T @ p.T_plane_item) for p in parts)
                  if f is not None]
        fp = union(prints)
        if fp is None:
            continue
        if on_pile:
            if max(_overlaps(fp, cloth), default=0.0) < MIN_OVERLAP_MM2 or (
                    anchor is not None and fp.overlap_mm2(anchor) < MIN_OVERLAP_MM2):
                continue
        if avoid is not None and fp.overlap_mm2(avoid) > 0.0:
            continue
        return T, fp
    return None


def _gripper_over(target: TableGarment, gen: np.random.Generator) -> TableDistractor:
    """A gripper 40-120 mm above the table, its fingertips over part of ``target``."""
    layers, _ = gripper(gen)
    radius = _radius_mm(target.garment.texture)
    direction = gen.uniform(-np.pi, np.pi)
    x0, y0 = target.T_table_garment[0, 3], target.T_table_garment[1, 3]
    reach = gen.uniform(0.1, 0.5) * radius
    tip = np.array([x0, y0]) + reach * np.array([np.cos(direction), np.sin(direction)])
    T = garment_placement(tip[0], tip[1], float(np.degrees(direction)))
    T[2, 3] = -float(gen.uniform(40.0, 120.0))
    return TableDistractor("gripper", tuple(layers), T, -1)


def random_table(
    garments: Sequence[Garment],
    n: int,
    rng: RngLike = None,
    conditions: Conditions | None = None,
    *,
    rig: StereoRig | None = None,
    T_cam1_table: ArrayLike | None = None,
    same_model_allowed: bool = True,
) -> TableLayout:
    """A random pile of ``n`` garments drawn from ``garments``, with distractors.

    Each garment after the first lies, with probability 0.65, over one or more of the earlier
    ones (covering at least 4 % of one of them, up to nearly all of it), else on a free part
    of the table at least 10 mm from the others (over them if no free place is found); every
    garment lies wholly inside both images (6 px margin), at an in-plane angle within
    :data:`THETA_RANGE_DEG`. Distractors follow ``conditions``: ``distractor_garments``
    foreign garments (half of them on the pile) and ``distractor_objects`` objects (a quarter
    on the pile), the others beside it, clear of everything; ``occlusion`` adds a gripper
    above a garment or a foreign garment over one. With ``wrinkle_height_mm`` every garment
    has folds.

    Parameters
    ----------
    garments : sequence of Garment
        The models that can appear (e.g. catalogue garments).
    n : int
        Garments on the table, :data:`MIN_TABLE_GARMENTS` to :data:`MAX_TABLE_GARMENTS`.
    rng : int or Generator, optional
        Seed or generator of every choice.
    conditions : Conditions, optional
        Table surface, distractors, occlusion, wrinkles (default: the paper's, no
        distractors).
    rig : StereoRig, optional
        The cameras that must see every garment (default: :func:`hand_stereo_rig` with the
        conditions' lens).
    T_cam1_table : ndarray (4, 4), optional
        Pose of the table in camera 1's frame (default: :func:`hand_table_pose`).
    same_model_allowed : bool
        Let a model appear twice (each garment after the first repeats one already there with
        probability 0.15, and always when ``garments`` has fewer than ``n``).

    Returns
    -------
    TableLayout
        Settled; instances 0 .. n - 1 in the order the garments were put down.

    Raises
    ------
    ValueError
        ``n`` out of range, no garments, too few for ``n`` without repeats, or a garment that
        does not fit inside both images.
    """
    if not isinstance(n, int | np.integer) or not (
            MIN_TABLE_GARMENTS <= n <= MAX_TABLE_GARMENTS):
        raise ValueError(f"n: expected an integer from {MIN_TABLE_GARMENTS} to "
                         f"{MAX_TABLE_GARMENTS}, got {n}")
    pool = list(garments)
    if not pool:
        raise ValueError("garments: expected at least one")
    if not same_model_allowed and len(pool) < n:
        raise ValueError(f"garments: {len(pool)} model(s) cannot make a table of {n} without "
                         "repeating one (allow same_model_allowed)")
    conditions = Conditions() if conditions is None else conditions
    gen = np.random.default_rng(rng)
    rig = hand_stereo_rig(lens=conditions.lens) if rig is None else rig
    T_cam1_table = (hand_table_pose(rig) if T_cam1_table is None
                    else _check_transform(T_cam1_table, "T_cam1_table"))
    surface = make_table(conditions.table, gen)
    placed: list[Footprint] = []
    table: list[TableGarment] = []
    for k, garment in enumerate(_choose_models(pool, int(n), gen, same_model_allowed)):
        overlap = k > 0 and gen.random() < _OVERLAP_PROBABILITY
        spot = _place_garment(garment, placed, gen, rig, T_cam1_table, overlap)
        if spot is None and k > 0:
            spot = _place_garment(garment, placed, gen, rig, T_cam1_table, not overlap)
        if spot is None:
            raise ValueError(f"garments: {garment.name} does not fit inside both images")
        wrinkles = (make_wrinkles(garment.texture, gen, conditions.wrinkle_height_mm)
                    if conditions.wrinkle_height_mm > 0 else None)
        placed.append(spot[1])
        table.append(TableGarment(k, garment, spot[0], k, wrinkles))
    cloth = list(placed)
    objects: list[Footprint] = []
    distractors: list[TableDistractor] = []
    wanted = (["garment"] * conditions.distractor_garments
              + [OBJECT_KINDS[int(gen.integers(len(OBJECT_KINDS)))]
                 for _ in range(conditions.distractor_objects)])
    wanted.sort(key=lambda kind: kind != "garment")  # cloth first: objects rest on it
    if conditions.occlusion == "garment":
        wanted.insert(0, "over")
    for kind in wanted:
        anchor = None
        if kind == "over":  # the occlusion condition: a foreign garment over a garment
            anchor = placed[int(gen.integers(len(placed)))]
        is_cloth = kind in ("garment", "over")
        parts = ([Layer(_foreign_garment(gen).texture, np.eye(4))] if is_cloth
                 else make_object(kind, gen))
        on_pile = anchor is not None or (
            gen.random() < _ON_PILE_PROBABILITY["garment" if is_cloth else "object"])
        gap = _GAP_MM if is_cloth else _OBJECT_GAP_MM
        spot = _place_distractor(parts, cloth, objects, gen, on_pile, gap, anchor)
        if spot is None and anchor is None:
            spot = _place_distractor(parts, cloth, objects, gen, not on_pile, gap)
        if spot is None:
            continue
        (cloth if is_cloth else objects).append(spot[1])
        order = len(table) + len(distractors)  # put down after everything before it
        distractors.append(TableDistractor("garment" if is_cloth else kind, tuple(parts),
                                           spot[0], order))
    if conditions.occlusion == "gripper":
        distractors.append(_gripper_over(table[int(gen.integers(len(table)))], gen))
    elevation = np.radians(gen.uniform(50.0, 80.0))
    azimuth = gen.uniform(0.0, 2.0 * np.pi)
    light = (float(np.cos(elevation) * np.cos(azimuth)),
             float(np.cos(elevation) * np.sin(azimuth)), float(-np.sin(elevation)))
    return TableLayout(tuple(table), surface, tuple(distractors), light).settled()


def simulate_table(
    garments: Sequence[Garment],
    n: int,
    rig: StereoRig,
    conditions: Conditions | None = None,
    rng: RngLike = None,
    *,
    same_model_allowed: bool = True,
) -> tuple[TableShot, dict[str, Any]]:
    """One stereo shot of a random table (:func:`random_table`) under ``conditions``.

    The table faces the rig (:func:`hand_table_pose`), tilted by up to
    ``conditions.tilt_deg`` about a random in-plane axis.

    Returns
    -------
    shot : TableShot
    info : dict
        JSON-ready facts of the shot: ``tilt_deg``, ``light_elevation_deg``,
        ``light_azimuth_deg``.
    """
    conditions = Conditions() if conditions is None else conditions
    if not conditions.target:
        raise ValueError("conditions: a table needs garments (conditions without a target "
                         "have none)")
    gen = np.random.default_rng(rng)
    T_tilt, tilt_deg = _tilt(gen, conditions.tilt_deg)
    T_cam1_table = hand_table_pose(rig) @ T_tilt
    layout = random_table(garments, n, gen, conditions, rig=rig, T_cam1_table=T_cam1_table,
                          same_model_allowed=same_model_allowed)
    shot = layout.render(rig, T_cam1_table, conditions, gen)
    light = np.asarray(layout.light_dir_table)
    info = {"tilt_deg": tilt_deg,
            "light_elevation_deg": float(np.degrees(np.arcsin(-light[2]))),
            "light_azimuth_deg": float(np.degrees(np.arctan2(light[1], light[0])) % 360.0)}
    return shot, info

