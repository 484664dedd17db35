"""The photo-model: sampled garment points with colour, and the file that holds it.

File format (``.npz``, no pickle, ``FORMAT_VERSION`` in its metadata):

========================  ==========  =====================================================
array                     shape       meaning
========================  ==========  =====================================================
``points_in_mm``          (N, 3)      S_in: points inside the garment, model frame, mm
``hsv_in``                (N, 3)      their colour: hue deg [0, 360), saturation, value [0, 1]
``points_out_mm``         (M, 3)      S_out: points of the band enveloping the outline, mm
``outline_mm``            (K, 3)      the silhouette's outer contour, model frame, mm
``photo_bgr``             (h, w, 3)   crop of the model photo around the garment (uint8)
``mask``                  (h, w)      the garment mask in that crop (uint8, 0/1)
``crop_origin_px``        (2,)        photo pixel (u, v) of the crop's top-left pixel
``meta``                  ()          JSON string: name, version, camera, settings, size, date
========================  ==========  =====================================================

Model frame (docs/contracts.md): origin at the area centroid of the silhouette on the garment plane,
x along the model photo's columns, y along its rows, z along the model camera's viewing
direction (into the plane); the garment is flat, so every point has z = 0.
"""

from __future__ import annotations

import json
import os
import zipfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from photomodel.errors import InputError

__all__ = ["FORMAT_VERSION", "PhotoModel", "load_model", "save_model"]

FORMAT_VERSION = 1
_FORMAT_NAME = "photomodel"
_ARRAYS = ("points_in_mm", "hsv_in", "points_out_mm", "outline_mm", "photo_bgr", "mask",
           "crop_origin_px")


@dataclass(frozen=True)
class PhotoModel:
    """A garment's photo-model (see the module docstring for the frames and units)."""

    name: str
    points_in_mm: NDArray[np.float64]
    hsv_in: NDArray[np.float32]
    points_out_mm: NDArray[np.float64]
    outline_mm: NDArray[np.float64]
    photo_bgr: NDArray[np.uint8]
    mask: NDArray[np.uint8]
    crop_origin_px: NDArray[np.int64]
    meta: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        for key in ("points_in_mm", "points_out_mm", "outline_mm"):
            arr = np.asarray(getattr(self, key), dtype=np.float64)
            if arr.ndim != 2 or arr.shape[1] != 3:
                raise ValueError(f"{key}: expected shape (N, 3), got {arr.shape}")
            object.__setattr__(self, key, arr)
        hsv = np.asarray(self.hsv_in, dtype=np.float32)
        if hsv.shape != (self.points_in_mm.shape[0], 3):
            raise ValueError(f"hsv_in: expected shape ({self.points_in_mm.shape[0]}, 3), "
                             f"got {hsv.shape}")
        object.__setattr__(self, "hsv_in", hsv)
        if self.points_in_mm.shape[0] == 0:
            raise ValueError("points_in_mm: a photo-model needs at least one inner point")

    @property
    def n_in(self) -> int:
        """Number of S_in points."""
        return int(self.points_in_mm.shape[0])

    @property
    def n_out(self) -> int:
        """Number of S_out points."""
        return int(self.points_out_mm.shape[0])

    @property
    def size_mm(self) -> tuple[float, float]:
        """Extent (width along x, height along y) of the outline in mm."""
        ext = self.outline_mm[:, :2].max(axis=0) - self.outline_mm[:, :2].min(axis=0)
        return float(ext[0]), float(ext[1])

    @property
    def area_mm2(self) -> float:
        """Area enclosed by the outline (shoelace formula), mm^2."""
        x, y = self.outline_mm[:, 0], self.outline_mm[:, 1]
        return float(0.5 * abs(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1))))


def save_model(model: PhotoModel, path: str | os.PathLike[str]) -> Path:
    """Write ``model`` to exactly ``path`` (whatever its ending), atomically.

    The file is a NumPy ``.npz`` archive (module docstring) whatever it is called; an
    existing file is replaced, an existing directory is an error.

    Raises
    ------
    InputError
        ``path`` is a directory, or its folder cannot be created.
    """
    p = Path(path)
    if p.is_dir():
        raise InputError(p, "is a directory; give a model file name")
    try:
        p.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError(p, f"cannot create its folder ({exc.strerror})") from None
    meta = {"format": _FORMAT_NAME, "version": FORMAT_VERSION, "name": model.name, **model.meta}
    tmp = p.with_name(f".{p.name}.tmp")
    try:
        with open(tmp, "wb") as fh:
            np.savez_compressed(fh, meta=np.array(json.dumps(meta)),
                                **{k: np.asarray(getattr(model, k)) for k in _ARRAYS})
        os.replace(tmp, p)
    finally:
        tmp.unlink(missing_ok=True)
    return p


def load_model(path: str | os.PathLike[str]) -> PhotoModel:
    """Read a photo-model file written by :func:`save_model`.

    Raises
    ------
    InputError
        The file is missing, not a photo-model, of a newer format version, or damaged.
    """
    p = Path(path)
    if not p.is_file():
        raise InputError(p, "model file not found")
    try:
        with np.load(p, allow_pickle=False) as data:
            if "meta" not in data.files:
                raise InputError(p, "not a photomodel file (no metadata)")
            meta = json.loads(str(data["meta"]))
            if not isinstance(meta, dict) or meta.get("format") != _FORMAT_NAME:
                raise InputError(p, "not a photomodel file")
            version = int(meta.get("version", -1))
            if version > FORMAT_VERSION or version < 1:
                raise InputError(p, f"model format version {version} is not supported "
                                    f"(this photomodel reads up to {FORMAT_VERSION})")
            missing = [k for k in _ARRAYS if k not in data.files]
            if missing:
                raise InputError(p, f"model file lacks {', '.join(missing)}")
            arrays = {k: data[k] for k in _ARRAYS}
    except InputError:
        raise
    except (OSError, ValueError, zipfile.BadZipFile, EOFError, json.JSONDecodeError) as exc:
        raise InputError(p, f"not a readable photomodel file ({type(exc).__name__})") from None
    name = str(meta.pop("name", p.stem))
    meta.pop("format", None)
    try:
        return PhotoModel(name=name, meta=meta, **arrays)
    except ValueError as exc:
        raise InputError(p, f"damaged model file: {exc}") from None
