"""Bilinear sampling at any number of points (cv2.remap alone takes at most 32767 a side)."""

from __future__ import annotations

import numpy as np
import pytest

from photomodel.image import sample_bilinear


@pytest.mark.parametrize("channels", [0, 1, 3])
@pytest.mark.parametrize("n", [0, 1, 4097, 40_000])
def test_samples_equal_the_bilinear_formula(n: int, channels: int) -> None:
    rng = np.random.default_rng(n + channels)
    shape = (50, 70) if channels == 0 else (50, 70, channels)
    image = rng.random(shape, dtype=np.float32)
    uv = rng.uniform([0, 0], [68.999, 48.999], size=(n, 2))
    got = sample_bilinear(image, uv)
    assert got.shape == (n, max(channels, 1))
    assert got.dtype == np.float32
    u0, v0 = np.floor(uv).astype(int).T
    a, b = (uv - np.floor(uv)).T
    img = image.reshape(50, 70, -1)
    want = ((1 - a) * (1 - b))[:, None] * img[v0, u0] + (a * (1 - b))[:, None] * img[v0, u0 + 1] \
        + ((1 - a) * b)[:, None] * img[v0 + 1, u0] + (a * b)[:, None] * img[v0 + 1, u0 + 1]
    np.testing.assert_allclose(got, want, atol=2e-3)  # OpenCV's 5-bit interpolation weights


def test_points_outside_take_the_border() -> None:
    image = np.arange(12, dtype=np.uint8).reshape(3, 4, 1).repeat(3, axis=2)
    got = sample_bilinear(image, np.array([[-5.0, -5.0], [10.0, 10.0]]))
    assert got.tolist() == [[0, 0, 0], [11, 11, 11]]
