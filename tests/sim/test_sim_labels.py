"""Printed labels on simulated garments: where the sticker goes, how large its modules are,
and what ``write_dataset(labels=True)`` writes (the reading is tested in
tests/identify/test_identify_labels.py)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("zxingcpp")

from photomodel.sim import (
    article_code,
    catalogue_garment,
    hand_stereo_rig,
    hand_table_pose,
    labelled_garment,
    random_label,
    write_dataset,
)
from photomodel.sim._labels import (
    MODULE_PX_RANGE,
    NOMINAL_PX_PER_MM,  # noqa: E402
)


def test_article_codes_are_deterministic_and_differ() -> None:
    assert article_code("No.5", 0) == article_code("No.5", 0)
    assert article_code("No.5", 0).startswith("PM-No.5-")
    assert len({article_code(f"No.{k}", 3) for k in range(1, 13)}) == 12
    assert article_code("No.5", 0) != article_code("No.5", 1)
    linear = article_code("No.5", 0, "Code128")
    assert linear.isdigit() and len(linear) == 10


@pytest.mark.parametrize("fmt", ["QRCode", "DataMatrix", "Code128"])
def test_the_sticker_lies_inside_the_silhouette_and_is_printed(fmt: str) -> None:
    garment = catalogue_garment("No.8")
    out = labelled_garment(garment, article_code("No.8", 0, fmt), fmt, 1.6, rng=4)
    label = out.label
    assert label is not None and label.format == fmt and out.name == garment.name
    tex = out.texture
    corners = tex.px_from_mm(label.sticker_corners_mm())
    u, v = np.rint(corners).astype(int).T
    assert np.all(tex.alpha[v, u] > 0.999)                  # every corner on the garment
    changed = np.any(tex.image_bgr != garment.texture.image_bgr, axis=-1)
    lo, hi = corners.min(axis=0) - 2, corners.max(axis=0) + 2
    rows, cols = np.nonzero(changed)
    assert changed.any() and np.all((cols >= lo[0]) & (cols <= hi[0])
                                    & (rows >= lo[1]) & (rows <= hi[1]))
    centre = np.rint(tex.px_from_mm(label.centre_mm)).astype(int)
    assert tex.image_bgr[centre[1] - 30:centre[1] + 30, centre[0] - 30:centre[0] + 30].min() < 60
    assert np.array_equal(tex.alpha, garment.texture.alpha)


def test_module_px_follows_the_module_size() -> None:
    rig = hand_stereo_rig()
    out = labelled_garment(catalogue_garment("No.1"), "PM-No.1-0001", "QRCode",
                           3.0 / NOMINAL_PX_PER_MM, where=(0.0, 10.0), rng=1, angle_deg=20.0)
    assert out.label is not None and out.label.centre_mm == (0.0, 10.0)
    truth = out.label.truth(rig, hand_table_pose(rig))
    assert truth["text"] == "PM-No.1-0001" and truth["in_view"] == [True, True]
    assert all(2.6 < px < 3.4 for px in truth["module_px"])
    corners = np.asarray(truth["corners_cam1"])
    sides = np.linalg.norm(np.roll(corners, -1, axis=0) - corners, axis=1)
    assert np.allclose(sides, sides.mean(), rtol=0.1)       # seen square-on: a square


def test_a_drawn_size_shrinks_until_it_fits_and_a_given_one_is_refused() -> None:
    small = catalogue_garment("No.3")                          # 130 x 110 mm
    lo_mm = MODULE_PX_RANGE[0] / NOMINAL_PX_PER_MM
    drawn = labelled_garment(small, "PM-No.3-0001", "QRCode", rng=2)
    assert drawn.label is not None and drawn.label.module_mm >= lo_mm * 0.999
    with pytest.raises(ValueError, match="does not fit on No.3"):
        labelled_garment(small, "PM-No.3-0001", "QRCode", 8.0, rng=2)
    with pytest.raises(ValueError, match="already carries a label"):
        labelled_garment(drawn, "again", "QRCode", rng=2)
    with pytest.raises(ValueError, match="module_mm"):
        labelled_garment(small, "x", "QRCode", -1.0)
    with pytest.raises(ValueError, match="format"):
        labelled_garment(small, "x", "NoSuchCode", 2.0)


def test_random_labels_are_the_seeds() -> None:
    garment = catalogue_garment("No.6")
    a = random_label(garment, "No.6", 7, rng=1).label
    b = random_label(garment, "No.6", 7, rng=1).label
    assert a is not None and b is not None
    assert (a.text, a.format, a.module_mm, a.centre_mm) == (b.text, b.format, b.module_mm,
                                                           b.centre_mm)
    assert a.text == article_code("No.6", 7, a.format)


def test_a_labelled_dataset_gives_each_scene_its_label(tmp_path: Path) -> None:
    out = tmp_path / "ds"
    write_dataset(out, ["No.8"], ["paper"], scenes=1, seed=3, labels=True)
    truth = json.loads((out / "truth.json").read_text())
    label = truth["paper_No.8_0000"]["label"]
    manifest = json.loads((out / "dataset.json").read_text())
    assert label["text"] == manifest["garments"]["No.8"]["label"]["text"]
    assert label["text"] == article_code("No.8", 3, label["format"])
    assert len(label["module_px"]) == 2 and all(px > 1.0 for px in label["module_px"])
    assert np.asarray(label["corners_cam2"]).shape == (4, 2)
