"""Labels: a barcode, QR code or DataMatrix on the garment, read in the hand cameras' views.

A label settles identity where it is read (the seed paper's "bar coding"): its text, through
the library's label map (``photomodel models label NAME CODE``,
:meth:`~photomodel.library.ModelLibrary.labels`), names a model. :func:`read_labels` reads
both views with zxing-cpp (the optional extra ``labels``) and matches the reads by text;
:func:`check_label` sets the label beside the photo-model's answer and says whether the two
agree. A disagreement is reported, never resolved: the photo-model's ``model`` stays as it is.
How big a label must be to be read, and the measured read rates: docs/method/labels.md.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import cv2
import numpy as np
from numpy.typing import NDArray

from photomodel.image import LINEAR_FORMATS, Barcode, decode_barcodes
from photomodel.locate import LocateResult

__all__ = ["LINEAR_TURNS_DEG", "READ_FORMATS", "LabelCheck", "LabelRead", "check_label",
           "read_labels"]

READ_FORMATS: tuple[str, ...] = ("QRCode", "DataMatrix", "Aztec", "Code128", "EAN13", "EAN8",
                                 "UPCA")
"""The symbologies :func:`read_labels` looks for by default: the 2D codes of logistics labels
and the linear codes with a check character that garments carry (Code 39, Codabar and ITF,
which need none and which a striped fabric can imitate, are left out)."""

LINEAR_TURNS_DEG: tuple[float, ...] = (22.5, 45.0, 67.5)
"""Turns of a view read again for linear codes: with zxing-cpp's own rows and columns, a
scan direction every 22.5 degrees, so that a code whose bars are at least a fifth of its
length high reads at any angle."""


@dataclass(frozen=True)
class LabelRead:
    """One label read in a stereo pair.

    Attributes
    ----------
    text : str
        What it encodes.
    format : str
        zxing-cpp's name of its symbology (``"QRCode"``, ``"DataMatrix"``, ``"Code128"``, ...).
    corners_cam1, corners_cam2 : ndarray (4, 2) or None
        Pixels (u, v) of the symbol's corners in camera 1's (right) and camera 2's (left)
        image, in the symbol's own orientation (top-left, top-right, bottom-right,
        bottom-left; a linear code's span its bars along the lines that read it); None where
        that view did not read it.
    """

    text: str
    format: str
    corners_cam1: NDArray[np.float64] | None
    corners_cam2: NDArray[np.float64] | None

    def to_json_dict(self) -> dict[str, Any]:
        """``{"text", "format", "corners_cam1", "corners_cam2"}``, corners as 4 [u, v]
        lists or null."""
        return {"text": self.text, "format": self.format,
                "corners_cam1": _corners_json(self.corners_cam1),
                "corners_cam2": _corners_json(self.corners_cam2)}


def _corners_json(corners: NDArray[np.float64] | None) -> list[list[float]] | None:
    return None if corners is None else [[float(u), float(v)] for u, v in corners]


def _area(corners: NDArray[np.float64]) -> float:
    """Area (px^2) of the quadrilateral (shoelace)."""
    u, v = corners[:, 0], corners[:, 1]
    return 0.5 * abs(float(np.dot(u, np.roll(v, -1)) - np.dot(v, np.roll(u, -1))))


def _by_label(reads: list[Barcode]) -> dict[tuple[str, str], NDArray[np.float64]]:
    """Each (text, format) once, with the corners of its largest read."""
    out: dict[tuple[str, str], NDArray[np.float64]] = {}
    for b in sorted(reads, key=lambda b: -_area(b.corners_px)):
        out.setdefault((b.text, b.format), b.corners_px)
    return out


def _turned(image: NDArray[np.uint8], angle_deg: float
            ) -> tuple[NDArray[np.uint8], NDArray[np.float64]]:
    """``image`` turned by ``angle_deg`` about its centre on a canvas that holds all of it,
    and the affine map (2, 3) from the turned image's pixels back to the image's."""
    h, w = image.shape[:2]
    A = cv2.getRotationMatrix2D(((w - 1) / 2, (h - 1) / 2), angle_deg, 1.0)
    c, s = abs(A[0, 0]), abs(A[0, 1])
    size = (int(np.ceil(w * c + h * s)), int(np.ceil(w * s + h * c)))
    A[:, 2] += ((size[0] - 1) / 2 - (w - 1) / 2, (size[1] - 1) / 2 - (h - 1) / 2)
    turned = cv2.warpAffine(image, A, size, flags=cv2.INTER_LINEAR,
                            borderMode=cv2.BORDER_REPLICATE)
    return turned, cv2.invertAffineTransform(A)


def _read_view(image: NDArray[np.uint8], formats: Sequence[str],
               turns_deg: Sequence[float], upscale: int) -> list[Barcode]:
    """Every read of one view: as it is, enlarged, and turned for the linear formats."""
    grey = cv2.cvtColor(image, cv2.COLOR_BGR2GRAY) if image.ndim == 3 else image
    reads = decode_barcodes(grey, formats)
    if upscale > 1:
        big = cv2.resize(grey, None, fx=upscale, fy=upscale, interpolation=cv2.INTER_CUBIC)
        reads += [Barcode(b.text, b.format, (b.corners_px + 0.5) / upscale - 0.5)
                  for b in decode_barcodes(big, formats)]
    linear = [f for f in formats if f in LINEAR_FORMATS]
    for angle in turns_deg if linear else ():
        turned, back = _turned(grey, angle)
        reads += [Barcode(b.text, b.format, b.corners_px @ back[:, :2].T + back[:, 2])
                  for b in decode_barcodes(turned, linear)]
    return reads


def read_labels(right_bgr: NDArray[np.uint8], left_bgr: NDArray[np.uint8], *,
                formats: Sequence[str] = READ_FORMATS,
                turns_deg: Sequence[float] = LINEAR_TURNS_DEG,
                upscale: int = 2) -> tuple[LabelRead, ...]:
    """The labels readable in a stereo pair: each view read on its own, reads matched by text.

    Each view is read in grey as it is and enlarged ``upscale`` times (cubic: zxing-cpp
    reads modules narrower than about 2.5 px much more often so). zxing-cpp reads a 2D code
    at any angle, but a linear code only along the image's rows and columns (tilted by at
    most about its height over its length); each view is therefore read again turned by
    ``turns_deg`` for the linear formats. Every read passed zxing-cpp's error correction or
    check character; the reads are pooled.

    Parameters
    ----------
    right_bgr, left_bgr : ndarray (H, W, 3) uint8
        Camera 1's (right) and camera 2's (left) images, BGR.
    formats : sequence of str
        zxing-cpp symbologies to look for (default :data:`READ_FORMATS`).
    turns_deg : sequence of float
        Angles (degrees) by which each view is turned and read again for the linear formats
        (default :data:`LINEAR_TURNS_DEG`; empty: read as it is only).
    upscale : int
        Enlargement of the second read (1: none).

    Returns
    -------
    tuple of LabelRead
        One per (text, format) read in either view, by text; a symbol read twice in one view
        (two garments of one article) keeps its larger read.

    Raises
    ------
    InputError
        zxing-cpp is not installed (``pip install 'photomodel[labels]'``).
    ValueError
        An unknown format name.
    """
    if isinstance(upscale, bool) or not isinstance(upscale, int) or not 1 <= upscale <= 4:
        raise ValueError(f"upscale: expected an integer from 1 to 4, got {upscale!r}")
    views = [_by_label(_read_view(image, formats, turns_deg, upscale))
             for image in (right_bgr, left_bgr)]
    keys = sorted(set(views[0]) | set(views[1]))
    return tuple(LabelRead(text, fmt, views[0].get((text, fmt)), views[1].get((text, fmt)))
                 for text, fmt in keys)


@dataclass(frozen=True)
class LabelCheck:
    """The label in an identification's answer, beside the photo-model's.

    Attributes
    ----------
    read : LabelRead
        The label.
    model : str or None
        The model its text names in the label map; None when the map does not hold it.
    agrees : bool or None
        True when ``model`` is the photo-model's answer, False when it is another (or the
        photo-model found none), None when the label names no model.
    located : LocateResult or None
        ``model`` located in the same pair (the photo-model's own search when it verified
        it, else a search made for the label); None when the label names no model, or one
        the library does not hold.
    found : bool or None
        ``located`` passes identification's test (score and visible outline); None without
        ``located``.
    """

    read: LabelRead
    model: str | None
    agrees: bool | None
    located: LocateResult | None = None
    found: bool | None = None

    def to_json_dict(self) -> dict[str, Any]:
        """The answer's ``label``: ``{"text", "format", "corners_cam1", "corners_cam2",
        "model", "agrees", "model_found", "model_score"}`` (docs/contracts.md)."""
        return {**self.read.to_json_dict(), "model": self.model, "agrees": self.agrees,
                "model_found": self.found,
                "model_score": None if self.located is None else float(self.located.score)}


def check_label(reads: Sequence[LabelRead], label_map: Mapping[str, str],
                answer: str | None,
                verify: Callable[[str], tuple[LocateResult | None, bool | None]]
                ) -> LabelCheck | None:
    """The label of an identification: which one, what it names, and whether it agrees.

    Of several labels read, the one naming the photo-model's answer is taken, else the first
    (by text) that names a model, else the first. Its model is verified (``verify``) so that
    the answer says whether it is in view too; the photo-model's answer is never changed.

    Parameters
    ----------
    reads : sequence of LabelRead
        :func:`read_labels`' answer.
    label_map : mapping of str to str
        Label text -> model name.
    answer : str or None
        The photo-model's answer (None: none of the models is on the table).
    verify : callable(str) -> (LocateResult or None, bool or None)
        The named model located in the pair and whether it counts as found ((None, None)
        when the library does not hold it).

    Returns
    -------
    LabelCheck or None
        None when no label was read.
    """
    if not reads:
        return None
    named = [r for r in reads if r.text in label_map]
    read = next((r for r in named if label_map[r.text] == answer), None) or (named or reads)[0]
    model = label_map.get(read.text)
    if model is None:
        return LabelCheck(read, None, None)
    located, found = verify(model)
    return LabelCheck(read, model, model == answer, located, found)
