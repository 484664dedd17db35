"""Registering a garment where it lies: the service builds a photo-model from the hand
cameras' stereo pair (uploaded, or grabbed from its camera source) with
:func:`~photomodel.model.build_in_place`, adds it to the library and answers where it lies."""

from __future__ import annotations

import warnings
from functools import partial
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
        ``plane_distance_mm``, ``plane_rms_mm``, ``plane_points``, ``empty_pair``), where it
        lies: ``T_cam1_model``, ``position_mm``, ``quat_wxyz`` (camera 1, mm), ``found``
        (true), ``model`` (its name) and ``id``, a result whose overlay shows it.
    """
    from photomodel.service._cell import _pair_png, _summary, _taken

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
    answer = {**_summary(entry),
            "in_place": {"mm_per_px": made.mm_per_px,
                         "plane_distance_mm": made.plane.distance_mm,
                         "plane_rms_mm": made.plane.rms_mm,
                         "plane_points": made.plane.points,
                         "plane_colour_share": None if quality is None
                         else quality.plane_colour_share,
                         "empty_pair": views[2] is not None},
            "T_cam1_model": T.tolist(), "position_mm": T[:3, 3].tolist(),
            "quat_wxyz": quat_wxyz_from_matrix(T[:3, :3]).tolist(), "found": True,
            "model": name}
    caption = f"registered {name} in place ({made.mm_per_px:.2f} mm/px)"
    cell.results.add("register", answer, partial(_pair_png, views[0], views[1], caption,
                                                 made.built.model, T, cell.rig))
    return answer


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


def set_scale(cell: CellService, name: str, *, factor: float | None = None,
              result_id: str | None = None) -> dict[str, Any]:
    """Store model ``name`` (of unknown scale) at a measured scale: ``factor`` (real mm per
    nominal mm), or the ``scale`` of locate result ``result_id`` of that model, found. The
    model is sampled anew at that scale (:func:`~photomodel.model.resampled_model`) and
    replaces the library's; the answer is its ``/models`` summary plus ``scale``."""
    from photomodel.errors import InputError
    from photomodel.model import at_scale, confirmed_scale
    from photomodel.service._cell import NotFound, _summary

    if (factor is None) == (result_id is None):
        raise InputError("factor", "give the scale as factor=F or the locate result it was "
                                   "measured in as result=ID (one of them)")
    if name not in cell.identifier.entries:
        raise NotFound("model", f"no model named {name!r}")
    source = f"factor {factor}"
    if result_id is not None:
        found = cell.results.get(result_id)
        if found is None:
            raise NotFound("result", f"no result {result_id!r} (only the last "
                                     f"{cell.results.size} are kept)")
        try:
            factor = confirmed_scale(found.answer, name)
        except ValueError as exc:
            raise InputError("result", f"result {result_id!r} {exc}") from None
        source = f"locate result {result_id}"
    assert factor is not None
    model = cell.library.load_entry(cell.identifier.entries[name])
    try:
        scaled = at_scale(model, factor, source)
    except ValueError as exc:
        field, _, text = str(exc).partition(": ")
        raise InputError(field, f"model {name!r} {text}" if field == "name" else text) from None
    return {**_summary(cell.adopt(scaled, replace=True, action="set-scale")), "scale": factor}
