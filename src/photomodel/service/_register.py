"""Registering a garment where it lies: the service builds a photo-model from the hand
cameras' stereo pair (uploaded, or grabbed from its camera source) with
:func:`~photomodel.model.build_in_place`, adds it to the library and answers where it lies."""

from __future__ import annotations

import warnings
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from photomodel.geometry import quat_wxyz_from_matrix
from photomodel.image import decode_color_image
from photomodel.library import check_model_name
from photomodel.model import build_in_place

if TYPE_CHECKING:
    from photomodel.service._cell import CellService

__all__ = ["register_from_camera", "register_in_place"]

Image = bytes | NDArray[np.uint8]


def _image(value: Image | None, field: str) -> NDArray[np.uint8] | None:
    if value is None or isinstance(value, np.ndarray):
        return value
    return decode_color_image(value, field)


def register_in_place(cell: CellService, name: str, right: Image, left: Image,
                      empty_right: Image | None = None, empty_left: Image | None = None, *,
                      replace: bool = False) -> dict[str, Any]:
    """Build a model of the garment in the pair where it lies, add it to ``cell``'s library.

    Parameters
    ----------
    cell : CellService
    name : str
    right, left : bytes or ndarray (H, W, 3) uint8
        Camera 1's and camera 2's view (image files or decoded images).
    empty_right, empty_left : bytes or ndarray, optional
        The same views of the empty table (both or neither).
    replace : bool

    Returns
    -------
    dict
        ``/models``' summary of the new model plus ``in_place`` (``mm_per_px``,
        ``plane_distance_mm``, ``plane_rms_mm``, ``plane_points``, ``empty_pair``) and where
        it lies: ``T_cam1_model``, ``position_mm``, ``quat_wxyz`` (camera 1, mm).
    """
    from photomodel.service._cell import _summary, _taken

    check_model_name(name, "name")
    if name in cell.identifier.entries and not replace:
        raise _taken(name)
    views = [_image(v, f) for v, f in ((right, "right"), (left, "left"),
                                         (empty_right, "empty_right"),
                                         (empty_left, "empty_left"))]
    with warnings.catch_warnings():           # the table is no green plane: reported below
        warnings.simplefilter("ignore")
        made = build_in_place(cell.rig, views[0], views[1],  # type: ignore[arg-type]
                              empty_right_bgr=views[2], empty_left_bgr=views[3], name=name,
                              sources=("right", "left", "empty_right", "empty_left"))
    entry = cell.adopt(made.built.model, replace=replace)
    T = made.T_cam1_model
    quality = made.built.quality
    return {**_summary(entry),
            "in_place": {"mm_per_px": made.mm_per_px,
                         "plane_distance_mm": made.plane.distance_mm,
                         "plane_rms_mm": made.plane.rms_mm,
                         "plane_points": made.plane.points,
                         "plane_colour_share": None if quality is None
                         else quality.plane_colour_share,
                         "empty_pair": views[2] is not None},
            "T_cam1_model": T.tolist(), "position_mm": T[:3, 3].tolist(),
            "quat_wxyz": quat_wxyz_from_matrix(T[:3, :3]).tolist()}


def register_from_camera(cell: CellService, name: str, *, replace: bool = False
                         ) -> dict[str, Any]:
    """:func:`register_in_place` on a fresh pair from ``cell``'s camera source (the garment
    told from the table's colour), plus the frame's fields (``frame_t_s``, ``frame_index``,
    ``source``, ...)."""
    from photomodel.service._cell import _taken

    check_model_name(name, "name")
    if name in cell.identifier.entries and not replace:     # before grabbing
        raise _taken(name)
    grab, frame = cell._grabbed()
    return {**register_in_place(cell, name, grab.right_bgr, grab.left_bgr, replace=replace),
            **frame}
