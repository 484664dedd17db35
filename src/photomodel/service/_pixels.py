"""Views uploaded without an image container: raw pixels (``application/octet-stream`` with
width, height and pixel format) and ``.npy`` arrays, turned into BGR (H, W, 3) uint8 arrays.
Every refusal is an :class:`~photomodel.errors.InputError` naming the field at fault."""

from __future__ import annotations

import io
import re

import numpy as np
from numpy.typing import NDArray

from photomodel.errors import InputError

__all__ = ["PIXEL_FORMATS", "RawLayout", "npy_view", "pixel_format", "raw_layout", "raw_pair",
           "raw_view"]

PIXEL_FORMATS = {"bgr8": 3, "rgb8": 3, "mono8": 1}
"""The raw pixel formats and their bytes per pixel (8 bits a channel, rows top to bottom,
no padding between rows); ``mono8`` is expanded to three equal channels."""

MAX_SIDE_PX = 65535


class RawLayout:
    """The layout of one raw view: ``width`` x ``height`` pixels in ``pixel_format``."""

    __slots__ = ("height", "pixel_format", "width")

    def __init__(self, width: int, height: int, pixel_format: str) -> None:
        self.width, self.height, self.pixel_format = width, height, pixel_format

    @property
    def nbytes(self) -> int:
        return self.width * self.height * PIXEL_FORMATS[self.pixel_format]

    def __str__(self) -> str:
        return f"{self.width}x{self.height} {self.pixel_format}"


def _side(text: str | None, name: str) -> int:
    if text is None:
        raise InputError(name, "missing field (raw pixels need width, height and, unless "
                               "bgr8, pixel_format)")
    if not re.fullmatch(r"\d{1,5}", text.strip()) or not 1 <= int(text) <= MAX_SIDE_PX:
        raise InputError(name, f"expected a size from 1 to {MAX_SIDE_PX} px, got {text!r}")
    return int(text)


def pixel_format(text: str | None) -> str:
    """The pixel format named by ``text`` (default ``bgr8``)."""
    fmt = (text or "bgr8").strip().lower()
    if fmt not in PIXEL_FORMATS:
        raise InputError("pixel_format", f"expected one of {', '.join(PIXEL_FORMATS)}, got "
                                         f"{text!r}")
    return fmt


def raw_layout(width: str | None, height: str | None, fmt: str | None) -> RawLayout:
    """The layout given by the ``width``, ``height`` and ``pixel_format`` fields (text)."""
    return RawLayout(_side(width, "width"), _side(height, "height"), pixel_format(fmt))


def _to_bgr(pixels: NDArray[np.uint8], fmt: str) -> NDArray[np.uint8]:
    """(H, W, 3) BGR from (H, W, 3) ``bgr8``/``rgb8`` or (H, W) ``mono8`` pixels (a new,
    writable array)."""
    if fmt == "mono8":
        return np.repeat(pixels.reshape(*pixels.shape[:2], 1), 3, axis=2)
    if fmt == "rgb8":
        return np.ascontiguousarray(pixels[..., ::-1])
    return pixels.copy()


def raw_view(data: bytes | memoryview, name: str, layout: RawLayout) -> NDArray[np.uint8]:
    """View ``name`` (``right`` or ``left``) from its raw bytes, as BGR (H, W, 3) uint8."""
    if len(data) != layout.nbytes:
        raise InputError(name, f"{layout} takes {layout.nbytes} bytes, got {len(data)}")
    shape = (layout.height, layout.width, PIXEL_FORMATS[layout.pixel_format])
    pixels = np.frombuffer(data, np.uint8).reshape(shape)
    return _to_bgr(pixels if shape[2] == 3 else pixels[..., 0], layout.pixel_format)


def raw_pair(data: bytes, layout: RawLayout
             ) -> tuple[NDArray[np.uint8], NDArray[np.uint8]]:
    """The right and left views from one body holding both, right first, each in
    ``layout``."""
    n = layout.nbytes
    if len(data) != 2 * n:
        raise InputError("body", f"two views of {layout} take 2 x {n} = {2 * n} bytes (right "
                                 f"then left), got {len(data)}")
    view = memoryview(data)
    return raw_view(view[:n], "right", layout), raw_view(view[n:], "left", layout)


def npy_view(data: bytes, name: str, fmt: str | None = None) -> NDArray[np.uint8]:
    """View ``name`` from a ``.npy`` file: (H, W, 3) uint8 in ``bgr8`` (default) or ``rgb8``
    order, or (H, W) uint8 ``mono8``; pickled arrays are refused."""
    try:
        array = np.load(io.BytesIO(data), allow_pickle=False)
    except (ValueError, OSError, EOFError) as exc:
        raise InputError(name, f"not a readable .npy file without pickles ({exc})") from None
    if not isinstance(array, np.ndarray):
        raise InputError(name, "expected one .npy array, got an .npz archive")
    if array.dtype != np.uint8:
        raise InputError(name, f"expected dtype uint8, got {array.dtype}")
    if array.ndim == 2:
        return _to_bgr(array, "mono8")
    if array.ndim != 3 or array.shape[2] != 3:
        raise InputError(name, f"expected shape (H, W, 3) or (H, W), got {array.shape}")
    order = pixel_format(fmt)
    if order == "mono8":
        raise InputError("pixel_format", "mono8 .npy arrays are (H, W); this one is "
                                         f"{array.shape}")
    return _to_bgr(array, order)
