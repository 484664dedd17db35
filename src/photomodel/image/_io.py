"""Reading and writing images with errors that name the file."""

from __future__ import annotations

import os
from pathlib import Path

import cv2
import numpy as np
from numpy.typing import NDArray

from photomodel.errors import InputError


def read_color_image(path: str | os.PathLike[str]) -> NDArray[np.uint8]:
    """Read a colour image as 8-bit BGR (H, W, 3).

    Raises
    ------
    InputError
        The file is missing, not a decodable image, or has no colour (hue needs colour).
    """
    p = Path(path)
    if not p.is_file():
        raise InputError(p, "image file not found")
    data = np.fromfile(p, dtype=np.uint8)
    image = cv2.imdecode(data, cv2.IMREAD_UNCHANGED) if data.size else None
    if image is None:
        raise InputError(p, "not a readable image (corrupt or unsupported format)")
    if image.dtype != np.uint8:
        scale = 255.0 / np.iinfo(image.dtype).max if image.dtype.kind == "u" else 255.0
        image = np.clip(image.astype(np.float64) * scale, 0, 255).astype(np.uint8)
    if image.ndim == 2 or image.shape[2] == 1:
        raise InputError(p, "image is greyscale; the photo-model method needs colour (hue)")
    if image.shape[2] == 4:
        image = cv2.cvtColor(image, cv2.COLOR_BGRA2BGR)
    return np.ascontiguousarray(image)


def write_image(path: str | os.PathLike[str], image: NDArray[np.uint8]) -> None:
    """Write an image atomically (temporary file, then rename); format from the suffix."""
    p = Path(path)
    p.parent.mkdir(parents=True, exist_ok=True)
    ok, buf = cv2.imencode(p.suffix or ".png", image)
    if not ok:
        raise InputError(p, f"cannot encode an image as {p.suffix or '.png'}")
    tmp = p.with_name(f".{p.name}.tmp")
    buf.tofile(tmp)
    os.replace(tmp, p)
