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

Who reads what: the default (``soft``) method samples ``photo_bgr`` and ``mask`` itself, mapped
to the model frame through ``crop_origin_px`` and the metadata's model camera (``camera_K``,
``camera_dist``, ``distance_mm``, ``centroid_in_camera_mm``); the paper's method uses S_in with
its colours and S_out; the overlay draws ``outline_mm`` and S_in; ``size_mm``, ``area_mm2`` and
the library's summary come from the outline and the point counts. Every stored field is used,
so :func:`load_model` checks every one, and their agreement (S_in on the mask, S_out off it,
the outline along its edge).

Model frame (docs/contracts.md): origin at the area centroid of the silhouette on the garment plane,
x along the model photo's columns, y along its rows, z along the model camera's viewing
direction (into the plane); the garment is flat, so every point has z = 0.
"""

from __future__ import annotations

import errno
import io
import json
import math
import os
import struct
import zipfile
import zlib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from photomodel._files import write_atomic
from photomodel._limits import (
    MAX_DISTANCE_MM,
    MAX_IMAGE_PIXELS,
    MAX_MODEL_BYTES,
    MAX_MODEL_EXTENT_MM,
    MAX_MODEL_FILE_BYTES,
    MAX_MODEL_META_BYTES,
    MAX_MODEL_POINTS,
    checked_size,
)
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
    buf = io.BytesIO()
    np.savez_compressed(buf, meta=np.array(json.dumps(meta)),
                        **{k: np.asarray(getattr(model, k)) for k in _ARRAYS})
    write_atomic(p, buf.getvalue())
    return p


def load_model(path: str | os.PathLike[str]) -> PhotoModel:
    """Read a photo-model file written by :func:`save_model`: the one place that checks one.

    The archive is checked before anything is unpacked: its size, its directory (at most
    a few members, none encrypted, stored or deflated), every member's declared size and
    their total against :data:`~photomodel._limits.MAX_MODEL_BYTES`; each array is read
    through a reader that allocates what its header declares only when the member holds that
    much, and stops there. The metadata (format, version, name, the model camera) is checked
    before the arrays are read, the arrays for their dtype, shape, finiteness and ranges, and
    the model as a whole for consistency: S_in (with its colours), S_out and the outline
    projected through the model camera fall on, off and along the mask; the mask matches
    the photo crop, which lies inside the photo; the outline is at most
    :data:`~photomodel._limits.MAX_MODEL_EXTENT_MM` across.

    Raises
    ------
    InputError
        The file is missing, not a photo-model, of a newer format version, too large, or
        damaged (the message names what is wrong).
    """
    p = Path(path)
    size = checked_size(p, "model file", MAX_MODEL_FILE_BYTES)
    try:
        with open(p, "rb") as fh:
            _check_zip_directory(p, fh, size)
            with zipfile.ZipFile(fh) as archive:
                infos = _members(p, archive)
                meta = _read_meta(p, archive, infos["meta"])
                arrays = {k: _read_npy(p, archive, infos[k], _KINDS[k]) for k in _ARRAYS}
    except InputError:
        raise
    except zlib.error:
        raise InputError(p, "damaged model file (its compressed data is corrupt)") from None
    except OSError as exc:
        if exc.errno != errno.EINVAL:
            raise InputError(p, f"cannot read the model file ({exc.strerror or exc})") from None
        raise InputError(p, "damaged model file (its zip directory points outside the "
                            "file)") from None
    except (ValueError, EOFError, zipfile.BadZipFile, NotImplementedError, RuntimeError,
            struct.error) as exc:
        raise InputError(p, f"damaged model file ({type(exc).__name__}: "
                            f"{_one_line(str(exc))})") from None
    name = meta.pop("name", p.stem)
    meta.pop("format", None)
    problem = _model_problem(name, arrays, meta)
    if problem:
        raise InputError(p, f"damaged model file: {problem}")
    try:
        return PhotoModel(name=name, meta=meta, **arrays)
    except ValueError as exc:
        raise InputError(p, f"damaged model file: {exc}") from None


# --- the archive ---------------------------------------------------------------------------

_MAX_MEMBERS = 16
_MAX_DIRECTORY_BYTES = 1 << 16
_MAX_NPY_HEADER = 10_000
_KINDS = {"points_in_mm": "f", "hsv_in": "f", "points_out_mm": "f", "outline_mm": "f",
          "photo_bgr": "u", "mask": "ub", "crop_origin_px": "iu"}
_EOCD = struct.Struct("<4s4H2LH")         # end of central directory
_ZIP64_LOCATOR = struct.Struct("<4sLQL")
_ZIP64_EOCD = struct.Struct("<4sQ2H2L4Q")


def _one_line(text: str, limit: int = 100) -> str:
    text = " ".join(text.split())
    return text if len(text) <= limit else text[:limit - 3] + "..."


def _check_zip_directory(p: Path, fh: Any, size: int) -> None:
    """The end record's member count and directory size, read before ``zipfile`` builds
    one object per member (a small file can list millions)."""
    tail_size = min(size, _EOCD.size + 0xFFFF + _ZIP64_LOCATOR.size)
    fh.seek(size - tail_size)
    tail = fh.read(tail_size)
    at = tail.rfind(b"PK\x05\x06")
    if at < 0 or at + _EOCD.size > len(tail):
        raise InputError(p, "not a photomodel file (not a zip archive, or cut short)")
    _, _, _, _, entries, directory, _, _ = _EOCD.unpack_from(tail, at)
    if entries == 0xFFFF or directory == 0xFFFFFFFF:  # ZIP64: the counts are elsewhere
        loc = at - _ZIP64_LOCATOR.size
        if loc < 0 or tail[loc:loc + 4] != b"PK\x06\x07":
            raise InputError(p, "damaged model file (its ZIP64 directory record is missing)")
        offset = _ZIP64_LOCATOR.unpack_from(tail, loc)[2]
        if offset + _ZIP64_EOCD.size > size:
            raise InputError(p, "damaged model file (its ZIP64 directory record is missing)")
        fh.seek(offset)
        record = fh.read(_ZIP64_EOCD.size)
        if record[:4] != b"PK\x06\x06":
            raise InputError(p, "damaged model file (its ZIP64 directory record is missing)")
        entries, directory = _ZIP64_EOCD.unpack(record)[6], _ZIP64_EOCD.unpack(record)[7]
    if entries > _MAX_MEMBERS or directory > _MAX_DIRECTORY_BYTES:
        raise InputError(p, f"not a photomodel file (its archive lists {entries} members; "
                            f"a model has {len(_ARRAYS) + 1})")
    fh.seek(0)


def _members(p: Path, archive: zipfile.ZipFile) -> dict[str, zipfile.ZipInfo]:
    """The members by array name, after the checks on what their directory declares."""
    infos = archive.infolist()
    names = [info.filename for info in infos]
    if len(set(names)) != len(names):
        raise InputError(p, "damaged model file (a member appears twice in the archive)")
    if "meta.npy" not in names:
        raise InputError(p, "not a photomodel file (no metadata)")
    missing = [k for k in _ARRAYS if f"{k}.npy" not in names]
    if missing:
        raise InputError(p, f"model file lacks {', '.join(missing)}")
    total = 0
    for info in infos:
        if info.flag_bits & 0x1:
            raise InputError(p, f"model file member {info.filename} is encrypted")
        if info.compress_type not in (zipfile.ZIP_STORED, zipfile.ZIP_DEFLATED):
            raise InputError(p, f"model file member {info.filename} uses compression method "
                                f"{info.compress_type} (a model's are stored or deflated)")
        total += info.file_size
    if total > MAX_MODEL_BYTES:
        raise InputError(p, f"model archive unpacks to {total / 1e6:.0f} MB, more than the "
                            f"{MAX_MODEL_BYTES / 1e6:.0f} MB of the largest model photomodel "
                            "reads")
    return {info.filename.removesuffix(".npy"): info for info in infos}


def _read_npy(p: Path, archive: zipfile.ZipFile, info: zipfile.ZipInfo, kinds: str,
              limit: int = MAX_MODEL_BYTES) -> NDArray[Any]:
    """One ``.npy`` member: its header's dtype (of ``kinds``) and shape, then exactly the
    bytes they declare, into an array allocated only when the member declares them."""
    name = info.filename
    if info.file_size > limit:
        raise InputError(p, f"model file member {name} unpacks to {info.file_size / 1e6:.1f} "
                            f"MB, more than {limit / 1e6:.1f} MB")
    with archive.open(info) as fh:
        shape, fortran, dtype = _npy_header(p, name, fh)
        if dtype.hasobject or dtype.kind not in kinds or dtype.fields is not None \
                or dtype.subdtype is not None:
            raise InputError(p, f"damaged model file ({name} holds {dtype} values)")
        if any(int(n) < 0 for n in shape):
            raise InputError(p, f"damaged model file ({name}: negative shape {shape})")
        count = math.prod(int(n) for n in shape)
        nbytes = count * dtype.itemsize
        if nbytes > info.file_size:
            raise InputError(p, f"damaged model file ({name}: its header declares "
                                f"{nbytes} bytes of data, the archive {info.file_size})")
        flat = np.empty(count, dtype=dtype)
        raw = flat.view(np.uint8) if nbytes else np.empty(0, np.uint8)
        filled = 0
        while filled < nbytes:
            got = fh.readinto(raw[filled:filled + (1 << 22)])
            if not got:
                raise InputError(p, f"damaged model file ({name} is cut short)")
            filled += got
        if fh.read(1):  # also reaches the member's end, where zipfile checks its CRC
            raise InputError(p, f"damaged model file ({name} holds more than its header "
                                "declares)")
    array = flat.reshape(shape, order="F" if fortran else "C")
    return array if array.flags.c_contiguous else array.copy(order="C")


def _npy_header(p: Path, name: str, fh: Any) -> tuple[tuple[int, ...], bool, np.dtype]:
    """(shape, fortran order, dtype) of a member's ``.npy`` header, numpy's own parse."""
    try:
        version = np.lib.format.read_magic(fh)
        if version == (1, 0):
            return np.lib.format.read_array_header_1_0(fh, _MAX_NPY_HEADER)
        if version == (2, 0):
            return np.lib.format.read_array_header_2_0(fh, _MAX_NPY_HEADER)
    except (zlib.error, zipfile.BadZipFile, OSError, EOFError):
        raise  # the archive's own damage, reported as such
    except Exception as exc:  # numpy's parse raises ValueError, SyntaxError, TokenError ...
        raise InputError(p, f"damaged model file ({name}: unreadable array header, "
                            f"{type(exc).__name__})") from None
    raise InputError(p, f"damaged model file ({name}: .npy format {version})")


def _read_meta(p: Path, archive: zipfile.ZipFile, info: zipfile.ZipInfo) -> dict[str, Any]:
    """The metadata: a JSON object of the photomodel format and a supported version."""
    array = _read_npy(p, archive, info, "U", limit=MAX_MODEL_META_BYTES)
    if array.shape != ():
        raise InputError(p, "not a photomodel file (its metadata is not one string)")
    try:
        meta = json.loads(str(array))
    except (ValueError, RecursionError):
        raise InputError(p, "not a photomodel file (its metadata is not JSON)") from None
    if not isinstance(meta, dict) or meta.get("format") != _FORMAT_NAME:
        raise InputError(p, "not a photomodel file")
    version = meta.get("version")
    if version is None:
        raise InputError(p, "damaged model file: its metadata lacks the format version")
    if not isinstance(version, int) or isinstance(version, bool):
        raise InputError(p, f"damaged model file: format version must be a whole number, got "
                            f"{_one_line(json.dumps(version), 40)}")
    if not 1 <= version <= FORMAT_VERSION:
        raise InputError(p, f"model format version {version} is not supported "
                            f"(this photomodel reads up to {FORMAT_VERSION})")
    return meta


# --- the model -----------------------------------------------------------------------------

_HUE_RANGE_DEG = 360.0
_TOLERANCE_PX = 1        # a stored point may lie this far off its side of the mask edge
_MIN_AREA_MM2 = 100.0    # the garment (the build's default minimum is 400 mm^2)


def _model_problem(name: Any, arrays: dict[str, NDArray[Any]], meta: dict[str, Any]
                   ) -> str | None:
    """What is wrong with a model's name, metadata and arrays (None when nothing is)."""
    if not isinstance(name, str) or not name or len(name) > 200 or not name.isprintable():
        return "name must be a printable string of 1-200 characters"
    camera = _meta_camera(meta)
    if isinstance(camera, str):
        return camera
    cam, distance, centroid, photo_size = camera
    photo, mask, origin = arrays["photo_bgr"], arrays["mask"], arrays["crop_origin_px"]
    if photo.ndim != 3 or photo.shape[2] != 3 or 0 in photo.shape:
        return f"photo_bgr: expected a colour image (h, w, 3), got shape {photo.shape}"
    if photo.shape[0] * photo.shape[1] > MAX_IMAGE_PIXELS:
        return f"photo_bgr: more than {MAX_IMAGE_PIXELS / 1e6:.0f} megapixels"
    if mask.shape != photo.shape[:2]:
        return f"mask: shape {mask.shape} differs from the photo's {photo.shape[:2]}"
    if mask.dtype != np.bool_ and mask.size and (mask.min() < 0 or mask.max() > 1):
        return "mask: expected values 0 and 1"
    if origin.shape != (2,):
        return f"crop_origin_px: expected 2 whole numbers, got shape {origin.shape}"
    x0, y0 = int(origin[0]), int(origin[1])
    h, w = mask.shape
    if x0 < 0 or y0 < 0 or (photo_size and (x0 + w > photo_size[0] or y0 + h > photo_size[1])):
        return f"crop_origin_px: the {w}x{h} crop at ({x0}, {y0}) is not inside the photo"
    n_in = arrays["points_in_mm"].shape[0] if arrays["points_in_mm"].ndim == 2 else 0
    for key, minimum in (("points_in_mm", 3), ("points_out_mm", 3), ("outline_mm", 3)):
        pts = arrays[key]
        if pts.ndim != 2 or pts.shape[1] != 3 or not minimum <= len(pts) <= MAX_MODEL_POINTS:
            return (f"{key}: expected ({minimum} to {MAX_MODEL_POINTS}, 3) points, got shape "
                    f"{pts.shape}")
        if not np.isfinite(pts).all():
            return f"{key}: contains non-finite values"
        if np.abs(pts[:, 2]).max() > 1e-6:
            return f"{key}: the model is flat, every z must be 0"
        if np.abs(pts[:, :2]).max() > MAX_MODEL_EXTENT_MM:
            return f"{key}: points beyond {MAX_MODEL_EXTENT_MM:g} mm of the model's origin"
    hsv = arrays["hsv_in"]
    if hsv.shape != (n_in, 3) or not np.isfinite(hsv).all():
        return f"hsv_in: expected {n_in} finite colours (N, 3), got shape {hsv.shape}"
    if hsv[:, 0].min() < 0 or hsv[:, 0].max() > _HUE_RANGE_DEG or hsv[:, 1:].min() < 0 \
            or hsv[:, 1:].max() > 1:
        return "hsv_in: expected hue in [0, 360] deg, saturation and value in [0, 1]"
    return _geometry_problem(arrays, cam, distance, centroid, (x0, y0))


def _meta_camera(meta: dict[str, Any]) -> tuple[Any, float, NDArray[np.float64],
                                                 tuple[int, int] | None] | str:
    """The model camera of the metadata (PinholeCamera, distance, centroid, photo size)
    that the default fitness uses to map the photo to the model frame, or the problem."""
    from photomodel.camera import PinholeCamera

    try:
        K = np.asarray(meta["camera_K"], dtype=np.float64)
        dist = np.asarray(meta["camera_dist"], dtype=np.float64)
        distance = meta["distance_mm"]
        centroid = np.asarray(meta["centroid_in_camera_mm"], dtype=np.float64)
    except KeyError as exc:
        return f"its metadata lacks {exc.args[0]} (the model camera)"
    except (TypeError, ValueError):
        return "its metadata's model camera (camera_K, camera_dist, centroid) is not numbers"
    try:
        camera = PinholeCamera(K, dist)
    except ValueError as exc:
        return f"metadata camera_{exc}"
    if isinstance(distance, bool) or not isinstance(distance, int | float) \
            or not 1 <= distance <= MAX_DISTANCE_MM:
        return f"metadata distance_mm must be a number in [1, {MAX_DISTANCE_MM:g}]"
    if centroid.shape != (3,) or not np.isfinite(centroid).all() \
            or np.abs(centroid).max() > MAX_DISTANCE_MM:
        return "metadata centroid_in_camera_mm must be 3 finite numbers"
    size = meta.get("photo_size_px")
    if size is not None:
        if not (isinstance(size, list) and len(size) == 2
                and all(isinstance(n, int) and not isinstance(n, bool) and n > 0 for n in size)
                and size[0] * size[1] <= MAX_IMAGE_PIXELS):
            return "metadata photo_size_px must be [width, height] in pixels"
        size = (size[0], size[1])
    return camera, float(distance), centroid, size


def _geometry_problem(arrays: dict[str, NDArray[Any]], camera: Any, distance: float,
                      centroid: NDArray[np.float64], origin: tuple[int, int]) -> str | None:
    """S_in, S_out and the outline against the mask, through the model camera."""
    mask = arrays["mask"].astype(np.uint8)
    h, w = mask.shape
    kernel = np.ones((2 * _TOLERANCE_PX + 1,) * 2, np.uint8)
    import cv2  # here: the command line imports this module while it builds its parser

    grown = cv2.dilate(mask, kernel)
    shrunk = cv2.erode(mask, kernel, borderType=cv2.BORDER_REPLICATE)
    px_per_mm = float(np.sqrt(camera.K[0, 0] * camera.K[1, 1])) / distance
    area_mm2 = float(mask.sum()) / px_per_mm**2
    if area_mm2 < _MIN_AREA_MM2:
        return f"mask: the garment covers {area_mm2:.0f} mm^2, less than {_MIN_AREA_MM2:g}"

    keys = ("points_in_mm", "points_out_mm", "outline_mm")
    xy = np.concatenate([arrays[k][:, :2] for k in keys]) + centroid[:2]
    with np.errstate(all="ignore"):  # a wild camera overflows: those points are outside
        uv = np.rint(camera.project(np.column_stack([xy, np.full(len(xy), distance)]))
                     - origin)
        inside = (uv[:, 0] >= 0) & (uv[:, 0] < w) & (uv[:, 1] >= 0) & (uv[:, 1] < h)
    uv = np.where(inside[:, None], uv, 0).astype(np.intp)
    index = uv[:, 1] * w + uv[:, 0]
    on_grown = inside & (grown.ravel()[index] > 0)
    on_shrunk = inside & (shrunk.ravel()[index] > 0)
    n_in, n_out = len(arrays["points_in_mm"]), len(arrays["points_out_mm"])
    if not on_grown[:n_in].all():
        return "points_in_mm: S_in points lie off the garment's mask"
    if on_shrunk[n_in:n_in + n_out].any():
        return "points_out_mm: S_out points lie on the garment's mask"
    if not on_grown[n_in + n_out:].all() or on_shrunk[n_in + n_out:].any():
        return "outline_mm: the outline does not follow the mask's edge"
    outline = arrays["outline_mm"]
    x, y = outline[:, 0], outline[:, 1]
    outline_area = 0.5 * abs(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))
    if outline_area < 0.5 * area_mm2:
        return "outline_mm: the outline encloses less than half the mask's garment"
    span_in = np.ptp(arrays["points_in_mm"][:, :2], axis=0)
    span = np.ptp(outline[:, :2], axis=0)
    if (span_in < 0.5 * span).any():
        return "points_in_mm: S_in does not cover the garment"
    return None
