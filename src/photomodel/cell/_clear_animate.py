"""A table cleared look by look, drawn frame by frame: what camera 1 saw, and where it went.

Left: camera 1's image of each look with every garment found outlined and labelled with its
pick rank, model and score (:func:`~photomodel.locate.draw_table_overlay`), the garment to pick
first green, and below it the same in words. Right: what the pick did ("look k: pick No.X
(score s) -> box No.X", or why nothing was placed) over the cell seen from above in the base
frame (x forward, y to the left): the arm's base, the work table and one box per model, each
with the garments placed in it so far; the box just filled highlighted, an arrow from the table
to it. One picture per look, shown for two frames (a GIF stores it once).
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from photomodel.camera import StereoRig
from photomodel.cell._clear import ClearConfig, ClearLook, box_layouts
from photomodel.geometry import transform_points
from photomodel.robot import CellLayout, check_animation_path, save_animation

__all__ = ["animate_clear"]

_CAMERA_IN = 6.0
"""Height of camera 1's panel, inches (at ``dpi`` 64, 384 px: a 480-row image at 0.8)."""
_MAP_MM = ((-800.0, 800.0), (-800.0, 1000.0))
"""The map's extent: base y (drawn left to right from +y), base x (bottom to top), mm."""


def animate_clear(looks: Sequence[ClearLook], out: str | os.PathLike[str], *, rig: StereoRig,
                  models: Sequence[str] | None = None, layout: CellLayout | None = None,
                  fps: int = 2, dpi: int = 64, title: str = "") -> Path:
    """Render a table's looks (:attr:`ClearReport.kept`) to ``out``, one picture per look.

    Each look's picture: left, what camera 1 saw, every garment found outlined and labelled
    with its pick rank, model and score (the one picked first green), the same list in words
    below; right, what the pick did ("look k: pick No.X (score s) -> box No.X", or why nothing
    was placed: covered, missed grasp, out of reach, nothing found) over a map of the cell
    seen from above, the box just filled highlighted and the count of each box after the
    look. Each picture lasts two frames, the last four.

    Parameters
    ----------
    looks : sequence of ClearLook
        One table's looks in order (:func:`run_clear` with ``keep``): camera 1's image
        (H, W, 3) uint8 BGR, the :class:`~photomodel.identify.TableResult` (poses
        ``T_cam1_model`` (4, 4) in camera 1's frame, mm), the pick record and the boxes'
        counts after it.
    out : path-like
        A .gif (or .mp4 with ffmpeg), written atomically (:func:`~photomodel.robot.
        check_animation_path`).
    rig : StereoRig
        The hand rig the looks were taken with (camera 1 projects the outlines).
    models : sequence of str, optional
        The cell's models, one box each in this order (:func:`box_layouts`); default
        :class:`ClearConfig`'s (the catalogue's No.1 to No.12).
    layout : CellLayout, optional
        The table (centre and size, base frame, mm) and the first box's place (default
        :class:`~photomodel.robot.CellLayout`).
    fps, dpi : int
        Frames per second (two a look); dots per inch (at 64 a frame is about 930 x 500 px,
        camera 1's image drawn at 0.8).
    title : str
        Above both panels (default names the table).

    Returns
    -------
    Path
        ``out``.
    """
    from matplotlib.animation import FuncAnimation

    p = check_animation_path(out)
    if not looks:
        raise ValueError("looks: none kept (run the table with keep=...)")
    layout = layout or CellLayout()
    names = tuple(models) if models is not None else ClearConfig.__dataclass_fields__[
        "models"].default
    boxes = box_layouts(layout, names)
    images = [_camera_panel(rig, look) for look in looks]
    fig, art = _figure(layout, boxes, images[0].shape, title or f"clearing table "
                       f"{looks[0].table}: look, pick the garment to pick first, place it "
                       "into its model's box")
    shown, heading, legend, caption, squares, counts, arrow = art
    # each picture twice (identical frames cost a GIF nothing), the last four times
    frames = [k for k in range(len(looks)) for _ in range(2)] + [len(looks) - 1] * 2

    def draw(k: int) -> tuple[object, ...]:
        look = looks[k]
        shown.set_data(images[k])
        heading.set_text(f"camera 1, look {look.look + 1}: {len(look.found.garments)} "
                         "garment(s) found")
        legend.set_text(_legend(look))
        caption.set_text(_caption(look))
        placed = look.placed
        filled = _filled(look)
        for name, square in squares.items():
            n = placed.get(name, 0)
            hot = name == filled
            square.set_facecolor("gold" if hot else ("wheat" if n else "white"))
            square.set_linewidth(2.5 if hot else 1.0)
            square.set_edgecolor("tab:red" if hot else "saddlebrown")
            counts[name].set_text(f"{name}\n{n}" if n else name)
            counts[name].set_fontweight("bold" if hot else "normal")
        if filled is not None and filled in boxes:
            x, y = boxes[filled].box_centre_mm[:2]
            tx, ty = layout.table_centre_mm[:2]
            arrow.set_positions((ty, tx), (y, x))
            arrow.set_visible(True)
        else:
            arrow.set_visible(False)
        return shown, heading, legend, caption, arrow, *squares.values(), *counts.values()

    anim = FuncAnimation(fig, draw, frames=frames, blit=False)
    return save_animation(anim, fig, p, fps, dpi)


def _camera_panel(rig: StereoRig, look: ClearLook) -> NDArray[np.uint8]:
    """Camera 1's image (H, W, 3) RGB with every found garment outlined and labelled."""
    from photomodel.locate import draw_table_overlay

    right = look.right_bgr
    drawn = []
    for g in (look.found.garments[i] for i in look.found.pick_order):
        model = look.models.get(g.model)
        if model is not None:
            drawn.append((model, g.result.A_cam1_model,
                          f"{g.pick_rank + 1}: {g.model} {g.result.score:.2f}"))
    # camera 2's panel is not shown: a blank stands in, and the sheet is cut after it
    sheet = draw_table_overlay(rig, right, np.zeros_like(right), drawn)
    return np.ascontiguousarray(sheet[: right.shape[0], -right.shape[1]:, ::-1])


def _legend(look: ClearLook) -> str:
    """The found garments in pick order, four a line: rank: model (score)."""
    found = look.found
    items = [f"{found.garments[i].pick_rank + 1}: {found.garments[i].model} "
             f"({found.garments[i].result.score:.2f})" for i in found.pick_order]
    lines = ["    ".join(items[k:k + 4]) for k in range(0, len(items), 4)] or ["none"]
    return "in pick order:  " + "\n".join(lines)


def _filled(look: ClearLook) -> str | None:
    """The box the look's pick filled, or None."""
    return look.pick["model"] if look.pick is not None and look.pick["placed"] else None


def _caption(look: ClearLook) -> str:
    """Two lines: the pick the look chose, then what it did."""
    k = look.look + 1
    pick = look.pick
    if pick is None:
        return f"look {k}: nothing found\n{look.remaining} garment(s) left on the table"
    head = f"look {k}: pick {pick['model']} (score {pick['score']:.2f})"
    if pick["placed"]:
        text = f"-> box {pick['model']}"
        if not pick["right_box"]:
            text += f" (wrong box: it is {pick['true_model']})"
    elif not pick["reachable"]:
        text = "out of reach: nothing placed"
    elif pick["under"]:
        text = "covered: nothing placed"
    else:
        text = f"missed grasp ({pick['grasp_error_mm']:.0f} mm off): nothing placed"
    if "dragged" in pick:
        text += ", dragging the one under it"
    if look.remaining == 0:
        text += ", table cleared"
    return f"{head}\n{text}"


def _figure(layout: CellLayout, boxes: dict[str, CellLayout], shape: tuple[int, ...],
            title: str) -> tuple[Any, tuple[Any, ...]]:
    """The figure (camera 1 left, the map right) and its artists: image, its heading, the
    caption, the boxes' squares and labels by model, the arrow to the box filled."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import FancyArrowPatch, Polygon, Rectangle

    (y0, y1), (x0, x1) = _MAP_MM
    cam_w = _CAMERA_IN * shape[1] / shape[0]
    map_h = _CAMERA_IN
    map_w = map_h * (y1 - y0) / (x1 - x0)
    left, gap, right, bottom, top = 0.15, 0.95, 0.15, 0.8, 1.05
    fig_w, fig_h = left + cam_w + gap + map_w + right, bottom + _CAMERA_IN + top
    fig = plt.figure(figsize=(fig_w, fig_h))
    img_ax = fig.add_axes((left / fig_w, bottom / fig_h, cam_w / fig_w, _CAMERA_IN / fig_h))
    img_ax.set_axis_off()
    shown = img_ax.imshow(np.zeros(shape, np.uint8))
    heading = img_ax.set_title("camera 1", fontsize=12)
    ax = fig.add_axes(((left + cam_w + gap) / fig_w, bottom / fig_h, map_w / fig_w,
                       map_h / fig_h))
    ax.set_xlim(y1, y0)                              # +y to the left, seen from above
    ax.set_ylim(x0, x1)
    ax.set_aspect("equal")
    ax.set_xlabel("base y, mm", fontsize=10)
    ax.set_ylabel("base x, mm", fontsize=10)
    ax.tick_params(labelsize=9)
    caption = ax.set_title("\n", fontsize=12, loc="left")
    tx, ty = layout.table_centre_mm[:2]
    hx, hy = layout.table_size_mm[0] / 2, layout.table_size_mm[1] / 2
    ax.add_patch(Rectangle((ty - hy, tx - hx), 2 * hy, 2 * hx, facecolor="0.85",
                           edgecolor="0.4"))
    ax.text(ty, tx + hx - 40, "table", ha="center", va="top", fontsize=11, color="0.25")
    ax.plot([0.0], [0.0], "o", color="0.3", ms=12)
    ax.text(0.0, -110.0, "arm", ha="center", va="top", fontsize=10, color="0.3")
    b = layout.box_size_mm / 2
    rim = np.array([[-b, -b, 0], [b, -b, 0], [b, b, 0], [-b, b, 0]], float)
    ax.text(0.99, 0.005, "seen from above", transform=ax.transAxes, ha="right",
            va="bottom", fontsize=9, color="0.4")
    squares, counts = {}, {}
    for name, box in boxes.items():
        pts = transform_points(box.T_base_box, rim)
        squares[name] = ax.add_patch(Polygon(pts[:, [1, 0]], closed=True, facecolor="white",
                                             edgecolor="saddlebrown"))
        x, y = box.box_centre_mm[:2]
        counts[name] = ax.text(y, x, name, ha="center", va="center", fontsize=9,
                               linespacing=1.1)
    arrow = ax.add_patch(FancyArrowPatch((ty, tx), (ty, tx), arrowstyle="-|>",
                                         mutation_scale=18, color="tab:red", lw=2,
                                         shrinkA=0, shrinkB=14))
    arrow.set_visible(False)
    legend = fig.text(left / fig_w, (bottom - 0.1) / fig_h, "", ha="left", va="top",
                      fontsize=12, linespacing=1.3)
    fig.suptitle(title, fontsize=12, y=1 - 0.1 / fig_h, va="top")
    return fig, (shown, heading, legend, caption, squares, counts, arrow)
