"""Look-alike garments for identification: each twin differs from its original in one respect."""

from __future__ import annotations

import numpy as np
import pytest

from photomodel.sim import (
    CATALOGUE,
    GARMENT_GROUPS,
    SIMILAR,
    catalogue_garment,
    expand_garments,
    garment_names,
    known_garments,
    parse_conditions,
)
from photomodel.sim._catalogue import PLANE_COLOURED


def test_the_paper_catalogue_is_unchanged() -> None:
    assert garment_names() == tuple(f"No.{i}" for i in range(1, 13))
    assert expand_garments("all") == garment_names()
    assert not set(SIMILAR) & set(CATALOGUE)
    assert set(known_garments()) == set(CATALOGUE) | set(SIMILAR) | set(PLANE_COLOURED)


def test_groups_and_names() -> None:
    assert expand_garments("similar") == GARMENT_GROUPS["similar"]
    assert expand_garments("No.3,similar,No.3-red") == (
        "No.3", "No.1", "No.1-small", "No.3-red", "No.4", "No.4-dots")
    with pytest.raises(ValueError, match="unknown garment 'No.13'.*groups: all, similar"):
        expand_garments("No.13")


@pytest.mark.parametrize(("twin", "differs"), [
    ("No.1-small", {"size_mm"}), ("No.3-red", {"colour_bgr"}), ("No.4-dots", {"fabric"})])
def test_twins_differ_in_one_respect(twin: str, differs: set[str]) -> None:
    a, b = CATALOGUE[twin.split("-")[0]], SIMILAR[twin]
    fields = ("shape", "fabric", "size_mm", "seed", "colour_bgr", "photo")
    assert {f for f in fields if getattr(a, f) != getattr(b, f)} == differs
    ga, gb = catalogue_garment(a.name), catalogue_garment(b.name)
    assert gb.name == twin and ga.shape == gb.shape
    if "size_mm" in differs:
        assert gb.size_mm[0] < 0.9 * ga.size_mm[0]
    else:
        assert ga.texture.alpha.shape == gb.texture.alpha.shape
        np.testing.assert_array_equal(ga.texture.alpha, gb.texture.alpha)


def test_empty_condition_has_nothing_on_the_table() -> None:
    c = parse_conditions("empty")
    assert not c.target and c.distractor_garments == 0 and c.distractor_objects == 0
