"""Text labels on pictures: light text on a one-pixel dark outline, drawn once."""

from __future__ import annotations

import cv2
import numpy as np
from numpy.typing import NDArray

__all__ = ["draw_label"]

_FONT = cv2.FONT_HERSHEY_SIMPLEX
_OUTLINE = np.ones((3, 3), np.uint8)


def draw_label(img: NDArray[np.uint8], text: str, org: tuple[int, int],
               colour: tuple[int, int, int] = (255, 255, 255), *,
               font_scale: float = 0.5) -> None:
    """Write ``text`` into ``img`` (in place): ``colour`` glyphs with a black outline.

    The glyphs are laid out once (``cv2.putText``, thickness 1) into a mask; the outline is
    that mask grown by one pixel. Drawing a thick black pass and a thin coloured pass instead
    writes the text twice a few pixels apart wherever the font's advance depends on the
    thickness (OpenCV 5's built-in font does: ``left (camera 2)`` is 111 px wide thin, 119
    px thick).

    Parameters
    ----------
    img : (H, W, 3) uint8
        BGR picture, changed in place.
    text : str
        One line of text.
    org : (int, int)
        Pixel (u, v) of the text's baseline start, as ``cv2.putText`` takes it.
    colour : (int, int, int)
        BGR colour of the glyphs.
    font_scale : float
        ``cv2.putText``'s font scale.
    """
    (width, height), baseline = cv2.getTextSize(text, _FONT, font_scale, 1)
    pad = 3 + height // 2          # room for the outline and glyphs beyond the measured box
    u0, v0 = max(org[0] - pad, 0), max(org[1] - height - pad, 0)
    u1 = min(org[0] + width + pad, img.shape[1])
    v1 = min(org[1] + baseline + pad, img.shape[0])
    if u1 <= u0 or v1 <= v0:
        return
    glyphs = np.zeros((v1 - v0, u1 - u0), np.uint8)
    cv2.putText(glyphs, text, (org[0] - u0, org[1] - v0), _FONT, font_scale, 255, 1,
                cv2.LINE_AA)
    ink = glyphs[..., None].astype(np.float32) / 255.0
    outline = cv2.dilate(glyphs, _OUTLINE)[..., None].astype(np.float32) / 255.0
    patch = img[v0:v1, u0:u1].astype(np.float32) * (1.0 - outline)
    patch = patch * (1.0 - ink) + np.asarray(colour, np.float32) * ink
    img[v0:v1, u0:u1] = np.rint(patch).astype(np.uint8)
