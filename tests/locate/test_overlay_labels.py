"""The overlay's labels (``locate --overlay``, the service's ``overlay.png``) are drawn once:
each panel's camera label and the caption, light on a dark outline that hugs the glyphs (issue
47: the labels showed twice, a few pixels apart)."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from photomodel.locate import draw_overlay
from photomodel.sim import hand_stereo_rig

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "image"))

from test_label import label_problems  # noqa: E402


def test_each_label_of_the_overlay_is_drawn_once() -> None:
    rig = hand_stereo_rig()
    width, height = rig.cam1.image_size
    grey = np.full((height, width, 3), 128, np.uint8)
    sheet = draw_overlay(None, rig, grey, grey.copy(), np.full((4, 4), np.nan),
                         caption="shirt: found  score 0.91")
    assert sheet.shape == (height + 28, 2 * width + 6, 3)
    for name, box in (("left label", sheet[:32, :width]),
                      ("right label", sheet[:32, width + 6:])):
        assert label_problems(box) == [], name
    caption = sheet[height:].copy()
    caption[caption.max(axis=2) < 60] = 128        # the bar is black: judge the text on grey
    assert (caption.min(axis=2) > 200).any()
    # the panels hold nothing but their label (no model): grey below the label rows
    assert (sheet[32:height, :width] == 128).all()
