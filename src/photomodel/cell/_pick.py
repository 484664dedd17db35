"""From a stereo pair and the arm's joints to a pick-and-place plan (what ``photomodel pick`` runs).
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from photomodel._files import write_atomic
from photomodel.camera import PinholeCamera, StereoRig
from photomodel.errors import InputError, PhotomodelError
from photomodel.locate import LocateResult, Locator, Method
from photomodel.model import PhotoModel
from photomodel.robot import (
    ArmModel,
    CellLayout,
    PickPlan,
    PickSettings,
    forward_kinematics,
    plan_pick,
)

__all__ = [
    "PickResult",
    "grasp_point_from_photo_px",
    "pick",
    "write_json_atomic",
]


def grasp_point_from_photo_px(model: PhotoModel, uv: ArrayLike) -> tuple[float, float]:
    """The model-frame point (x, y) mm of a pixel (u, v) of the model photo.

    Uses the model camera and distance stored in the model's metadata (as the build did: the
    pixel's ray met with the plane, minus the silhouette's centroid). The pixel must lie on the
    garment (inside the model's mask).
    """
    meta = model.meta
    try:
        camera = PinholeCamera(np.asarray(meta["camera_K"]), np.asarray(meta["camera_dist"]))
        distance = float(meta["distance_mm"])
        centroid = np.asarray(meta["centroid_in_camera_mm"][:2], dtype=np.float64)
    except (KeyError, TypeError, ValueError):
        raise InputError("--grasp-px", f"model {model.name!r} lacks its camera metadata; give "
                         "the grasp point in mm (--grasp-mm)") from None
    uv_arr = np.asarray(uv, dtype=np.float64).reshape(1, 2)
    u, v = (uv_arr[0] - model.crop_origin_px).round().astype(int)
    h, w = model.mask.shape
    if not (0 <= u < w and 0 <= v < h and model.mask[v, u]):
        raise InputError("--grasp-px", f"pixel ({uv_arr[0, 0]:.0f}, {uv_arr[0, 1]:.0f}) is not "
                         f"on the garment of model {model.name!r}")
    xy = camera.undistort_pixels(uv_arr)[0] * distance - centroid
    return float(xy[0]), float(xy[1])


@dataclass(frozen=True)
class PickResult:
    """A located garment and its plan."""

    located: LocateResult
    T_base_hand: NDArray[np.float64]
    T_hand_cam1: NDArray[np.float64]
    plan: PickPlan

    def to_json_dict(self) -> dict[str, Any]:
        return {"model": self.located.model, "locate": self.located.to_json_dict(),
                "T_base_hand": self.T_base_hand.tolist(),
                "T_hand_cam1": self.T_hand_cam1.tolist(),
                "T_base_model": self.plan.T_base_model.tolist(), **self.plan.to_json_dict()}


def pick(model: PhotoModel | Locator, rig: StereoRig, right_bgr: NDArray[np.uint8],
         left_bgr: NDArray[np.uint8], arm: ArmModel, q: ArrayLike,
         T_hand_cam1: NDArray[np.float64], *, layout: CellLayout | None = None,
         settings: PickSettings | None = None, rng: int = 0,
         method: Method = "default") -> PickResult:
    """Locate ``model`` in the stereo pair taken at joints ``q`` (n,) rad and plan its pick.

    ``model`` is a photo-model, or a :class:`~photomodel.Locator` of one for ``rig`` that a
    cell keeps from pick to pick (``method`` is then the Locator's).

    Raises
    ------
    PhotomodelError
        The garment is not found in the images.
    UnreachableError
        The plan cannot be executed within the joint limits.
    """
    q_arr = arm.check_joints(q, "--joints-deg")
    locator = model if isinstance(model, Locator) else Locator(model, rig, method=method)
    located = locator(right_bgr, left_bgr, rng=rng)
    if not located.found:
        raise PhotomodelError(f"{locator.model.name}: not found in the stereo pair (score "
                              f"{located.score:.2f}); nothing to pick")
    T_base_hand = forward_kinematics(arm, q_arr)
    T_base_model = T_base_hand @ T_hand_cam1 @ located.T_cam1_model
    plan = plan_pick(arm, q_arr, T_base_model, layout, settings, rng=rng)
    return PickResult(located, T_base_hand, np.asarray(T_hand_cam1, dtype=float), plan)


def write_json_atomic(path: str | os.PathLike[str], data: dict[str, Any]) -> Path:
    """Write ``data`` as indented JSON, atomically (:func:`~photomodel._files.write_atomic`)."""
    p = Path(path)
    if p.is_dir():
        raise InputError(p, "is a directory; give a file name")
    p.parent.mkdir(parents=True, exist_ok=True)
    write_atomic(p, (json.dumps(data, indent=1) + "\n").encode())
    return p
