"""Garments: silhouettes, anti-aliasing and the frame at the area centroid."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from photomodel.sim import GARMENT_SHAPES, garment_outline_mm, make_garment
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
