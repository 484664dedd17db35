"""Fabric and plane textures."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from photomodel.sim import (
    MODEL_GREEN_BGR,
    PlaneTexture,
    plaid_fabric,
    plain_fabric,
    table_plane,
    uniform_plane,
)


def _hsv(texture: PlaneTexture) -> np.ndarray:
    return cv2.cvtColor(texture.image_bgr, cv2.COLOR_BGR2HSV).reshape(-1, 3).astype(float)


def test_plaid_is_colourful_striped_and_not_green():
    tex = plaid_fabric((400, 300), rng=3)
    assert tex.image_bgr.shape == (300, 400, 3) and tex.alpha.min() == 1.0
    hsv = _hsv(tex)
    hue_hist = np.bincount((hsv[hsv[:, 1] > 80, 0] // 10).astype(int), minlength=18)
    assert (hue_hist > 0.05 * hue_hist.sum()).sum() >= 3  # several distinct hues
    green = (hsv[:, 0] > 45) & (hsv[:, 0] < 75) & (hsv[:, 1] > 60)
    assert green.mean() < 0.01
    # Stripes both ways: colour varies along rows and along columns.
    img = tex.image_bgr.astype(float)
    assert img.mean(axis=0).std(axis=0).max() > 10 and img.mean(axis=1).std(axis=0).max() > 10


def test_plain_fabric_is_one_colour_with_slight_grain():
    tex = plain_fabric((300, 200), (40, 60, 180), rng=1)
    img = tex.image_bgr.astype(float)
    np.testing.assert_allclose(img.reshape(-1, 3).mean(axis=0), (40, 60, 180), atol=0.3)
    assert 1.5 < img[..., 2].std() < 3.5


def test_uniform_planes():
    green = uniform_plane(rng=0)
    assert green.size_mm == (600.0, 480.0) and green.mm_per_px == 0.5
    np.testing.assert_allclose(green.origin_px, [599.5, 479.5])
    np.testing.assert_allclose(green.image_bgr.reshape(-1, 3).mean(axis=0), MODEL_GREEN_BGR,
                               atol=0.5)
    table = table_plane(rng=0)
    grey = table.image_bgr.astype(float).mean(axis=2)
    assert abs(grey.mean() - 128) < 2 and 3 < grey.std() < 8
    np.testing.assert_allclose(table.mm_from_px(table.px_from_mm([[12.5, -3.0]])), [[12.5, -3]])


@pytest.mark.parametrize("make", [
    lambda rng: plaid_fabric((120, 80), rng),
    lambda rng: plain_fabric((120, 80), (10, 20, 200), rng),
    lambda rng: uniform_plane(rng=rng, size_mm=(60, 40)),
    lambda rng: table_plane(rng, size_mm=(120, 80)),
])
def test_textures_are_deterministic_per_seed(make):
    a, b, c = make(7), make(7), make(8)
    np.testing.assert_array_equal(a.image_bgr, b.image_bgr)
    assert not np.array_equal(a.image_bgr, c.image_bgr)
    gen = np.random.default_rng(7)
    np.testing.assert_array_equal(make(gen).image_bgr, a.image_bgr)


def test_plane_texture_validates_its_fields():
    img = np.zeros((4, 5, 3), np.uint8)
    ok = np.ones((4, 5), np.float32)
    with pytest.raises(ValueError, match="image_bgr"):
        PlaneTexture(img.astype(float), ok, 1.0, (0, 0))
    with pytest.raises(ValueError, match="alpha"):
        PlaneTexture(img, np.ones((5, 4)), 1.0, (0, 0))
    with pytest.raises(ValueError, match="alpha"):
        PlaneTexture(img, ok * 2, 1.0, (0, 0))
    with pytest.raises(ValueError, match="mm_per_px"):
        PlaneTexture(img, ok, 0.0, (0, 0))
    with pytest.raises(ValueError, match="origin_px"):
        PlaneTexture(img, ok, 1.0, (0, 0, 0))
