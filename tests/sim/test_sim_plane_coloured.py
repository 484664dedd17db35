"""The catalogue's plane-coloured garments: names, group, plane colours and the paper's 12
left as they were."""

from __future__ import annotations

import numpy as np

from photomodel.sim import (
    GARMENT_GROUPS,
    expand_garments,
    known_garments,
    model_station_camera,
    render_model_photos,
)
from photomodel.sim._catalogue import CATALOGUE, PLANE_COLOURED, catalogue_garment

NEW = ("green-print", "green-hem", "grey-on-grey", "white-on-white", "black-on-black")


def test_the_new_garments_have_their_own_group_and_all_stays_the_papers_12() -> None:
    assert tuple(PLANE_COLOURED) == NEW
    assert expand_garments("plane-coloured") == NEW
    assert GARMENT_GROUPS["all"] == tuple(CATALOGUE) == tuple(f"No.{i}" for i in range(1, 13))
    assert set(NEW) <= set(known_garments())
    assert expand_garments("No.1,green-hem") == ("No.1", "green-hem")


def test_the_paper_garments_keep_the_green_plane() -> None:
    assert all(catalogue_garment(n).plane_bgr is None for n in CATALOGUE)


def test_each_plane_coloured_garment_is_photographed_on_its_plane() -> None:
    camera = model_station_camera()
    for name in ("grey-on-grey", "white-on-white", "black-on-black", "green-hem"):
        g = catalogue_garment(name)
        photo, background = render_model_photos(g, camera, 1)
        expected = (60, 160, 50) if g.plane_bgr is None else g.plane_bgr
        np.testing.assert_allclose(np.median(background.reshape(-1, 3), axis=0), expected,
                                   atol=2)
        assert not np.array_equal(photo, background)


def test_the_hem_is_dark_green_and_leaves_the_silhouette_alone() -> None:
    g = catalogue_garment("green-hem")
    tex = g.texture
    inside = tex.alpha > 0.99
    rows = np.nonzero(inside.any(axis=1))[0]
    bottom = tex.image_bgr[rows[-1] - 5][inside[rows[-1] - 5]].mean(axis=0)
    top = tex.image_bgr[rows[0] + 20][inside[rows[0] + 20]].mean(axis=0)
    np.testing.assert_allclose(bottom, (40, 85, 20), atol=4)
    np.testing.assert_allclose(top, (170, 120, 60), atol=4)
    np.testing.assert_allclose(tex.origin_px, np.array(
        [(tex.alpha * np.arange(tex.alpha.shape[1])).sum(),
         (tex.alpha * np.arange(tex.alpha.shape[0])[:, None]).sum()]) / tex.alpha.sum(),
        atol=1e-6)
