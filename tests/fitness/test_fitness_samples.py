"""Model samples drawn together (``SampleDrawer``): what each spacing drawn alone gives, the
colours as their definition gives them, the shared work done once and no image kept."""

from __future__ import annotations

from functools import lru_cache

import cv2
import numpy as np
import pytest

from photomodel.experiments import ExperimentConfig, Trial, trial_inputs
from photomodel.fitness import (
    ModelSamples,
    PreparedModel,
    SampleDrawer,
    SampleSpacing,
    level_spacing,
    model_samples,
    scan_spacing,
)
from photomodel.fitness import _samples as samples_module
from photomodel.image import sample_bilinear
from photomodel.image._features import log_opponent
from photomodel.locate import COARSE_SCAN
from photomodel.model import PhotoModel
from photomodel.search import PyramidConfig

_FIELDS = ("p_in", "f_in", "p_out", "f_out", "table_out")


@lru_cache(maxsize=4)
def _model(garment: str) -> PhotoModel:
    config = ExperimentConfig(garments=(garment,), conditions=("paper",), trials=1, seed=0)
    return trial_inputs(config, Trial(f"paper_{garment}_0000", garment, "paper", 0))[0]


def _locator_spacings() -> list[SampleSpacing]:
    """The spacings a locator prepares: levels 0 and 1 with every candidate camera blur,
    levels 2 and 3 with the default blur, the coarse scan's."""
    blurs = PyramidConfig().optics_blur_candidates_mm
    return ([level_spacing(level, optics_blur_mm=b) for level in (0, 1) for b in blurs]
            + [level_spacing(2), level_spacing(3), scan_spacing(COARSE_SCAN)])


def _defined_colours(model: PhotoModel, uv: np.ndarray, spacing: SampleSpacing,
                     px_per_mm: float) -> np.ndarray:
    """The colours (N, 3) of the photo at crop pixels ``uv`` (N, 2) as the module docstring
    defines them, one blur after the other over the garment only (normalised convolution)."""
    mask = model.mask.astype(np.float32)

    def garment_blur(image: np.ndarray, sigma: float) -> np.ndarray:
        weight = cv2.GaussianBlur(mask, (0, 0), sigma)
        blurred = cv2.GaussianBlur(image * mask[..., None], (0, 0), sigma)
        return blurred / np.maximum(weight, 1e-3)[..., None]

    photo = model.photo_bgr
    if spacing.optics_blur_mm > 0:
        blurred = garment_blur(photo.astype(np.float32), spacing.optics_blur_mm * px_per_mm)
        photo = np.clip(np.rint(blurred), 0, 255).astype(np.uint8)
    colours = garment_blur(log_opponent(photo), max(spacing.blur_mm * px_per_mm, 0.3))
    return np.asarray(sample_bilinear(colours, uv), dtype=np.float64)


@pytest.mark.parametrize("garment", ["No.3", "No.6"])
def test_samples_drawn_together_are_those_drawn_alone_to_the_bit(garment: str) -> None:
    model = _model(garment)
    spacings = _locator_spacings()
    together = PreparedModel(model)
    SampleDrawer(together).draw(spacings)
    for spacing in spacings:
        alone = model_samples(PreparedModel(model), spacing)
        drawn = model_samples(together, spacing)
        for name in _FIELDS:
            np.testing.assert_array_equal(getattr(drawn, name), getattr(alone, name),
                                          err_msg=f"{name} of {spacing}")
    # One geometry per level, shared by its blurs.
    level0 = [model_samples(together, s) for s in spacings[:6]]
    assert all(s.p_in is level0[0].p_in for s in level0)


def test_the_colours_are_the_photos_blurred_as_defined() -> None:
    """Each spacing's inner colours are the photo's, blurred by the camera in grey levels
    (rounded to grey levels) and then in the features, each over the garment only: the
    definition written out, to the bit."""
    model = _model("No.3")
    prepared = PreparedModel(model)
    spacings = _locator_spacings()
    SampleDrawer(prepared).draw(spacings)
    for spacing in (spacings[0], spacings[5], spacings[7], spacings[-1]):
        geometry = prepared.kept.get(("geometry", spacing.geometry), lambda: None)
        assert geometry is not None
        expected = _defined_colours(model, geometry.uv_in, spacing, geometry.px_per_mm)
        np.testing.assert_array_equal(model_samples(prepared, spacing).f_in, expected)


def test_the_shared_work_is_done_once(monkeypatch: pytest.MonkeyPatch) -> None:
    """One outline for every spacing and one log-opponent image per camera blur, over two
    calls of one drawer; spacings drawn before are not drawn again."""
    calls: dict[str, int] = {"outline": 0, "log_opponent": 0, "coloured": 0}

    def counted(name: str, function):  # type: ignore[no-untyped-def]
        def run(*args, **kwargs):  # type: ignore[no-untyped-def]
            calls[name] += 1
            return function(*args, **kwargs)
        return run

    monkeypatch.setattr(samples_module, "_outline_of",
                        counted("outline", samples_module._outline_of))
    monkeypatch.setattr(samples_module, "log_opponent",
                        counted("log_opponent", samples_module.log_opponent))
    monkeypatch.setattr(samples_module, "_coloured",
                        counted("coloured", samples_module._coloured))
    prepared = PreparedModel(_model("No.3"))
    spacings = _locator_spacings()
    drawer = SampleDrawer(prepared)
    drawer.draw(spacings[-3:])       # levels 2 and 3, the coarse scan's: one camera blur
    drawer.draw([*spacings, spacings[0]])
    assert calls == {"outline": 1, "log_opponent": len(PyramidConfig().optics_blur_candidates_mm),
                     "coloured": len(spacings)}
    SampleDrawer(prepared).draw(spacings)
    assert calls["coloured"] == len(spacings)


def test_a_prepared_model_keeps_samples_and_points_but_no_image() -> None:
    prepared = PreparedModel(_model("No.3"))
    spacings = _locator_spacings()
    SampleDrawer(prepared).draw(spacings)
    kinds = {key[0] if isinstance(key, tuple) else key for key in prepared.kept._values}
    assert kinds == {"samples", "geometry"}
    photo_bytes = prepared.model.photo_bgr.size * 4       # one float32 image of the photo
    for key, value in prepared.kept._values.items():
        if key[0] == "samples":
            assert isinstance(value, ModelSamples)
        arrays = [a for a in vars(value).values() if isinstance(a, np.ndarray)]
        assert sum(a.nbytes for a in arrays) < photo_bytes / 4, key
    # A bare photo-model's samples are kept in a prepared model of the drawer's own.
    drawer = SampleDrawer(prepared.model)
    drawer.draw(spacings[:1])
    assert drawer.prepared is not prepared and ("samples", spacings[0]) in drawer.prepared.kept
