"""The arm's motion through a pick-and-place plan, drawn with matplotlib 3D (GIF or MP4).

The arm is drawn as the polyline through its DH frame origins (base, shoulder, elbow, wrist,
flange) plus the gripper to the TCP; the work table, the 220 x 220 mm box and the garment's
outline (carried by the gripper between ``grasp`` and ``place``). GIFs are written with
matplotlib's ``PillowWriter``; MP4 needs ``ffmpeg`` on the PATH.
"""

from __future__ import annotations

import os
import shutil
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from photomodel._files import write_atomic_with
from photomodel.errors import InputError
from photomodel.geometry import invert_transform, transform_points
from photomodel.robot._arm import ArmModel
from photomodel.robot._kinematics import joint_frames
from photomodel.robot._plan import CellLayout, Gripper, PickPlan

__all__ = [
    "ANIMATION_SUFFIXES",
    "animate_plan",
    "check_animation_path",
    "draw_workspace",
    "save_animation",
]

ANIMATION_SUFFIXES = (".gif", ".mp4")


def check_animation_path(path: str | os.PathLike[str]) -> Path:
    """The output path, or :class:`InputError` for an unknown type or MP4 without ffmpeg."""
    p = Path(path)
    suffix = p.suffix.lower()
    if suffix not in ANIMATION_SUFFIXES:
        raise InputError(p, f"unknown animation type; use one of {ANIMATION_SUFFIXES}")
    if suffix == ".mp4" and shutil.which("ffmpeg") is None:
        raise InputError(p, "writing MP4 needs ffmpeg on the PATH, which is missing; "
                         "write a .gif instead")
    if p.is_dir():
        raise InputError(p, "is a directory; give a file name")
    return p


def _densify(path_q: NDArray[np.float64], frames_per_move: int) -> tuple[NDArray[np.float64],
                                                                         NDArray[np.int64]]:
    """Joint-space interpolation between consecutive rows; returns (q (M, n), segment (M,))."""
    qs, segs = [path_q[:1]], [np.zeros(1, dtype=np.int64)]
    for k in range(len(path_q) - 1):
        step = np.max(np.abs(path_q[k + 1] - path_q[k]))
        n = int(np.clip(np.ceil(step / np.radians(6.0)), 1, frames_per_move))
        s = np.linspace(0.0, 1.0, n + 1)[1:, None]
        qs.append((1 - s) * path_q[k] + s * path_q[k + 1])
        segs.append(np.full(n, k + 1, dtype=np.int64))
    return np.concatenate(qs), np.concatenate(segs)


def animate_plan(
    arm: ArmModel,
    plan: PickPlan,
    out: str | os.PathLike[str],
    *,
    layout: CellLayout | None = None,
    gripper: Gripper | None = None,
    outline_model_mm: NDArray[np.float64] | None = None,
    fps: int = 12,
    frames_per_move: int = 12,
    dpi: int = 90,
    title: str = "",
) -> Path:
    """Render the plan's motion to ``out`` (.gif or .mp4), atomically.

    Parameters
    ----------
    arm : ArmModel
    plan : PickPlan
    out : path-like
    layout : CellLayout, optional
        Table and box to draw.
    gripper : Gripper, optional
        TCP offset (must match the plan's).
    outline_model_mm : ndarray (K, 3), optional
        The garment's outline in the model frame (e.g. ``PhotoModel.outline_mm``).
    fps, frames_per_move, dpi : int
        Frame rate, most frames per joint move, resolution.
    title : str

    Returns
    -------
    Path
        The written file.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.animation import FuncAnimation

    p = check_animation_path(out)
    layout = layout or CellLayout()
    T_hand_tcp = (gripper or Gripper()).T_hand_tcp
    q_all, seg = _densify(plan.path_q, frames_per_move)
    frames = joint_frames(arm, q_all)  # (M, n + 1, 4, 4)
    T_tcp = frames[:, -1] @ T_hand_tcp
    names = [w.name for w in plan.waypoints]
    rows = list(plan.waypoint_rows)
    grasp_row, place_row = rows[names.index("grasp")], rows[names.index("place")]
    T_tcp_model = invert_transform(plan.waypoint("grasp").T_base_tcp) @ plan.T_base_model
    T_model_placed = plan.waypoint("place").T_base_tcp @ T_tcp_model
    if outline_model_mm is None:
        outline_model_mm = np.zeros((0, 3))
    outline = outline_model_mm[:: max(1, len(outline_model_mm) // 120)]

    fig = plt.figure(figsize=(5.6, 4.6))
    ax = fig.add_subplot(projection="3d")
    draw_workspace(ax, layout)
    (arm_line,) = ax.plot([], [], [], "-o", color="tab:blue", lw=3, ms=3)
    (tool_line,) = ax.plot([], [], [], "-", color="tab:red", lw=2)
    (cloth,) = ax.plot([], [], [], "-", color="tab:green", lw=1.5)
    tcp_track = T_tcp[:, :3, 3]
    ax.plot(tcp_track[:, 0], tcp_track[:, 1], tcp_track[:, 2], ":", color="0.6", lw=0.8)
    text = ax.text2D(0.02, 0.95, "", transform=ax.transAxes, fontsize=8)
    fig.suptitle(title or f"{arm.name}: pick and place", fontsize=9)

    def draw(k: int) -> tuple[object, ...]:
        origins = frames[k, :, :3, 3]
        arm_line.set_data_3d(origins[:, 0], origins[:, 1], origins[:, 2])
        tip = T_tcp[k, :3, 3]
        tool_line.set_data_3d([origins[-1, 0], tip[0]], [origins[-1, 1], tip[1]],
                              [origins[-1, 2], tip[2]])
        if len(outline):
            if seg[k] > place_row:
                T_model = T_model_placed
            elif seg[k] > grasp_row:
                T_model = T_tcp[k] @ T_tcp_model
            else:
                T_model = plan.T_base_model
            pts = transform_points(T_model, outline)
            cloth.set_data_3d(pts[:, 0], pts[:, 1], pts[:, 2])
        stage = next((n for n, r in zip(names, rows, strict=True) if r >= seg[k]), names[-1])
        text.set_text(f"to {stage}")
        return arm_line, tool_line, cloth, text

    anim = FuncAnimation(fig, draw, frames=len(q_all), blit=False)
    return save_animation(anim, fig, p, fps, dpi)


def draw_workspace(ax: Any, layout: CellLayout) -> None:
    """Draw the work table's outline and the box on a matplotlib 3D axes (base frame, mm),
    and set the axes' limits, labels and view as :func:`animate_plan` does."""
    tx, ty, tz = layout.table_centre_mm
    hx, hy = layout.table_size_mm[0] / 2, layout.table_size_mm[1] / 2
    ax.plot([tx - hx, tx + hx, tx + hx, tx - hx, tx - hx],
            [ty - hy, ty - hy, ty + hy, ty + hy, ty - hy], [tz] * 5, color="0.5", lw=1)
    b = layout.box_size_mm / 2
    rim = np.array([[-b, -b, 0], [b, -b, 0], [b, b, 0], [-b, b, 0], [-b, -b, 0]], float)
    T_box = layout.T_base_box
    for h in (0.0, layout.box_depth_mm):
        pts = transform_points(T_box, rim + [0.0, 0.0, h])
        ax.plot(pts[:, 0], pts[:, 1], pts[:, 2], color="saddlebrown", lw=1)
    for corner in rim[:4]:
        pts = transform_points(T_box, np.array([corner, corner + [0.0, 0.0, layout.box_depth_mm]]))
        ax.plot(pts[:, 0], pts[:, 1], pts[:, 2], color="saddlebrown", lw=1)
    ax.set_xlim(-300, 1000)
    ax.set_ylim(-800, 500)
    ax.set_zlim(0, 1300)
    ax.set_xlabel("x mm")
    ax.set_ylabel("y mm")
    ax.set_zlabel("z mm")
    ax.view_init(elev=24, azim=-60)


def save_animation(anim: Any, fig: Any, out: Path, fps: int, dpi: int) -> Path:
    """Write a matplotlib animation to ``out`` (.gif or .mp4) through a temporary file, and
    close the figure."""
    import matplotlib.pyplot as plt
    from matplotlib.animation import FFMpegWriter, PillowWriter

    out.parent.mkdir(parents=True, exist_ok=True)
    writer = PillowWriter(fps=fps) if out.suffix.lower() == ".gif" else FFMpegWriter(fps=fps)
    try:
        write_atomic_with(out, lambda tmp: anim.save(str(tmp), writer=writer, dpi=dpi))
    finally:
        plt.close(fig)
    return out
