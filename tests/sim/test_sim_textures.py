"""Fabric and plane textures."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from photomodel.sim import (
    PlaneTexture,
    camo_fabric,
    dot_fabric,
    photo_fabric,
    plaid_fabric,
    plain_fabric,
    print_fabric,
    stripe_fabric,
    uniform_plane,
)
from photomodel.sim._textures import MODEL_GREEN_BGR, PHOTO_PRINTS, photo_print_image, table_plane


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
    lambda rng: stripe_fabric((120, 80), rng),
    lambda rng: dot_fabric((120, 80), rng),
    lambda rng: print_fabric((120, 80), rng),
    lambda rng: camo_fabric((120, 80), rng),
    lambda rng: photo_fabric((120, 80), rng),
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


# --- More fabrics ---------------------------------------------------------------------------


def _saturated_green(texture: PlaneTexture) -> float:
    hsv = _hsv(texture)
    return float(((hsv[:, 0] > 40) & (hsv[:, 0] < 75) & (hsv[:, 1] > 60)).mean())


def _n_hues(texture: PlaneTexture) -> int:
    hsv = _hsv(texture)
    hist = np.bincount((hsv[hsv[:, 1] > 80, 0] // 10).astype(int), minlength=18)
    return int((hist > 0.05 * hist.sum()).sum())


@pytest.mark.parametrize("make", [stripe_fabric, dot_fabric, print_fabric, camo_fabric])
@pytest.mark.parametrize("seed", range(4))
def test_drawn_fabrics_keep_off_green(make, seed):
    tex = make((240, 200), seed)
    assert tex.image_bgr.shape == (200, 240, 3) and tex.alpha.min() == 1.0
    np.testing.assert_allclose(tex.origin_px, (119.5, 99.5))
    assert _saturated_green(tex) < 0.005


@pytest.mark.parametrize("vertical", [True, False])
def test_stripes_run_one_way_with_several_colours(vertical):
    tex = stripe_fabric((400, 300), 5, n_colours=3, vertical=vertical,
                        ground_bgr=(240, 240, 240), mm_per_px=0.5)
    img = tex.image_bgr.astype(float)
    across, along = (0, 1) if vertical else (1, 0)
    # Colour changes across the stripes, only grain along them.
    assert img.mean(axis=across).std(axis=0).max() > 20
    assert img.mean(axis=along).std(axis=0).max() < 2
    line = img.mean(axis=across)  # (L, 3), one value per stripe position
    colours = {tuple(np.round(c / 16)) for c in line}
    assert len(colours) >= 3
    assert np.mean(np.abs(line - 240).max(axis=1) < 8) > 0.25  # ground stripes


def test_stripe_widths_are_in_mm():
    fine = stripe_fabric((800, 10), 1, vertical=True, mm_per_px=0.25, weave_sigma=0.0)
    coarse = stripe_fabric((400, 10), 1, vertical=True, mm_per_px=0.5, weave_sigma=0.0)

    def changes(tex):
        row = tex.image_bgr[5].astype(int)
        return int((np.abs(np.diff(row, axis=0)).max(axis=1) > 30).sum())

    assert changes(fine) == pytest.approx(changes(coarse), abs=2)


def test_dots_are_round_antialiased_and_sized_in_mm():
    tex = dot_fabric((400, 400), 0, ground_bgr=(40, 40, 200), n_dot_colours=1,
                     radius_mm=4.0, mm_per_px=0.5, weave_sigma=0.0)
    img = tex.image_bgr.astype(float)
    dist = np.abs(img - (40, 40, 200)).max(axis=-1)
    dot = dist > 100
    assert 0.05 < dot.mean() < 0.45
    assert ((dist > 20) & (dist < 150)).sum() > 200  # soft edges
    n, labels, stats, _ = cv2.connectedComponentsWithStats(dot.astype(np.uint8))
    inner = stats[1:][(stats[1:, 0] > 0) & (stats[1:, 1] > 0)
                      & (stats[1:, 0] + stats[1:, 2] < 400) & (stats[1:, 1] + stats[1:, 3] < 400)]
    # Radius 4 mm = 8 px: a disc of about pi * 8^2 pixels, as wide as it is tall.
    assert np.median(inner[:, 4]) == pytest.approx(np.pi * 64, rel=0.1)
    np.testing.assert_allclose(inner[:, 2], inner[:, 3], atol=1)
    # A dark or bright ground gets white dots.
    assert img[dot].mean(axis=0).min() > 200


def test_print_and_camo_are_colourful_or_shaded():
    flowers = print_fabric((400, 300), 3, ground_bgr=(235, 240, 245))
    assert _n_hues(flowers) >= 3
    ground = np.abs(flowers.image_bgr.astype(float) - (235, 240, 245)).max(axis=-1) < 12
    assert 0.3 < ground.mean() < 0.95
    camo = camo_fabric((400, 300), 3, n_colours=4)
    grey = camo.image_bgr.astype(float).mean(axis=-1)
    levels = np.histogram(grey, bins=16, range=(0, 256))[0]
    assert (levels > 0.05 * grey.size).sum() >= 3  # several distinct shades
    # Blotches, not noise: neighbouring pixels mostly alike.
    assert np.mean(np.abs(np.diff(grey, axis=1)) < 10) > 0.9


def test_photo_fabric_reads_bundled_files_without_network(monkeypatch):
    import importlib.util
    import socket
    from pathlib import Path

    def no_network(*args, **kwargs):
        raise OSError("network disabled in this test")

    monkeypatch.setattr(socket, "socket", no_network)
    monkeypatch.setattr(socket, "create_connection", no_network)
    photo_print_image.cache_clear()
    data_dir = Path(next(iter(importlib.util.find_spec("skimage").submodule_search_locations)))
    for name in PHOTO_PRINTS:
        picture = photo_print_image(name)
        assert picture.ndim == 3 and picture.dtype == np.uint8 and not picture.flags.writeable
        assert any((data_dir / "data").glob(f"{name}.*"))
        tex = photo_fabric((300, 200), 1, photo=name)
        assert tex.image_bgr.shape == (200, 300, 3)
        assert tex.image_bgr.astype(float).std() > 15
        assert _saturated_green(tex) < 0.01


def test_photo_fabric_covers_or_tiles():
    one = photo_fabric((300, 200), 4, photo="astronaut", weave_sigma=0.0)
    tiled = photo_fabric((600, 200), 4, photo="astronaut", tile_mm=50.0, mm_per_px=0.5,
                         weave_sigma=0.0)
    # Tiles of 100 px, every other one mirrored: a period of 200 px.
    a = tiled.image_bgr.astype(float)
    assert np.abs(a[:, :400] - a[:, 200:]).mean() < 1.0
    assert np.abs(a[:, :300] - a[:, 100:400]).mean() > 10
    # One picture, scaled up: smooth (no repeat).
    b = one.image_bgr.astype(float)
    assert np.abs(b[:, :200] - b[:, 100:]).mean() > 10


def test_new_fabrics_name_bad_arguments():
    with pytest.raises(ValueError, match="n_colours"):
        stripe_fabric((10, 10), 0, n_colours=1)
    with pytest.raises(ValueError, match="stripe_mm"):
        stripe_fabric((10, 10), 0, stripe_mm=(5.0, 1.0))
    with pytest.raises(ValueError, match="ground_bgr"):
        stripe_fabric((10, 10), 0, ground_bgr=(1.0, 2.0))
    with pytest.raises(ValueError, match="n_dot_colours"):
        dot_fabric((10, 10), 0, n_dot_colours=3)
    with pytest.raises(ValueError, match="radius_mm"):
        dot_fabric((10, 10), 0, radius_mm=0.0)
    with pytest.raises(ValueError, match="motif_mm"):
        print_fabric((10, 10), 0, motif_mm=-1.0)
    with pytest.raises(ValueError, match="n_colours"):
        camo_fabric((10, 10), 0, n_colours=9)
    with pytest.raises(ValueError, match="photo"):
        photo_fabric((10, 10), 0, photo="lena")
    with pytest.raises(ValueError, match="tile_mm"):
        photo_fabric((10, 10), 0, photo="coffee", tile_mm=0.0)
    with pytest.raises(ValueError, match="size_px"):
        dot_fabric((0, 10), 0)
