"""Barcodes, QR codes and DataMatrix symbols, through zxing-cpp (the optional extra ``labels``).

The one place that imports ``zxingcpp``: :func:`decode_barcodes` reads the symbols of one
image, :func:`barcode_modules` prints one (the simulator's labels). Formats are zxing's own
names (``"QRCode"``, ``"DataMatrix"``, ``"Code128"``, ``"EAN13"``, ...). Pixels follow
docs/contracts.md: (u, v) = (column, row), origin at the centre of the top-left pixel.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from types import ModuleType

import numpy as np
from numpy.typing import NDArray

from photomodel.errors import InputError

__all__ = ["EXTRA_HINT", "LINEAR_FORMATS", "Barcode", "barcode_modules", "decode_barcodes", "zxing",
           "zxing_available"]

EXTRA_HINT = "pip install 'photomodel[labels]' (zxing-cpp 2.2 or later)"
"""How to get the reader, for messages."""

LINEAR_FORMATS: frozenset[str] = frozenset({
    "Code128", "Code39", "Code93", "Codabar", "ITF", "EAN13", "EAN8", "UPCA", "UPCE",
    "DataBar", "DataBarExpanded", "DataBarLimited"})
"""Symbologies of one row of bars (read along scan lines)."""


def zxing(source: str = "labels") -> ModuleType:
    """The ``zxingcpp`` module; :class:`~photomodel.errors.InputError` naming ``source`` (the
    option or feature that asked for labels) when it is not installed."""
    try:
        import zxingcpp
    except ImportError:
        raise InputError(source, f"reading and printing labels needs zxing-cpp: "
                                 f"{EXTRA_HINT}") from None
    return zxingcpp


def zxing_available() -> bool:
    """Whether zxing-cpp can be imported."""
    try:
        zxing()
    except InputError:
        return False
    return True


@dataclass(frozen=True)
class Barcode:
    """One symbol read in one image.

    Attributes
    ----------
    text : str
        Its content as zxing's human-readable interpretation gives it.
    format : str
        zxing's name of its symbology (``"QRCode"``, ``"DataMatrix"``, ``"Code128"``, ...).
    corners_px : ndarray (4, 2)
        Pixels (u, v) of the symbol's corners (quiet zone excluded) in the symbol's own
        orientation: top-left, top-right, bottom-right, bottom-left. A linear code's corners
        span its bars along the scan lines that read it (not necessarily their full height).
    """

    text: str
    format: str
    corners_px: NDArray[np.float64]


def _formats(module: ModuleType, formats: Sequence[str]) -> object:
    try:
        return module.barcode_formats_from_str(",".join(formats))
    except (ValueError, RuntimeError) as exc:
        raise ValueError(f"formats: {exc} (got {list(formats)})") from None


def decode_barcodes(image: NDArray[np.uint8], formats: Sequence[str]) -> list[Barcode]:
    """Every symbol of ``formats`` that zxing-cpp reads in ``image``.

    Parameters
    ----------
    image : ndarray (H, W, 3) BGR or (H, W) grey, uint8
    formats : sequence of str
        zxing format names to look for.

    Returns
    -------
    list of Barcode
        Valid reads only (a symbol whose error correction fails is not listed).

    Raises
    ------
    InputError
        zxing-cpp is not installed.
    """
    module = zxing()
    found = module.read_barcodes(np.ascontiguousarray(image), formats=_formats(module, formats))
    out = []
    for b in found:
        if not b.valid:
            continue
        p = b.position
        corners = np.array([[q.x, q.y] for q in (p.top_left, p.top_right, p.bottom_right,
                                                  p.bottom_left)], dtype=np.float64)
        # zxing's points are pixel edges (pixel i spans [i, i + 1)); ours are pixel centres.
        out.append(Barcode(str(b.text), b.format.name, corners - 0.5))
    return out


def barcode_modules(text: str, format: str) -> NDArray[np.bool_]:
    """The modules of the symbol encoding ``text``, as zxing-cpp's writer prints it.

    Parameters
    ----------
    text : str
    format : str
        ``"QRCode"``, ``"DataMatrix"`` (square), ``"Code128"`` or another format zxing-cpp
        can create.

    Returns
    -------
    ndarray (rows, columns) bool
        True for a dark module, quiet zone excluded; a linear code is one row.

    Raises
    ------
    InputError
        zxing-cpp is not installed.
    ValueError
        A format zxing-cpp cannot write, or text it cannot encode in it.
    """
    module = zxing()
    try:
        fmt = module.barcode_format_from_str(format)
    except (ValueError, RuntimeError) as exc:
        raise ValueError(f"format: {exc} (got {format!r})") from None
    try:
        if hasattr(module, "create_barcode"):           # zxing-cpp 2.3 and later
            extra = {"force_square": True} if format == "DataMatrix" else {}
            image = module.create_barcode(text, fmt, **extra).to_image(
                scale=1, add_quiet_zones=False)
        else:                                            # zxing-cpp 2.2
            image = module.write_barcode(fmt, text, quiet_zone=0)
    except (ValueError, RuntimeError) as exc:
        raise ValueError(f"text: cannot encode {text!r} as {format}: {exc}") from None
    dark = np.asarray(image) < 128
    if dark.ndim != 2 or not dark.any():
        raise ValueError(f"text: zxing-cpp printed no {format} symbol for {text!r}")
    return dark[:1] if format in LINEAR_FORMATS else dark
