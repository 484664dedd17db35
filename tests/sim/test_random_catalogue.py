"""The simulated catalogue ``cat-00000`` ... : deterministic articles, designed look-alike pairs
that differ in exactly one respect, no other pair practically identical, a clothing mix."""

from __future__ import annotations

import hashlib
import json
import subprocess
import sys
from collections import defaultdict
from pathlib import Path

import cv2
import numpy as np
import pytest

from photomodel.sim import (
    FABRICS,
    GARMENT_SHAPES,
    MAX_CATALOGUE,
    GarmentSpec,
    catalogue_garment,
    catalogue_names,
    catalogue_spec,
    expand_garments,
    lookalike_of,
    write_dataset,
)
from photomodel.sim import _random_catalogue as random_catalogue
from photomodel.sim._catalogue import _build
from photomodel.sim._textures import PLAIN_HUES

CHECKED = 2000  # articles whose pairs the tests compare


@pytest.fixture(scope="module")
def specs() -> list[GarmentSpec]:
    return [catalogue_spec(i) for i in range(CHECKED)]


def _hsv(bgr: tuple[int, int, int]) -> tuple[float, float, float]:
    h, s, v = cv2.cvtColor(np.uint8([[bgr]]), cv2.COLOR_BGR2HSV)[0, 0]
    return float(h), float(s), float(v)


def _hue_apart(a: float, b: float) -> float:
    """OpenCV hue units (2 degrees each) between two hues, around the circle."""
    d = abs(a - b) % 180.0
    return min(d, 180.0 - d)


def _texture_digest(name: str) -> str:
    """Digest of a catalogue garment's texture, built afresh (not from the cache)."""
    g = _build.__wrapped__(name, 0.5)  # type: ignore[attr-defined]
    return hashlib.sha256(g.texture.image_bgr.tobytes() + g.texture.alpha.tobytes()).hexdigest()


# --- names and determinism -------------------------------------------------------------------


def test_names() -> None:
    assert MAX_CATALOGUE == 100_000
    assert catalogue_names(3) == ("cat-00000", "cat-00001", "cat-00002")
    assert catalogue_names(0) == ()
    assert catalogue_spec(42).name == "cat-00042"
    for bad in (-1, MAX_CATALOGUE + 1, 2.0, True, "3"):
        with pytest.raises(ValueError, match="n: expected an integer from 0 to 100000"):
            catalogue_names(bad)  # type: ignore[arg-type]
    for bad in (-1, MAX_CATALOGUE, 1.5):
        with pytest.raises(ValueError, match="index"):
            catalogue_spec(bad)  # type: ignore[arg-type]
    for bad in ("cat-100000", "cat-1", "No.1", "cat-0000a"):
        with pytest.raises(ValueError, match="cat-00000 to cat-99999"):
            lookalike_of(bad)


def test_an_article_does_not_depend_on_how_many_are_asked_for(
        specs: list[GarmentSpec], monkeypatch: pytest.MonkeyPatch) -> None:
    among_200 = specs[:200]
    # A fresh catalogue asked for one article only gives the same specs...
    monkeypatch.setattr(random_catalogue, "_CATALOGUE", random_catalogue._Catalogue())
    assert catalogue_spec(157) == among_200[157]
    assert [catalogue_spec(i) for i in range(200)] == among_200
    # ... and so does another process (another hash seed), down to the texture's bytes.
    here = str(Path(__file__).parent)
    code = (f"import sys; sys.path.insert(0, {here!r}); from test_random_catalogue import "
            "_texture_digest; from photomodel.sim import catalogue_spec; "
            "print(repr(catalogue_spec(157))); print(_texture_digest('cat-00157'))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         timeout=120, check=True).stdout.splitlines()
    assert out[0] == repr(among_200[157])
    assert out[1] == _texture_digest("cat-00157") == _texture_digest("cat-00157")


def test_catalogue_garment_builds_an_article() -> None:
    spec = catalogue_spec(42)
    g = catalogue_garment("cat-00042")
    assert (g.name, g.shape, g.fabric, g.size_mm, g.description) == (
        spec.name, spec.shape, spec.fabric, spec.size_mm, spec.description)
    assert catalogue_garment("cat-00042") is g  # cached like the named garments
    assert not g.texture.image_bgr.flags.writeable
    with pytest.raises(ValueError, match="cat-NNNNN"):
        catalogue_garment("cat-100000")


def test_articles_with_a_hem_or_a_photo_repeat_build(specs: list[GarmentSpec]) -> None:
    hemmed = next(s for s in specs if s.hem is not None and s.fabric == "plain")
    g = catalogue_garment(hemmed.name)
    tex, (height_mm, colour) = g.texture, hemmed.hem
    inside = tex.alpha > 0.99
    bottom = np.nonzero(inside.any(axis=1))[0][-1]
    row = tex.image_bgr[bottom - 2][inside[bottom - 2]].mean(axis=0)
    assert np.abs(row - colour).max() < 12  # the hem's colour along the bottom edge
    middle = tex.image_bgr[inside].mean(axis=0)
    assert np.linalg.norm(middle - hemmed.colour_bgr) < 30 + height_mm
    tiled = next(s for s in specs if s.photo_tile_mm is not None)
    assert catalogue_garment(tiled.name).fabric == "photo"


# --- look-alike pairs ------------------------------------------------------------------------


def test_every_tenth_article_is_the_look_alike_of_the_one_before(
        specs: list[GarmentSpec]) -> None:
    kinds: dict[str, int] = defaultdict(int)
    for i, twin in enumerate(specs):
        if i % 10 != 9:
            assert lookalike_of(twin.name) is None
            assert "look-alike" not in twin.description
            continue
        original = specs[i - 1]
        pair = lookalike_of(twin.name)
        assert pair is not None and pair[0] == original.name, twin
        kind = pair[1]
        kinds[kind] += 1
        assert f"look-alike of {original.name}: differs only in {kind}" in twin.description
        # Everything but the one respect is the original's.
        for field in ("shape", "fabric", "seed", "photo", "photo_tile_mm", "hem", "plane_bgr"):
            assert getattr(twin, field) == getattr(original, field), (field, twin)
        if kind == "size":
            assert twin.colour_bgr == original.colour_bgr
            np.testing.assert_allclose(twin.size_mm, np.multiply(original.size_mm, 0.8),
                                       atol=0.05)
        else:
            assert kind == "colour" and original.fabric in ("plain", "stripes", "dots", "print")
            assert twin.size_mm == original.size_mm
            (h0, s0, v0), (h1, s1, v1) = _hsv(original.colour_bgr), _hsv(twin.colour_bgr)
            turned = _hue_apart(h0, h1) >= 20 and abs(s1 - s0) <= 4 and abs(v1 - v0) <= 2
            assert turned or abs(v1 - v0) >= 100, (original, twin)  # or light <-> dark
        if original.fabric in ("plaid", "camo", "photo"):
            assert kind == "size"
    assert kinds["colour"] > 40 and kinds["size"] > 40


# --- distinct otherwise ----------------------------------------------------------------------


def _practically_identical_pairs(specs: list[GarmentSpec]) -> list[tuple[str, str]]:
    """Pairs that break the module's rule, found independently of the generator: same shape
    and fabric, both sides within 15 %, and for coloured fabrics colours less than 40 apart in
    BGR (photo: the same picture and repeat), with the same hem."""
    groups: dict[tuple[str, str], list[GarmentSpec]] = defaultdict(list)
    for s in specs:
        if s.fabric not in ("plaid", "camo"):
            groups[(s.shape, s.fabric)].append(s)
    found = []
    for (_, fabric), group in groups.items():
        size = np.array([s.size_mm for s in group])
        if fabric == "photo":
            prints = {key: k for k, key in enumerate({(s.photo, s.photo_tile_mm) for s in group})}
            ident = np.array([[1000.0 * prints[(s.photo, s.photo_tile_mm)], 0, 0]
                              for s in group])
        else:
            ident = np.array([s.colour_bgr for s in group], dtype=float)
        hem = np.array([s.hem[1] if s.hem else (-999, -999, -999) for s in group], dtype=float)
        ratio = np.maximum(size[:, None] / size[None], size[None] / size[:, None])
        same = (ratio < 1.15).all(axis=-1)
        same &= ((ident[:, None] - ident[None]) ** 2).sum(axis=-1) < 40.0 ** 2
        same &= ((hem[:, None] - hem[None]) ** 2).sum(axis=-1) < 40.0 ** 2
        for a, b in zip(*np.nonzero(np.triu(same, 1)), strict=True):
            pair = sorted((group[a].name, group[b].name))
            if lookalike_of(pair[1]) != (pair[0], "colour") and lookalike_of(pair[1]) != (
                    pair[0], "size"):
                found.append((pair[0], pair[1]))
    return found


def test_no_two_articles_but_the_designed_pairs_are_practically_identical(
        specs: list[GarmentSpec]) -> None:
    assert _practically_identical_pairs(specs) == []
    # The check finds what it looks for: a near copy of an article under another name.
    plain = next(s for i, s in enumerate(specs) if s.fabric == "plain" and i % 10 < 8)
    b, g, r = plain.colour_bgr
    w, h = plain.size_mm
    clone = GarmentSpec(**{**vars(plain), "name": "cat-99998", "size_mm": (w * 1.1, h / 1.1),
                           "colour_bgr": (min(b + 20, 255), max(g - 20, 0), r)})
    assert (plain.name, "cat-99998") in _practically_identical_pairs([*specs, clone])


# --- the mix ---------------------------------------------------------------------------------


def test_the_mix_is_a_clothing_catalogue(specs: list[GarmentSpec]) -> None:
    first = specs[:200]
    assert {s.shape for s in first} == set(GARMENT_SHAPES)
    assert {s.fabric for s in first} == set(FABRICS)
    plain = sum(s.fabric == "plain" for s in specs) / len(specs)
    assert 0.25 < plain < 0.35
    green = (PLAIN_HUES[1] - 180.0, PLAIN_HUES[0])  # the plane's hues: 35 to 90
    values = []
    for s in specs:
        w, h = s.size_mm
        assert 110 <= w <= 250 and 90 <= h <= 200, s
        assert s.fabric in FABRICS and s.shape in GARMENT_SHAPES
        assert (s.colour_bgr is not None) == (s.fabric in ("plain", "stripes", "dots", "print"))
        for colour in (s.colour_bgr, s.hem[1] if s.hem else None):
            if colour is None:
                continue
            hue, _, value = _hsv(colour)
            values.append(value)
            grey = max(colour) - min(colour) < 8  # hue meaningless
            assert grey or not green[0] < hue < green[1], s  # never the plane's green
    values_ = np.array(values)
    assert (values_ < 70).mean() > 0.08 and (values_ > 220).mean() > 0.08  # dark and light too


# --- integration -----------------------------------------------------------------------------


def test_garment_groups_and_names() -> None:
    assert expand_garments("catalogue:3") == ("cat-00000", "cat-00001", "cat-00002")
    assert expand_garments("No.3, catalogue:2, cat-00001, cat-00042") == (
        "No.3", "cat-00000", "cat-00001", "cat-00042")
    for bad in ("catalogue:0", "catalogue:abc", "catalogue:100001", "catalogue:", "catalogue:-1"):
        with pytest.raises(ValueError, match=r"catalogue:N .*1 to 100000"):
            expand_garments(bad)
    for bad in ("cat-100000", "cat-1", "cat-00001x"):
        with pytest.raises(ValueError, match=r"cat-NNNNN.*catalogue:N"):
            expand_garments(bad)


def test_a_library_is_written_without_scenes_and_alike_by_one_or_two_workers(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    names = catalogue_names(2)
    one = write_dataset(tmp_path / "one", [], ["paper", "no-target"], 1, 5, library=names,
                        workers=1)
    two = write_dataset(tmp_path / "two", [], ["paper", "no-target"], 1, 5, library=names,
                        workers=2)
    assert one.models == two.models == names and one.scenes == ("no-target_0000",)

    def files(root: Path) -> dict[str, bytes]:
        return {p.relative_to(root).as_posix(): p.read_bytes()
                for p in sorted(root.rglob("*")) if p.is_file()}

    assert files(one.out) == files(two.out)
    # A program read from stdin cannot spawn workers: it renders them itself, alike.
    monkeypatch.setattr(sys.modules["__main__"], "__file__", "<stdin>", raising=False)
    piped = write_dataset(tmp_path / "piped", [], ["paper", "no-target"], 1, 5, library=names,
                          workers=2)
    assert files(piped.out) == files(one.out)
    assert {f"models/{n}/{p}" for n in names for p in ("photo.bmp", "background.bmp")} <= set(
        files(one.out))
    manifest = json.loads((one.out / "dataset.json").read_text())
    assert set(manifest["library"]) == set(names) and manifest["garments"] == {}
    # No scene at all is a dataset too.
    empty = write_dataset(tmp_path / "empty", [], ["paper"], 1, 5, library=names[:1])
    assert empty.scenes == () and json.loads((empty.out / "truth.json").read_text()) == {}
    with pytest.raises(ValueError, match="library: no catalogue garment 'cat-1'"):
        write_dataset(tmp_path / "bad", [], ["paper"], library=["cat-1"])
    assert not (tmp_path / "bad").exists()
