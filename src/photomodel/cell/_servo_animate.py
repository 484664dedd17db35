"""A servoed pick drawn frame by frame: the arm over the belt, and what camera 1 sees.

Left, matplotlib 3D in the base frame: the arm (DH frame origins, gripper to the TCP), the work
table and the box, the garment's true outline where the belt has carried it (green) and the
outline the command aims at (orange, dashed), the TCP's path so far. Right: camera 1's frame
with the tracker's outline (the model's outline projected at the tracked pose; none in a
frame tracked as lost or not looked at). One animation frame per control tick.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from photomodel.camera import StereoRig
from photomodel.cell._servo import ServoOutcome
from photomodel.geometry import transform_points
from photomodel.robot import (
    ArmModel,
    CellLayout,
    Gripper,
    check_animation_path,
    draw_workspace,
    joint_frames,
    save_animation,
)

__all__ = ["animate_servo"]


def animate_servo(arm: ArmModel, rig: StereoRig, outcome: ServoOutcome,
                  out: str | os.PathLike[str], *, layout: CellLayout | None = None,
                  gripper: Gripper | None = None, step: int = 2, fps: int = 8,
                  dpi: int = 64, title: str = "") -> Path:
    """Render a servoed order's ticks (:class:`ServoOutcome` with ticks kept) to ``out``.

    Parameters
    ----------
    arm : ArmModel
    rig : StereoRig
        The hand rig (camera 1 projects the tracked outline).
    outcome : ServoOutcome
        An order run with ``keep_ticks=True``.
    out : path-like
        A .gif (or .mp4 with ffmpeg), written atomically.
    layout, gripper : optional
        Table and box to draw; the TCP offset.
    step : int
        Draw every ``step``-th tick.
    fps, dpi : int
    title : str

    Returns
    -------
    Path
    """
    from matplotlib.animation import FuncAnimation

    p = check_animation_path(out)
    ticks = outcome.ticks
    if not ticks or outcome.model is None:
        raise ValueError("outcome: no ticks kept (run the order with keep_ticks=True)")
    layout = layout or CellLayout()
    T_hand_tcp = (gripper or Gripper()).T_hand_tcp
    frames = joint_frames(arm, np.stack([t.q for t in ticks]))
    tcp = (frames[:, -1] @ T_hand_tcp)[:, :3, 3]
    outline = outcome.model.outline_mm
    outline = outline[:: max(1, len(outline) // 120)]
    shape = next((t.image.shape for t in ticks if t.image is not None), (rig.cam1.height_px,
                                                                         rig.cam1.width_px, 3))

    fig, art = _figure(layout, shape, title)
    arm_line, tool_line, cloth, aim, path, text, shown, tracked, caption = art

    def draw(k: int) -> tuple[object, ...]:
        tick = ticks[k]
        origins = frames[k, :, :3, 3]
        arm_line.set_data_3d(origins[:, 0], origins[:, 1], origins[:, 2])
        tool_line.set_data_3d(*np.column_stack([origins[-1], tcp[k]]))
        for line, T in ((cloth, tick.T_base_model_true), (aim, tick.T_base_model_aim)):
            pts = transform_points(T, outline)
            line.set_data_3d(pts[:, 0], pts[:, 1], pts[:, 2])
        path.set_data_3d(tcp[: k + 1, 0], tcp[: k + 1, 1], tcp[: k + 1, 2])
        text.set_text(f"t = {tick.t_s:.2f} s  {tick.phase}")
        if tick.image is not None:
            shown.set_data(tick.image[..., ::-1])
        uv = _tracked_outline(rig, tick.T_cam1_model, outline)
        tracked.set_data(uv[:, 0], uv[:, 1])
        look = "blind, finishing on the prediction" if tick.mode is None else tick.mode
        caption.set_text(f"camera 1: {look}"
                         + (f", {tick.visible:.0%} in view" if np.isfinite(tick.visible) else ""))
        return arm_line, tool_line, cloth, aim, path, text, shown, tracked, caption

    shown_ticks = [*range(0, len(ticks), max(1, step))]
    if shown_ticks[-1] != len(ticks) - 1:
        shown_ticks.append(len(ticks) - 1)
    anim = FuncAnimation(fig, draw, frames=shown_ticks, blit=False)
    return save_animation(anim, fig, p, fps, dpi)


def _figure(layout: CellLayout, shape: tuple[int, ...], title: str
            ) -> tuple[Any, tuple[Any, ...]]:
    """The figure (the cell in 3D left, camera 1 right) and its artists: arm, tool, garment,
    aim, TCP path, 3D caption, image, tracked outline, image caption."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig = plt.figure(figsize=(9.6, 4.2))
    ax = fig.add_subplot(1, 2, 1, projection="3d")
    draw_workspace(ax, layout)
    ax.set_xlim(0, 1000)
    ax.set_ylim(-750, 250)
    ax.set_zlim(0, 800)
    ax.view_init(elev=22, azim=-35)
    (arm_line,) = ax.plot([], [], [], "-o", color="tab:blue", lw=3, ms=3)
    (tool_line,) = ax.plot([], [], [], "-", color="tab:red", lw=2)
    (cloth,) = ax.plot([], [], [], "-", color="tab:green", lw=1.5, label="garment (truth)")
    (aim,) = ax.plot([], [], [], "--", color="tab:orange", lw=1.2, label="aimed at")
    (path,) = ax.plot([], [], [], ":", color="0.4", lw=0.8)
    ax.legend(loc="upper right", fontsize=7)
    text = ax.text2D(0.02, 0.95, "", transform=ax.transAxes, fontsize=8)
    img_ax = fig.add_subplot(1, 2, 2)
    img_ax.set_axis_off()
    shown = img_ax.imshow(np.zeros(shape, np.uint8))
    (tracked,) = img_ax.plot([], [], "-", color="lime", lw=1.2)
    caption = img_ax.set_title("camera 1", fontsize=8)
    fig.suptitle(title or "servoed pick on a moving conveyor", fontsize=9)
    fig.tight_layout()
    return fig, (arm_line, tool_line, cloth, aim, path, text, shown, tracked, caption)


def _tracked_outline(rig: StereoRig, T_cam1_model: NDArray[np.float64] | None,
                     outline: NDArray[np.float64]) -> NDArray[np.float64]:
    """Pixels (K, 2) of the model outline at the tracked pose; empty without one."""
    if T_cam1_model is None:
        return np.zeros((0, 2))
    pts = transform_points(T_cam1_model, outline)
    uv = rig.cam1.project(pts[pts[:, 2] > 1.0])
    return np.vstack([uv, uv[:1]]) if len(uv) else uv
