"""The views of a calibration: image folders, pair folders, and the corners found in them.

Views are taken in name order. Each image is read through
:func:`~photomodel.image.read_grey_image` (bounded, errors naming the file), searched for the
board and dropped: only its corners and size are kept, so a hundred views cost no more memory
than one.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from photomodel.calibrate._detect import Detection, find_corners
from photomodel.calibrate._pattern import Target
from photomodel.errors import InputError
from photomodel.image import IMAGE_SUFFIXES, read_grey_image

__all__ = ["IMAGE_SUFFIXES", "ViewCorners", "detect_views", "list_images", "list_pairs"]

_MAX_VIEWS = 1000


@dataclass(frozen=True)
class ViewCorners:
    """One view: its name, file, image size and what the board search found.

    Parameters
    ----------
    name : str
        The view's name (the file's stem, or the pair folder's name).
    path : Path
        The image file.
    size : (int, int)
        (width, height), px.
    detection : Detection
        The corners (N, 2) px, or why there are none.
    """

    name: str
    path: Path
    size: tuple[int, int]
    detection: Detection

    @property
    def corners(self) -> NDArray[np.float64] | None:
        return self.detection.corners


def _folder(path: str | os.PathLike[str], what: str) -> Path:
    p = Path(path)
    if not p.exists():
        raise InputError(p, f"{what} folder not found")
    if not p.is_dir():
        raise InputError(p, f"is not a folder (expected the {what} folder)")
    return p


def list_images(folder: str | os.PathLike[str]) -> list[tuple[str, Path]]:
    """(name, path) of the image files (PNG, BMP, JPEG) directly in ``folder``, in name order.

    Raises
    ------
    InputError
        The folder is missing, holds no image file or more than 1000.
    """
    p = _folder(folder, "calibration images")
    files = sorted(f for f in p.iterdir()
                   if f.is_file() and f.suffix.lower() in IMAGE_SUFFIXES
                   and not f.name.startswith("."))
    if not files:
        raise InputError(p, f"holds no image files ({', '.join(IMAGE_SUFFIXES)})")
    if len(files) > _MAX_VIEWS:
        raise InputError(p, f"holds {len(files)} images, more than the {_MAX_VIEWS} views a "
                            "calibration takes")
    return [(f.name, f) for f in files]


def _pair_image(folder: Path, stem: str) -> Path | None:
    for suffix in IMAGE_SUFFIXES:
        candidate = folder / f"{stem}{suffix}"
        if candidate.is_file():
            return candidate
    return None


def list_pairs(folder: str | os.PathLike[str]) -> list[tuple[str, Path, Path]]:
    """(id, right, left) of the pair folders ``folder/<id>/{right,left}.png``, in name order.

    Camera 1 (the reference) is the right camera. BMP and JPEG files are taken too.

    Raises
    ------
    InputError
        The folder is missing or holds no pair folder, or a pair folder lacks one of its
        two images.
    """
    p = _folder(folder, "stereo pairs")
    subdirs = sorted(d for d in p.iterdir() if d.is_dir() and not d.name.startswith("."))
    if not subdirs:
        raise InputError(p, "holds no pair folders (expected DIR/<id>/right.png and "
                            "DIR/<id>/left.png)")
    if len(subdirs) > _MAX_VIEWS:
        raise InputError(p, f"holds {len(subdirs)} pair folders, more than the {_MAX_VIEWS} "
                            "views a calibration takes")
    pairs = []
    for d in subdirs:
        right, left = _pair_image(d, "right"), _pair_image(d, "left")
        for image, stem in ((right, "right"), (left, "left")):
            if image is None:
                raise InputError(d, f"lacks {stem}.png (each pair folder holds right.png, "
                                    "camera 1, and left.png, camera 2)")
        assert right is not None and left is not None
        pairs.append((d.name, right, left))
    return pairs


def detect_views(views: list[tuple[str, Path]], board: Target,
                 size: tuple[int, int] | None = None) -> list[ViewCorners]:
    """Read each view and find the board in it.

    Parameters
    ----------
    views : list of (name, path)
    board : Chessboard or CharucoBoard
    size : (int, int), optional
        (width, height) every view must have; by default the first view's.

    Raises
    ------
    InputError
        An image cannot be read, or its size differs from the others'.
    """
    out: list[ViewCorners] = []
    first: tuple[Path, tuple[int, int]] | None = None
    for name, path in views:
        grey = read_grey_image(path, "calibration image")
        h, w = grey.shape
        if size is not None and (w, h) != size:
            raise InputError(path, f"is {w}x{h} px but the other camera's views are "
                                   f"{size[0]}x{size[1]} px: all views must have one size")
        if first is None:
            first = (path, (w, h))
        elif (w, h) != first[1]:
            fw, fh = first[1]
            raise InputError(path, f"is {w}x{h} px but {first[0]} is {fw}x{fh} px: all views "
                                   "must come from one camera at one resolution")
        out.append(ViewCorners(name, path, (w, h), find_corners(grey, board)))
    return out
