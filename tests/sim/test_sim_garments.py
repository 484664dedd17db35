"""Garments: silhouettes, anti-aliasing and the frame at the area centroid."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from photomodel.sim import FABRICS, GARMENT_SHAPES, garment_outline_mm, make_garment
from photomodel.sim._garments import _MARGIN_PX


def _alpha_centroid(alpha: np.ndarray) -> np.ndarray:
    v, u = np.indices(alpha.shape)
    return np.array([(alpha * u).sum(), (alpha * v).sum()]) / alpha.sum()


def _polygon_centroid(pts: np.ndarray) -> np.ndarray:
    x, y = pts[:, 0], pts[:, 1]
    xn, yn = np.roll(x, -1), np.roll(y, -1)
    cross = x * yn - xn * y
    area = cross.sum() / 2
    return np.array([((x + xn) * cross).sum(), ((y + yn) * cross).sum()]) / (6 * area)


@pytest.mark.parametrize("shape", GARMENT_SHAPES)
@pytest.mark.parametrize("fabric", ["plaid", "plain"])
def test_origin_is_the_silhouette_area_centroid(shape, fabric):
    g = make_garment(shape, fabric, (230.0, 190.0), rng=4)
    tex = g.texture
    np.testing.assert_allclose(_alpha_centroid(tex.alpha.astype(float)), tex.origin_px, atol=0.01)
    # ... which is the outline polygon's own centroid (independent computation), up to the
    # rasteriser rounding vertices to the 4x grid (half a fine pixel = 0.125 texture pixel).
    outline = garment_outline_mm(shape, g.size_mm)
    poly_px = outline / tex.mm_per_px + (_MARGIN_PX - 0.5)
    np.testing.assert_allclose(_polygon_centroid(poly_px), tex.origin_px, atol=0.2)


@pytest.mark.parametrize("shape", GARMENT_SHAPES)
def test_silhouette_size_and_antialiasing(shape):
    g = make_garment(shape, "plain", (250.0, 200.0), rng=0, mm_per_px=0.5)
    alpha = g.texture.alpha
    assert g.size_mm == (250.0, 200.0) and g.name == f"{shape}-plain"
    cols, rows = np.nonzero(alpha.max(axis=0) > 0.5)[0], np.nonzero(alpha.max(axis=1) > 0.5)[0]
    assert cols[-1] - cols[0] + 1 == pytest.approx(500, abs=1)
    assert rows[-1] - rows[0] + 1 == pytest.approx(400, abs=1)
    edge = (alpha > 0.02) & (alpha < 0.98)
    assert edge.sum() > 0.5 * cv2.findContours((alpha > 0.5).astype(np.uint8),
                                               cv2.RETR_EXTERNAL,
                                               cv2.CHAIN_APPROX_NONE)[0][0].shape[0]
    assert alpha[0].max() == alpha[-1].max() == alpha[:, 0].max() == alpha[:, -1].max() == 0


def test_tshirt_is_not_half_turn_symmetric():
    alpha = make_garment("tshirt", "plain", (220, 200), rng=0).texture.alpha > 0.5
    # Rotate 180 degrees about the area centroid and compare silhouettes.
    v, u = np.nonzero(alpha)
    cu, cv = u.mean(), v.mean()
    ru, rv = np.rint(2 * cu - u).astype(int), np.rint(2 * cv - v).astype(int)
    inside = (ru >= 0) & (rv >= 0) & (ru < alpha.shape[1]) & (rv < alpha.shape[0])
    overlap = alpha[rv[inside], ru[inside]].sum() / alpha.sum()
    assert overlap < 0.85


def test_plain_colour_and_determinism():
    g = make_garment("towel", "plain", (100, 80), rng=1, colour_bgr=(30, 40, 200))
    inside = g.texture.alpha > 0.99
    np.testing.assert_allclose(g.texture.image_bgr[inside].mean(axis=0), (30, 40, 200), atol=0.5)
    a, b, c = (make_garment("tshirt", "plaid", (120, 100), rng=s) for s in (5, 5, 6))
    np.testing.assert_array_equal(a.texture.image_bgr, b.texture.image_bgr)
    assert not np.array_equal(a.texture.image_bgr, c.texture.image_bgr)


def test_bad_arguments_are_named():
    with pytest.raises(ValueError, match="shape"):
        make_garment("hat", "plain")
    with pytest.raises(ValueError, match="fabric"):
        make_garment("towel", "silk")
    with pytest.raises(ValueError, match="size_mm"):
        make_garment("towel", "plain", (0.0, 10.0))


# --- All silhouettes and fabrics ------------------------------------------------------------


def _segments_cross(pts: np.ndarray) -> bool:
    """Whether any two non-adjacent edges of a closed polygon (N, 2) intersect or touch."""
    a, b = pts, np.roll(pts, -1, axis=0)
    n = len(pts)
    i, j = np.triu_indices(n, k=2)
    keep = (j - i) % n != n - 1  # the last edge is adjacent to the first
    i, j = i[keep], j[keep]

    def orient(p, q, r):
        return np.sign((q[:, 0] - p[:, 0]) * (r[:, 1] - p[:, 1])
                       - (q[:, 1] - p[:, 1]) * (r[:, 0] - p[:, 0]))

    def on_segment(p, q, r):  # r, collinear with p-q, lies within the segment's box
        lo, hi = np.minimum(p, q), np.maximum(p, q)
        return np.all((r >= lo) & (r <= hi), axis=1)

    o1, o2 = orient(a[i], b[i], a[j]), orient(a[i], b[i], b[j])
    o3, o4 = orient(a[j], b[j], a[i]), orient(a[j], b[j], b[i])
    proper = (o1 * o2 < 0) & (o3 * o4 < 0)
    touch = (((o1 == 0) & on_segment(a[i], b[i], a[j])) | ((o2 == 0) & on_segment(a[i], b[i], b[j]))
             | ((o3 == 0) & on_segment(a[j], b[j], a[i]))
             | ((o4 == 0) & on_segment(a[j], b[j], b[i])))
    return bool(np.any(proper | touch))


def test_segment_crossing_check_can_fail():
    bowtie = np.array([(0.0, 0.0), (1.0, 1.0), (1.0, 0.0), (0.0, 1.0)])
    assert _segments_cross(bowtie)
    pinched = np.array([(0.0, 0.0), (2.0, 0.0), (1.0, 1.0), (2.0, 2.0), (0.0, 2.0), (1.0, 1.0)])
    assert _segments_cross(pinched)  # touches itself at (1, 1)
    assert not _segments_cross(np.array([(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)]))


@pytest.mark.parametrize("shape", GARMENT_SHAPES)
def test_outlines_are_simple_clockwise_and_fill_their_box(shape):
    size = (230.0, 190.0)
    pts = garment_outline_mm(shape, size)
    assert pts.ndim == 2 and pts.shape[1] == 2 and len(pts) >= 4
    np.testing.assert_allclose(pts.min(axis=0), (0, 0), atol=1e-9)
    np.testing.assert_allclose(pts.max(axis=0), size, atol=1e-9)
    x, y = pts[:, 0], pts[:, 1]
    assert (x * np.roll(y, -1) - np.roll(x, -1) * y).sum() > 0  # clockwise on screen (y down)
    assert np.all(np.linalg.norm(pts - np.roll(pts, -1, axis=0), axis=1) > 1e-6)
    assert not _segments_cross(pts)
    # One connected silhouette without holes.
    alpha = make_garment(shape, "plain", size, rng=0, mm_per_px=1.0).texture.alpha > 0.5
    n_labels, _ = cv2.connectedComponents(alpha.astype(np.uint8))
    n_background, _ = cv2.connectedComponents((~alpha).astype(np.uint8))
    assert n_labels == 2 and n_background == 2


def test_original_outlines_are_unchanged():
    # Regression values of the first three shapes (other tests and datasets rely on them).
    expected = {"tshirt": (24, 2760.0, 958.72698595), "towel": (40, 4600.0, 3800.0),
                "trousers": (9, 1035.0, 931.0)}
    for shape, (n, sx, sy) in expected.items():
        pts = garment_outline_mm(shape, (230.0, 190.0))
        assert len(pts) == n
        np.testing.assert_allclose(pts.sum(axis=0), (sx, sy), rtol=1e-9)


def test_shapes_differ_from_each_other():
    masks = {s: make_garment(s, "plain", (200, 180), rng=0, mm_per_px=1.0).texture.alpha > 0.5
             for s in GARMENT_SHAPES}
    for s in GARMENT_SHAPES:
        for t in GARMENT_SHAPES:
            if s < t:
                iou = (masks[s] & masks[t]).sum() / (masks[s] | masks[t]).sum()
                assert iou < 0.93, (s, t, iou)


@pytest.mark.parametrize("fabric", FABRICS)
def test_every_fabric_makes_a_garment(fabric):
    g = make_garment("tshirt", fabric, (120.0, 100.0), rng=3, description="d")
    tex = g.texture
    assert (g.shape, g.fabric, g.description, g.name) == ("tshirt", fabric, "d",
                                                         f"tshirt-{fabric}")
    assert tex.image_bgr.shape == (208, 248, 3) and tex.image_bgr.dtype == np.uint8
    np.testing.assert_allclose(_alpha_centroid(tex.alpha.astype(float)), tex.origin_px,
                               atol=0.01)
    again = make_garment("tshirt", fabric, (120.0, 100.0), rng=3)
    np.testing.assert_array_equal(again.texture.image_bgr, tex.image_bgr)
    inside = tex.image_bgr[tex.alpha > 0.99].astype(float)
    # Patterned fabrics vary far beyond the weave's grain.
    assert (inside.std(axis=0).max() > 15) == (fabric != "plain")


@pytest.mark.parametrize("fabric", ["stripes", "dots", "print"])
def test_colour_is_the_ground_of_patterned_fabrics(fabric):
    ground = (235, 238, 240)
    g = make_garment("towel", fabric, (150.0, 120.0), rng=2, colour_bgr=ground)
    inside = g.texture.image_bgr[g.texture.alpha > 0.99].astype(float)
    near = np.abs(inside - ground).max(axis=1) < 12
    assert near.mean() > 0.3


def test_photo_garment_uses_the_named_picture():
    a = make_garment("towel", "photo", (150.0, 120.0), rng=2, photo="coffee")
    b = make_garment("towel", "photo", (150.0, 120.0), rng=2, photo="rocket")
    assert not np.array_equal(a.texture.image_bgr, b.texture.image_bgr)
    with pytest.raises(ValueError, match="photo"):
        make_garment("towel", "photo", photo="mona-lisa")
