"""Contact sheet of a dataset directory: every model photo and every stereo scene, labelled.

Works on any directory in the dataset layout of docs/contracts.md (simulated or recorded on a
real rig).
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import cv2
import numpy as np
from numpy.typing import NDArray

from photomodel.errors import InputError
from photomodel.image import read_color_image

__all__ = ["contact_sheet"]

_FONT = cv2.FONT_HERSHEY_SIMPLEX


def _label(tile: NDArray[np.uint8], text: str) -> NDArray[np.uint8]:
    """The tile with a strip of text below it."""
    strip = np.full((18, tile.shape[1], 3), 32, np.uint8)
    cv2.putText(strip, text, (4, 13), _FONT, 0.4, (235, 235, 235), 1, cv2.LINE_AA)
    return np.vstack([tile, strip])


def _grid(tiles: list[NDArray[np.uint8]], columns: int, title: str) -> NDArray[np.uint8]:
    h, w = tiles[0].shape[:2]
    rows = -(-len(tiles) // columns)
    sheet = np.full((rows * (h + 4) + 30, columns * (w + 4) + 4, 3), 16, np.uint8)
    cv2.putText(sheet, title, (6, 21), _FONT, 0.6, (255, 255, 255), 1, cv2.LINE_AA)
    for k, tile in enumerate(tiles):
        r, c = divmod(k, columns)
        y, x = 30 + r * (h + 4), 4 + c * (w + 4)
        sheet[y:y + h, x:x + w] = tile
    return sheet


def contact_sheet(
    dataset: str | os.PathLike[str],
    tile_width_px: int = 200,
    columns: int = 6,
    max_scenes: int | None = None,
) -> NDArray[np.uint8]:
    """A picture of a dataset: the model photos, then each scene's right and left images.

    Parameters
    ----------
    dataset : path
        Dataset directory (``models/``, ``scenes/``, ``truth.json``).
    tile_width_px : int
        Width of one image on the sheet (a stereo scene takes two).
    columns : int
        Model photos per row (scenes: half as many pairs).
    max_scenes : int, optional
        Show at most this many scenes (in ``truth.json`` order).

    Returns
    -------
    ndarray (H, W, 3) uint8
        BGR sheet.

    Raises
    ------
    InputError
        Missing directory, unreadable ``truth.json`` or images.
    """
    root = Path(dataset)
    truth_path = root / "truth.json"
    if not truth_path.is_file():
        raise InputError(truth_path, "not found (is this a dataset directory?)")
    try:
        truth = json.loads(truth_path.read_text())
    except (OSError, ValueError) as exc:
        raise InputError(truth_path, f"cannot read: {exc}") from exc
    tile_h = round(tile_width_px * 3 / 4)

    def thumb(path: Path) -> NDArray[np.uint8]:
        image = read_color_image(path)
        return cv2.resize(image, (tile_width_px, tile_h), interpolation=cv2.INTER_AREA)

    parts = []
    models = sorted((p for p in (root / "models").glob("*") if p.is_dir()),
                    key=lambda p: (len(p.name), p.name))
    if models:
        tiles = [_label(thumb(m / "photo.bmp"), m.name) for m in models]
        parts.append(_grid(tiles, columns, "model photos (model station, 400 mm)"))
    ids = list(truth)[:max_scenes]
    if ids:
        tiles = []
        for scene_id in ids:
            pair = np.hstack([thumb(root / "scenes" / scene_id / "right.png"),
                              thumb(root / "scenes" / scene_id / "left.png")])
            model = truth[scene_id].get("model")
            note = "" if model else "  no target"
            tiles.append(_label(pair, f"{scene_id}  (right | left){note}"))
        parts.append(_grid(tiles, max(1, columns // 2), "stereo scenes (camera 1 = right)"))
    if not parts:
        raise InputError(root, "no models and no scenes to show")
    width = max(p.shape[1] for p in parts)
    padded = [np.pad(p, ((0, 0), (0, width - p.shape[1]), (0, 0)), constant_values=16)
              for p in parts]
    return np.vstack(padded)
