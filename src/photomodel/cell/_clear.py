"""Clearing tables (``photomodel cell --tables K --garments N``): look, pick the garment to pick
first, place it into the box of its model, look again, until the table is empty.

Each table is a random pile of catalogue garments (:func:`~photomodel.sim.random_table`, the
hand cameras at the photographing pose seeing it as :func:`~photomodel.sim.hand_table_pose`
renders it). Each look renders the table as it lies now, runs
:meth:`~photomodel.identify.Identifier.all` on the catalogue's station models, and takes the
first of its pick order. The simulator's truth says which garment that was (the one nearest
the estimated pose), whether something lay on it, and its model; the pick is planned with the
simulated hand-eye calibration into the box of the *identified* model (one box per model,
:func:`box_layouts`). A pick whose grasp point lies within the tolerance of the truth takes the
garment away (what lay on it settles onto what was under it); a pick that misses leaves it,
pushed a little. A pick may also drag the garment it lay on (``drag_probability``): that one
then lies elsewhere, and the next look must find it where it now lies.

Each look can be kept (:class:`ClearLook`: camera 1's image, what was found, the pick and the
boxes' counts) for :func:`~photomodel.cell.animate_clear`.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field, replace
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from photomodel.cell._cell import CellSetup, _photo_model, _stats, make_cell
from photomodel.model import PhotoModel
from photomodel.robot import (
    CellLayout,
    PickSettings,
    UnreachableError,
    forward_kinematics,
    grasp_pose,
    plan_pick,
)

if TYPE_CHECKING:
    from photomodel.identify import TableResult

__all__ = ["ClearConfig", "ClearLook", "ClearReport", "box_layouts", "clear_table",
           "run_clear"]

BOX_ROWS_Y_MM = (-600.0, 600.0)
BOX_COLUMNS_X_MM = (150.0, 410.0, -110.0, 670.0, -370.0, -630.0)
"""Where the boxes stand (base frame, floor level): two rows beside the arm, 260 mm apart."""


@dataclass(frozen=True)
class ClearConfig:
    """Settings of a table-clearing run.

    Parameters
    ----------
    tables : int
    garments : int
        Garments on each table, 2 to 6.
    models : tuple of str
        Catalogue garments the piles are drawn from (the library: one station model each).
    condition : str
        Simulated conditions of the looks (``+``-joined names).
    seed : int
    tolerance_mm : float
        A pick whose grasp point lies within this distance of the truth takes the garment.
    drag_probability : float
        Chance that a pick drags the garment under the picked one to another place.
    max_looks_per_garment : int
        Looks allowed per garment before a table counts as not cleared.
    hand_eye : {"calibrated", "true"}
    """

    tables: int = 10
    garments: int = 4
    models: tuple[str, ...] = tuple(f"No.{k}" for k in range(1, 13))
    condition: str = "paper"
    seed: int = 0
    tolerance_mm: float = 10.0
    drag_probability: float = 0.3
    max_looks_per_garment: int = 3
    hand_eye: str = "calibrated"
    layout: CellLayout = field(default_factory=CellLayout)
    pick: PickSettings = field(default_factory=PickSettings)

    def __post_init__(self) -> None:
        from photomodel.sim import MAX_TABLE_GARMENTS, MIN_TABLE_GARMENTS

        if self.tables < 1:
            raise ValueError(f"tables: expected a positive count, got {self.tables}")
        if not MIN_TABLE_GARMENTS <= self.garments <= MAX_TABLE_GARMENTS:
            raise ValueError(f"garments: expected {MIN_TABLE_GARMENTS} to {MAX_TABLE_GARMENTS} "
                             f"a table, got {self.garments}")
        if not self.models:
            raise ValueError("models: expected at least one catalogue garment")
        if len(self.models) > len(BOX_ROWS_Y_MM) * len(BOX_COLUMNS_X_MM):
            raise ValueError(f"models: at most {len(BOX_ROWS_Y_MM) * len(BOX_COLUMNS_X_MM)} "
                             f"(one box each), got {len(self.models)}")
        if not 0.0 <= self.drag_probability <= 1.0:
            raise ValueError("drag_probability: expected [0, 1]")

    def to_json_dict(self) -> dict[str, Any]:
        d = {k: v for k, v in self.__dict__.items() if k not in ("layout", "pick")}
        d["models"] = list(self.models)
        d["layout"] = asdict(self.layout)
        return d


def box_layouts(layout: CellLayout, models: tuple[str, ...]) -> dict[str, CellLayout]:
    """One box per model: ``layout`` with its box moved to the model's place (row by row of
    :data:`BOX_COLUMNS_X_MM` x :data:`BOX_ROWS_Y_MM`, in the order of ``models``)."""
    places = [(x, y) for y in BOX_ROWS_Y_MM for x in BOX_COLUMNS_X_MM]
    z = layout.box_centre_mm[2]
    return {m: replace(layout, box_centre_mm=(x, y, z))
            for m, (x, y) in zip(models, places, strict=False)}


@dataclass(frozen=True)
class ClearLook:
    """One look at a table as :func:`clear_table` saw and acted on it (kept on request).

    Attributes
    ----------
    table, look : int
        The table's index and the look's (0 first).
    right_bgr : ndarray of uint8, shape (H, W, 3)
        Camera 1's image of the table (BGR), as the look rendered it.
    found : TableResult
        :meth:`~photomodel.identify.Identifier.all`'s answer: every garment found (poses
        ``T_cam1_model`` in camera 1's frame, mm), and the pick order.
    models : dict of str to PhotoModel
        The photo-model of each found garment's model, by name (to draw their outlines).
    pick : dict or None
        The look's pick record (an entry of the table record's ``picks``: ``model``,
        ``score``, ``placed``, ``under``, ``reachable``, ``grasp_error_mm`` (mm), ...); None
        when nothing was found.
    placed : dict of str to int
        Garments in each model's box after this look (boxes still empty left out).
    remaining : int
        Garments left on the table after this look.
    """

    table: int
    look: int
    right_bgr: NDArray[np.uint8]
    found: TableResult
    models: dict[str, PhotoModel]
    pick: dict[str, Any] | None
    placed: dict[str, int]
    remaining: int


@dataclass(frozen=True)
class ClearReport:
    """Every table's record and the summary (JSON-ready); the cell's set-up and the looks of
    the table kept (:func:`run_clear`'s ``keep``), when asked for."""

    tables: list[dict[str, Any]]
    summary: dict[str, Any]
    setup: CellSetup | None = None
    kept: list[ClearLook] | None = None

    def to_json_dict(self) -> dict[str, Any]:
        return {"summary": self.summary, "tables": self.tables}


def _nudged(T: NDArray[np.float64], gen: np.random.Generator, shift_mm: tuple[float, float],
            turn_deg: float) -> NDArray[np.float64]:
    """``T`` (a garment on the table) pushed by a random shift and turn in the table plane."""
    from photomodel.sim import garment_placement

    angle = gen.uniform(0.0, 2.0 * np.pi)
    d = gen.uniform(*shift_mm)
    push = garment_placement(d * np.cos(angle), d * np.sin(angle),
                             float(gen.uniform(-turn_deg, turn_deg)))
    out = np.array(T, dtype=np.float64)
    out[:3, :3] = push[:3, :3] @ out[:3, :3]
    out[:3, 3] = push[:3, :3] @ out[:3, 3] + push[:3, 3]
    return out


def clear_table(config: ClearConfig, setup: CellSetup, identifier: Any, index: int,
                keep: list[ClearLook] | None = None) -> dict[str, Any]:
    """Clear table ``index`` (module docstring): its record.

    ``keep``: a list each look is appended to (:class:`ClearLook`), or None.
    """
    from photomodel.sim import (
        catalogue_garment,
        hand_table_pose,
        parse_conditions,
        random_table,
        scene_rng,
    )

    t0 = time.perf_counter()
    conditions = parse_conditions(config.condition)
    gen = scene_rng(config.seed, "table", index)
    T_cam1_table = hand_table_pose(setup.rig)
    table = random_table([catalogue_garment(m) for m in config.models], config.garments, gen,
                         conditions, rig=setup.rig, T_cam1_table=T_cam1_table)
    boxes = box_layouts(config.layout, config.models)
    T_base_hand = forward_kinematics(setup.arm, setup.q_photo)
    picks: list[dict[str, Any]] = []
    boxed: dict[str, int] = {}
    reason = "cleared"
    for look in range(config.max_looks_per_garment * config.garments):
        if not table.garments:
            break
        shot = table.render(setup.rig, T_cam1_table, conditions, gen)
        found = identifier.all(shot.right_bgr, shot.left_bgr, rng=scene_rng(
            config.seed, "table-look", index, look))
        first = found.first
        if first is None:
            reason = f"nothing found with {len(table.garments)} garment(s) left"
            if keep is not None:
                keep.append(_look(identifier, index, look, shot.right_bgr, found, None, boxed,
                                  len(table.garments)))
            break
        T_est = first.result.T_cam1_model
        truth = min(shot.garments, key=lambda g: float(np.linalg.norm(
            g.T_cam1_model[:3, 3] - T_est[:3, 3])))
        T_base_est = T_base_hand @ setup.T_hand_cam1 @ T_est
        T_base_true = T_base_hand @ setup.T_hand_cam1_true @ truth.T_cam1_model
        error = (grasp_pose(T_base_est, config.pick.grasp_point_mm)[:3, 3]
                 - grasp_pose(T_base_true, config.pick.grasp_point_mm)[:3, 3])
        record: dict[str, Any] = {
            "look": look, "model": first.model, "true_model": truth.model,
            "instance": truth.instance, "score": first.result.score,
            "visible_fraction": first.visible_fraction,
            "true_visible_fraction": truth.visible_fraction[0],
            "under": list(truth.covered_by), "found": len(found.garments),
            "on_table": len(shot.garments), "identify_seconds": found.seconds,
            "grasp_error_mm": float(np.linalg.norm(error)),
            "right_box": first.model == truth.model}
        try:
            plan = plan_pick(setup.arm, setup.q_photo, T_base_est, boxes[first.model],
                             config.pick, rng=scene_rng(config.seed, "table-ik", index, look))
            record.update(reachable=True, within_limits=bool(plan.within_limits))
        except UnreachableError as exc:
            record.update(reachable=False, within_limits=False, reason=str(exc))
        taken = (record["reachable"] and record["grasp_error_mm"] <= config.tolerance_mm
                 and not truth.covered_by)
        record["placed"] = bool(taken)
        picks.append(record)
        below = [g for g in shot.garments if truth.instance in g.covered_by]
        if taken:
            table = table.without(truth.instance)
        else:                                    # the grasp missed: the garment is pushed
            g = table.garment(truth.instance)
            table = table.moved(truth.instance, _nudged(g.T_table_garment, gen, (5.0, 20.0),
                                                        5.0))
        if below and gen.random() < config.drag_probability:
            dragged = below[int(gen.integers(len(below)))].instance
            g = table.garment(dragged)
            table = table.moved(dragged, _nudged(g.T_table_garment, gen, (10.0, 40.0), 10.0))
            record["dragged"] = dragged
        if taken:
            boxed[first.model] = boxed.get(first.model, 0) + 1
        if keep is not None:
            keep.append(_look(identifier, index, look, shot.right_bgr, found, record, boxed,
                              len(table.garments)))
    else:
        if table.garments:
            reason = f"{len(table.garments)} garment(s) left after {len(picks)} looks"
    placed = [p for p in picks if p["placed"]]
    return {"table": index, "garments": config.garments, "placed": len(placed),
            "cleared": not table.garments, "reason": reason, "looks": len(picks),
            "wrong_box": sum(1 for p in placed if not p["right_box"]),
            "picked_covered": sum(1 for p in picks if p["under"]),
            "grasp_error_mm": [p["grasp_error_mm"] for p in placed],
            "seconds": time.perf_counter() - t0, "picks": picks}


def _look(identifier: Any, table: int, look: int, right_bgr: NDArray[np.uint8],
          found: TableResult, record: dict[str, Any] | None, boxed: dict[str, int],
          remaining: int) -> ClearLook:
    """The look as kept: the found garments' photo-models from the identifier's prepared ones
    (every model of an in-memory library stays prepared)."""
    models = {}
    for g in found.garments:
        held = identifier.prepared.peek(g.model)
        if held is not None:
            models[g.model] = held.model
    return ClearLook(table, look, right_bgr, found, models, record, dict(boxed), remaining)


def run_clear(config: ClearConfig,
              progress: Callable[[int, int, str], None] | None = None,
              keep: int | None = None) -> ClearReport:
    """Clear ``config.tables`` tables; ``progress(done, total, what)`` after each one.

    ``keep``: the table whose looks are kept (:attr:`ClearReport.kept`, for
    :func:`~photomodel.cell.animate_clear`), or None.
    """
    from photomodel.cell._cell import CellConfig
    from photomodel.identify import Identifier

    t0 = time.perf_counter()
    setup = make_cell(CellConfig(seed=config.seed, condition=config.condition,
                                 hand_eye=config.hand_eye, layout=config.layout,
                                 pick=config.pick))
    identifier = Identifier([_photo_model(m, config.seed) for m in config.models], setup.rig)
    tables = []
    kept: list[ClearLook] | None = None
    for k in range(config.tables):
        looks: list[ClearLook] | None = [] if k == keep else None
        record = clear_table(config, setup, identifier, k, looks)
        if looks is not None:
            kept = looks
        tables.append(record)
        if progress is not None:
            progress(k + 1, config.tables, f"table {k}: {record['placed']} of "
                                           f"{record['garments']} placed ({record['reason']})")
    return ClearReport(tables, summarise_clear(config, tables, time.perf_counter() - t0),
                       setup, kept)


def summarise_clear(config: ClearConfig, tables: list[dict[str, Any]], seconds: float
                    ) -> dict[str, Any]:
    """Garments placed of all, wrong boxes, picks of a covered garment, grasp errors, time."""
    total = sum(t["garments"] for t in tables)
    placed = sum(t["placed"] for t in tables)
    errors = [e for t in tables for e in t["grasp_error_mm"]]
    return {"tables": len(tables), "cleared": sum(t["cleared"] for t in tables),
            "garments": total, "placed": placed, "placed_share": placed / max(total, 1),
            "wrong_box": sum(t["wrong_box"] for t in tables),
            "picked_covered": sum(t["picked_covered"] for t in tables),
            "looks": sum(t["looks"] for t in tables),
            "grasp_error_mm": _stats(errors),
            "seconds_per_garment": sum(t["seconds"] for t in tables) / max(placed, 1),
            "seconds": seconds, "config": config.to_json_dict()}
