"""``draw_label``: the text is drawn once, its dark outline hugging the glyphs (issue 47: the
overlay's labels were drawn twice, a few pixels apart, where a thick outline pass and the thin
text pass had different advances)."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from photomodel.image import draw_label

TEXT = "left (camera 2)"


def label_problems(img: np.ndarray) -> list[str]:
    """What is wrong with the one label drawn on mid-grey ``img``: dark outline pixels more
    than 2 px from any glyph pixel (a second, shifted copy of the text), an outline reaching
    further than the glyphs."""
    bright = (img.min(axis=2) > 160).astype(np.uint8)    # glyphs: lighter than the grey
    dark = img.max(axis=2) < 60
    if not bright.any() or not dark.any():
        return ["no label"]
    near = cv2.dilate(bright, np.ones((5, 5), np.uint8)).astype(bool)
    problems = []
    if (dark & ~near).any():
        problems.append(f"{int((dark & ~near).sum())} outline pixels away from the text")
    cols_b, cols_d = np.nonzero(bright.any(axis=0))[0], np.nonzero(dark.any(axis=0))[0]
    if abs(cols_d[0] - cols_b[0]) > 2 or abs(cols_d[-1] - cols_b[-1]) > 2:
        problems.append(f"outline spans columns {cols_d[[0, -1]]}, text {cols_b[[0, -1]]}")
    return problems


def test_the_text_is_drawn_once_on_a_hugging_outline() -> None:
    img = np.full((40, 200, 3), 128, np.uint8)
    draw_label(img, TEXT, (8, 20))
    assert label_problems(img) == []
    cols = np.nonzero((img.min(axis=2) > 160).any(axis=0))[0]
    width = cv2.getTextSize(TEXT, cv2.FONT_HERSHEY_SIMPLEX, 0.5, 1)[0][0]
    assert 7 <= cols[0] and cols[-1] <= 8 + width              # one copy, where measured


def test_a_thick_outline_pass_is_caught() -> None:
    """The check fails on the old drawing where the font's advance depends on thickness (and
    passes where it does not: OpenCV 4's Hershey fonts)."""
    img = np.full((40, 200, 3), 128, np.uint8)
    cv2.putText(img, TEXT, (8, 20), cv2.FONT_HERSHEY_SIMPLEX, 0.5, (0, 0, 0), 3, cv2.LINE_AA)
    cv2.putText(img, TEXT, (8, 20), cv2.FONT_HERSHEY_SIMPLEX, 0.5, (255, 255, 255), 1,
                cv2.LINE_AA)
    thin = cv2.getTextSize(TEXT, cv2.FONT_HERSHEY_SIMPLEX, 0.5, 1)[0][0]
    thick = cv2.getTextSize(TEXT, cv2.FONT_HERSHEY_SIMPLEX, 0.5, 3)[0][0]
    assert (label_problems(img) != []) == (thick - thin > 4)


def test_colour_and_labels_at_or_past_the_edges() -> None:
    img = np.full((30, 60, 3), 128, np.uint8)
    draw_label(img, TEXT, (40, 5), (80, 80, 255))     # mostly outside: clipped, no error
    draw_label(img, TEXT, (500, 500))                  # wholly outside: nothing drawn
    reddish = (img[..., 2] > 200) & (img[..., 0] < 120)
    assert reddish.any() and (img[25:, :] == 128).all()


@pytest.mark.parametrize("text", ["", " "])
def test_empty_text_draws_no_glyphs(text: str) -> None:
    img = np.full((30, 60, 3), 128, np.uint8)
    draw_label(img, text, (8, 20))
    assert (img == 128).all()
