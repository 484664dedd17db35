"""``pick``'s helpers: a grasp point given as a pixel of the model photo."""

from __future__ import annotations

import numpy as np
import pytest

from photomodel.cell import grasp_point_from_photo_px
from photomodel.errors import InputError


def test_grasp_point_from_a_photo_pixel(plain_case) -> None:
    case = plain_case
    model = case.built.model
    cx, cy, d = model.meta["centroid_in_camera_mm"]
    uv_centroid = case.camera.project(np.array([[cx, cy, d]]))[0]
    np.testing.assert_allclose(grasp_point_from_photo_px(model, uv_centroid), (0.0, 0.0),
                               atol=1e-6)
    uv = case.camera.project(np.array([[cx + 30.0, cy - 20.0, d]]))[0]
    np.testing.assert_allclose(grasp_point_from_photo_px(model, uv), (30.0, -20.0), atol=1e-3)
    with pytest.raises(InputError, match="not on the garment"):
        grasp_point_from_photo_px(model, (2.0, 2.0))
