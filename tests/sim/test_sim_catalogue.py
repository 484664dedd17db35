"""The built-in catalogue of 12 garments, and garments cut from a user's photo and mask."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from photomodel.errors import InputError
from photomodel.sim import (
    CATALOGUE,
    FABRICS,
    GARMENT_SHAPES,
    catalogue_garment,
    garment_from_image,
    garment_names,
    load_garment,
)
from photomodel.sim._catalogue import _build

NAMES = tuple(f"No.{i}" for i in range(1, 13))


def _alpha_centroid(alpha: np.ndarray) -> np.ndarray:
    v, u = np.indices(alpha.shape)
    a = alpha.astype(np.float64)
    return np.array([(a * u).sum(), (a * v).sum()]) / a.sum()


def _bbox_px(alpha: np.ndarray) -> tuple[int, int]:
    cols = np.nonzero(alpha.max(axis=0) > 0.5)[0]
    rows = np.nonzero(alpha.max(axis=1) > 0.5)[0]
    return cols[-1] - cols[0] + 1, rows[-1] - rows[0] + 1


def _inside_hsv(name: str) -> np.ndarray:
    g = catalogue_garment(name)
    hsv = cv2.cvtColor(np.ascontiguousarray(g.texture.image_bgr), cv2.COLOR_BGR2HSV)
    return hsv[g.texture.alpha > 0.99].astype(float)


def _distinct_hues(hsv: np.ndarray) -> int:
    """Number of 20-degree hue bins that hold over 5 % of the saturated pixels."""
    hues = hsv[hsv[:, 1] > 80, 0]
    hist = np.bincount((hues // 10).astype(int), minlength=18)
    return int((hist > 0.05 * hist.sum()).sum())


def test_names_are_no1_to_no12_in_order():
    assert garment_names() == NAMES
    assert tuple(CATALOGUE) == NAMES
    assert all(spec.name == key for key, spec in CATALOGUE.items())


def test_catalogue_covers_shapes_fabrics_and_the_hard_colours():
    specs = CATALOGUE.values()
    assert {s.fabric for s in specs} == set(FABRICS)
    shapes = {s.shape for s in specs}
    assert shapes <= set(GARMENT_SHAPES)
    assert {"tshirt", "longsleeve", "trousers", "shorts", "towel", "skirt", "sock",
            "dress"} <= shapes
    assert any(s.fabric == "photo" and s.photo for s in specs)
    assert all(s.size_mm[0] <= 250 and s.size_mm[1] <= 200 for s in specs)


@pytest.mark.parametrize("name", NAMES)
def test_every_garment_builds_to_its_spec(name):
    spec = CATALOGUE[name]
    g = catalogue_garment(name)
    tex = g.texture
    assert (g.name, g.shape, g.fabric) == (name, spec.shape, spec.fabric)
    assert g.size_mm == spec.size_mm and g.description == spec.description
    assert tex.mm_per_px == 0.5 and tex.image_bgr.dtype == np.uint8
    w_px, h_px = _bbox_px(tex.alpha)
    assert abs(w_px * tex.mm_per_px - g.size_mm[0]) <= 1.5
    assert abs(h_px * tex.mm_per_px - g.size_mm[1]) <= 1.5
    np.testing.assert_allclose(_alpha_centroid(tex.alpha), tex.origin_px, atol=0.01)
    assert tex.alpha[0].max() == tex.alpha[-1].max() == 0.0
    # Cached, shared and read-only.
    assert catalogue_garment(name) is g
    with pytest.raises(ValueError):
        tex.image_bgr[0, 0, 0] = 1


@pytest.mark.parametrize("name", NAMES)
def test_builds_are_byte_identical(name):
    cached = catalogue_garment(name)
    fresh = _build.__wrapped__(name, 0.5)
    assert fresh is not cached
    assert fresh.texture.image_bgr.tobytes() == cached.texture.image_bgr.tobytes()
    assert fresh.texture.alpha.tobytes() == cached.texture.alpha.tobytes()
    np.testing.assert_array_equal(fresh.texture.origin_px, cached.texture.origin_px)


def test_other_resolution():
    coarse, fine = catalogue_garment("No.1", mm_per_px=1.0), catalogue_garment("No.1")
    assert coarse.texture.mm_per_px == 1.0 and coarse.size_mm == fine.size_mm
    w_px, h_px = _bbox_px(coarse.texture.alpha)
    assert (w_px, h_px) == pytest.approx(coarse.size_mm, abs=1.5)


def test_no3_is_the_small_light_colourful_one():
    area = {n: CATALOGUE[n].size_mm[0] * CATALOGUE[n].size_mm[1] for n in NAMES}
    assert min(area, key=area.get) == "No.3"
    assert CATALOGUE["No.3"].size_mm == pytest.approx((130, 110), abs=10)
    hsv = _inside_hsv("No.3")
    assert _distinct_hues(hsv) >= 3
    assert np.median(hsv[:, 2]) > 200  # light


def test_dark_white_and_grey_plain_garments_exist():
    plain = {n: _inside_hsv(n) for n in NAMES if CATALOGUE[n].fabric == "plain"}
    med = {n: np.median(hsv, axis=0) for n, hsv in plain.items()}
    assert any(v < 90 for _, _, v in med.values()), "no dark (low-value) garment"
    assert any(s < 25 and v > 215 for _, s, v in med.values()), "no white garment"
    assert any(s < 10 and 60 < v < 215 for _, s, v in med.values()), "no grey garment"


@pytest.mark.parametrize("name", NAMES)
def test_garments_keep_off_the_planes_green(name):
    hsv = _inside_hsv(name)
    green = (hsv[:, 1] > 60) & (hsv[:, 0] > 40) & (hsv[:, 0] < 75)
    assert green.mean() < 0.01


def test_unknown_name_and_bad_resolution():
    with pytest.raises(ValueError, match=r"No\.1, No\.2.*No\.12"):
        catalogue_garment("No.13")
    with pytest.raises(ValueError, match="mm_per_px"):
        catalogue_garment("No.1", mm_per_px=0.0)


# --- User garments --------------------------------------------------------------------------


def _photo(seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """A 320 x 240 photo: a red-orange blob with a blue patch, on pure green; and its mask."""
    rng = np.random.default_rng(seed)
    image = np.zeros((240, 320, 3), np.uint8)
    image[:] = (0, 255, 0)
    mask = np.zeros((240, 320), np.uint8)
    cv2.ellipse(mask, (150, 130), (110, 70), 20.0, 0, 360, 255, -1)
    cv2.rectangle(mask, (60, 40), (120, 110), 255, -1)
    garment = np.clip(rng.normal((30, 60, 220), 8, (240, 320, 3)), 0, 255).astype(np.uint8)
    garment[100:160, 120:200] = (200, 80, 20)
    image[mask > 0] = garment[mask > 0]
    return image, mask


def test_garment_from_image_round_trip():
    image, mask = _photo()
    cols = np.nonzero(mask.any(axis=0))[0]
    rows = np.nonzero(mask.any(axis=1))[0]
    bw, bh = cols[-1] - cols[0] + 1, rows[-1] - rows[0] + 1
    g = garment_from_image(image, mask, 180.0, "mine", description="a test")
    tex, src_mm = g.texture, 180.0 / bw
    assert (g.name, g.shape, g.fabric, g.description) == ("mine", "user", "photo", "a test")
    assert tex.mm_per_px == pytest.approx(src_mm)
    assert g.size_mm == pytest.approx((180.0, bh * src_mm))
    assert tex.alpha.sum() * src_mm**2 == pytest.approx((mask > 0).sum() * src_mm**2, rel=1e-3)
    assert _bbox_px(tex.alpha) == (bw, bh)
    np.testing.assert_allclose(_alpha_centroid(tex.alpha), tex.origin_px, atol=1e-6)
    # 4-pixel transparent margin, opaque interior, soft edges.
    a = tex.alpha
    assert a[:4].max() == a[-4:].max() == a[:, :4].max() == a[:, -4:].max() == 0.0
    inner = cv2.erode((mask > 0).astype(np.uint8), np.ones((5, 5), np.uint8))
    crop = inner[rows[0]:rows[-1] + 1, cols[0]:cols[-1] + 1]
    assert (a[5:-5, 5:-5][crop > 0] == 1.0).all()
    assert ((a > 0.05) & (a < 0.95)).sum() > 100
    # Garment colours are the photo's; the green background never bleeds in.
    np.testing.assert_array_equal(tex.image_bgr[5:-5, 5:-5][crop > 0],
                                  image[rows[0]:rows[-1] + 1, cols[0]:cols[-1] + 1][crop > 0])
    assert not np.all(tex.image_bgr == (0, 255, 0), axis=-1).any()


@pytest.mark.parametrize("mm_per_px", [0.5, 0.2])
def test_garment_from_image_resampled(mm_per_px):
    image, mask = _photo()
    bw = np.ptp(np.nonzero(mask.any(axis=0))[0]) + 1
    src_mm = 180.0 / bw  # 0.8 mm per photo pixel: 0.5 downsamples, 0.2 upsamples
    g = garment_from_image(image, mask.astype(bool), 180.0, "mine", mm_per_px=mm_per_px)
    tex = g.texture
    assert tex.mm_per_px == pytest.approx(mm_per_px, rel=0.01)
    assert g.size_mm[0] == 180.0
    w_px, h_px = _bbox_px(tex.alpha)
    assert w_px * tex.mm_per_px == pytest.approx(180.0, abs=1.5)
    assert h_px * tex.mm_per_px == pytest.approx(g.size_mm[1], abs=1.5)
    area = tex.alpha.sum() * tex.mm_per_px**2
    assert area == pytest.approx((mask > 0).sum() * src_mm**2, rel=0.01)
    np.testing.assert_allclose(_alpha_centroid(tex.alpha), tex.origin_px, atol=1e-6)


def test_garment_from_image_names_bad_arguments():
    image, mask = _photo()
    with pytest.raises(ValueError, match="image_bgr"):
        garment_from_image(image.astype(float), mask, 100.0, "g")
    with pytest.raises(ValueError, match="image_bgr"):
        garment_from_image(image[..., 0], mask, 100.0, "g")
    with pytest.raises(ValueError, match="mask"):
        garment_from_image(image, mask[:-1], 100.0, "g")
    with pytest.raises(ValueError, match="mask"):
        garment_from_image(image, np.zeros_like(mask), 100.0, "g")
    with pytest.raises(ValueError, match="mask"):
        garment_from_image(image, mask.astype(float), 100.0, "g")
    for width in (0.0, -5.0, float("nan"), float("inf")):
        with pytest.raises(ValueError, match="width_mm"):
            garment_from_image(image, mask, width, "g")
    with pytest.raises(ValueError, match="name"):
        garment_from_image(image, mask, 100.0, "")
    with pytest.raises(ValueError, match="mm_per_px"):
        garment_from_image(image, mask, 100.0, "g", mm_per_px=-1.0)


def test_load_garment_reads_files(tmp_path):
    image, mask = _photo()
    cv2.imwrite(str(tmp_path / "shirt.png"), image)
    cv2.imwrite(str(tmp_path / "shirt_mask.png"), mask)
    g = load_garment(tmp_path / "shirt.png", tmp_path / "shirt_mask.png", 180.0)
    ref = garment_from_image(image, mask, 180.0, "shirt")
    assert g.name == "shirt" and g.size_mm == ref.size_mm
    np.testing.assert_array_equal(g.texture.image_bgr, ref.texture.image_bgr)
    np.testing.assert_array_equal(g.texture.alpha, ref.texture.alpha)


def test_load_garment_errors_name_the_file(tmp_path):
    image, mask = _photo()
    photo, mask_file = tmp_path / "shirt.png", tmp_path / "mask.png"
    cv2.imwrite(str(photo), image)

    def fails(mask_path, width=180.0, source=None):
        with pytest.raises(InputError) as err:
            load_garment(photo, mask_path, width)
        assert err.value.source == str(source or mask_path)
        return err.value.problem

    assert "not found" in fails(tmp_path / "missing.png")
    mask_file.write_bytes(b"not a png at all")
    assert "readable" in fails(mask_file)
    cv2.imwrite(str(mask_file), mask[:100])
    assert "320x100" in fails(mask_file) and "320x240" in fails(mask_file)
    cv2.imwrite(str(mask_file), np.zeros_like(mask))
    assert "empty" in fails(mask_file)
    cv2.imwrite(str(mask_file), mask)
    assert "positive" in fails(mask_file, width=0.0, source="width_mm")
    with pytest.raises(InputError) as err:
        load_garment(tmp_path / "nophoto.png", mask_file, 180.0)
    assert err.value.source == str(tmp_path / "nophoto.png")
