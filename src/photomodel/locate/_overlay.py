"""Overlay picture: the found model outline drawn on both images side by side."""

from __future__ import annotations

import cv2
import numpy as np
from numpy.typing import NDArray

from photomodel.camera import StereoRig
from photomodel.image import draw_label
from photomodel.model import PhotoModel

__all__ = ["RANK_COLOURS_BGR", "draw_overlay", "draw_table_overlay"]


def draw_overlay(model: PhotoModel | None, rig: StereoRig, right_bgr: NDArray[np.uint8],
                 left_bgr: NDArray[np.uint8], A_cam1_model: NDArray[np.float64],
                 caption: str = "") -> NDArray[np.uint8]:
    """Left image | right image with the model outline, S_in points and axes at the pose.

    ``A_cam1_model`` maps model points into camera 1: a pose ``T_cam1_model``, or the
    strained map the search scored (:attr:`~photomodel.locate.LocateResult.A_cam1_model`).
    The left (camera 2) image is drawn on the left, as a person sees the scene. With no
    ``model`` (or a pose of NaN) only the pair and the caption are drawn.
    """
    none = np.zeros((0, 3))
    uv1, uv2 = rig.project_poses(A_cam1_model, none if model is None else model.outline_mm)
    in1, in2 = rig.project_poses(A_cam1_model, none if model is None else model.points_in_mm)
    axes = np.array([[0, 0, 0], [40, 0, 0], [0, 40, 0]], dtype=np.float64)
    ax1, ax2 = rig.project_poses(A_cam1_model, axes)
    panels = []
    for img, uv, pin, ax in ((left_bgr, uv2, in2, ax2), (right_bgr, uv1, in1, ax1)):
        out = img.copy()
        ok = np.isfinite(pin).all(axis=1)
        for u, v in np.rint(pin[ok]).astype(int)[::2]:
            cv2.circle(out, (int(u), int(v)), 1, (255, 255, 0), -1)
        if np.isfinite(uv).all():
            cv2.polylines(out, [np.rint(uv).astype(np.int32).reshape(-1, 1, 2)], True,
                          (0, 255, 255), 2, cv2.LINE_AA)
        if np.isfinite(ax).all():
            o, x, y = (tuple(int(c) for c in np.rint(p)) for p in ax)
            cv2.arrowedLine(out, o, x, (0, 0, 255), 2, cv2.LINE_AA)
            cv2.arrowedLine(out, o, y, (0, 200, 0), 2, cv2.LINE_AA)
        panels.append(out)
    return _sheet(panels, caption)


def _sheet(panels: list[NDArray[np.uint8]], caption: str) -> NDArray[np.uint8]:
    """Camera 2's panel | camera 1's panel, each named, and the caption in a bar below."""
    for panel, name in zip(panels, ("left (camera 2)", "right (camera 1)"), strict=True):
        _text(panel, name, (8, 20))
    h = max(p.shape[0] for p in panels)
    panels = [cv2.copyMakeBorder(p, 0, h - p.shape[0], 0, 0, cv2.BORDER_CONSTANT) for p in panels]
    sheet = np.concatenate([panels[0], np.zeros((h, 6, 3), np.uint8), panels[1]], axis=1)
    if caption:
        bar = np.zeros((28, sheet.shape[1], 3), np.uint8)
        _text(bar, caption, (8, 19))
        sheet = np.concatenate([sheet, bar], axis=0)
    return sheet


def _text(img: NDArray[np.uint8], text: str, org: tuple[int, int]) -> None:
    """White text on a dark outline, drawn once (:func:`~photomodel.image.draw_label`)."""
    draw_label(img, text, org)


RANK_COLOURS_BGR = ((0, 220, 0), (0, 255, 255), (255, 200, 0), (255, 0, 255), (0, 128, 255))
"""Outline colours by pick rank: the garment to pick first green, then yellow, cyan, ..."""


def draw_table_overlay(rig: StereoRig, right_bgr: NDArray[np.uint8],
                       left_bgr: NDArray[np.uint8],
                       garments: list[tuple[PhotoModel, NDArray[np.float64], str]],
                       caption: str = "") -> NDArray[np.uint8]:
    """Left image | right image with every found garment's outline and its label.

    ``garments``: (model, ``A_cam1_model`` (4, 4), label) in pick order (the first drawn
    green, on top of the others); each label (its pick rank, name and score, say) is written
    at the garment's model origin.
    """
    panels = [left_bgr.copy(), right_bgr.copy()]
    for k in reversed(range(len(garments))):
        model, A, label = garments[k]
        colour = RANK_COLOURS_BGR[min(k, len(RANK_COLOURS_BGR) - 1)]
        uv1, uv2 = rig.project_poses(A, model.outline_mm)
        o1, o2 = rig.project_poses(A, np.zeros((1, 3)))
        for panel, uv, origin in ((panels[0], uv2, o2), (panels[1], uv1, o1)):
            if np.isfinite(uv).all():
                cv2.polylines(panel, [np.rint(uv).astype(np.int32).reshape(-1, 1, 2)], True,
                              colour, 2, cv2.LINE_AA)
            if np.isfinite(origin).all():
                u, v = (int(c) for c in np.rint(origin[0]))
                _text(panel, label, (u - 4 * len(label), v))
    return _sheet(panels, caption)
