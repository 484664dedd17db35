"""Preview picture of a photo-model: mask, S_in, S_out and outline over the model photo."""

from __future__ import annotations

import cv2
import numpy as np
from numpy.typing import NDArray

from photomodel.image import draw_label
from photomodel.model._build import BuildResult

_IN_BGR = (255, 255, 0)  # cyan
_OUT_BGR = (255, 0, 255)  # magenta
_OUTLINE_BGR = (0, 255, 255)  # yellow
_TEXT_BGR = (255, 255, 255)
_WARN_BGR = (80, 80, 255)  # light red


def render_preview(photo_bgr: NDArray[np.uint8], built: BuildResult, scale: int = 2
                   ) -> NDArray[np.uint8]:
    """Draw the build result over the photo (upscaled ``scale`` times) with a legend.

    Returns a BGR image; the mask is darkened outside, S_in points are cyan, S_out points
    magenta and the outline yellow; the legend ends with the build's quality line (the share
    of plane colour, in red when it drew a warning).
    """
    img = cv2.resize(photo_bgr, None, fx=scale, fy=scale, interpolation=cv2.INTER_NEAREST)
    mask = cv2.resize(built.mask.astype(np.uint8), None, fx=scale, fy=scale,
                      interpolation=cv2.INTER_NEAREST).astype(bool)
    img[~mask] = (img[~mask] * 0.45).astype(np.uint8)

    def px(uv: NDArray[np.float64]) -> NDArray[np.int32]:
        return np.rint((uv + 0.5) * scale - 0.5).astype(np.int32)

    cv2.polylines(img, [px(built.uv_outline).reshape(-1, 1, 2)], True, _OUTLINE_BGR, 1,
                  cv2.LINE_AA)
    for (u, v) in px(built.uv_out):
        cv2.circle(img, (int(u), int(v)), 1, _OUT_BGR, -1)
    for (u, v) in px(built.uv_in):
        cv2.circle(img, (int(u), int(v)), 1, _IN_BGR, -1)
    m = built.model
    lines = [
        f"{m.name}: S_in {m.n_in} pts (cyan), S_out {m.n_out} pts (magenta), outline (yellow)",
        f"size {m.size_mm[0]:.0f} x {m.size_mm[1]:.0f} mm, area {m.area_mm2:.0f} mm^2",
    ]
    colours = [_TEXT_BGR, _TEXT_BGR]
    q = built.quality
    if q is not None:
        lines.append(q.summary() + (": WARNING, see the build's message" if q.warning else ""))
        colours.append(_WARN_BGR if q.warning else _TEXT_BGR)
    for i, (text, colour) in enumerate(zip(lines, colours, strict=True)):
        draw_label(img, text, (8, 20 + 20 * i), colour)
    return img
