"""A model's descriptor (issue 50): what it measures of a known silhouette and colour, its
JSON round trip, and ``from_json_dict`` refusing every malformed descriptor with a ValueError
that names it (never another exception, whatever JSON it is given)."""

from __future__ import annotations

import json
import math
from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from photomodel.image._features import log_opponent
from photomodel.model import DESCRIPTOR_VERSION, ModelDescriptor, PhotoModel, describe_model
from photomodel.model._descriptor import (
    COLOUR_GRID_SHAPE,
    MAX_COLOUR_BINS,
    colour_grid_coords,
    model_mm_per_px,
)

N_BINS = int(np.prod(COLOUR_GRID_SHAPE))
FOCAL_PX, DISTANCE_MM = 800.0, 400.0     # 0.5 mm a model-photo pixel


def _rectangle_model(colour_bgr: tuple[int, int, int], width_px: int = 120,
                     height_px: int = 80, margin_px: int = 12) -> PhotoModel:
    """A one-colour rectangular garment on a photo of the same colour (so that blurring
    mixes in no other colour): ``width_px`` x ``height_px`` pixels of 0.5 mm."""
    mm = DISTANCE_MM / FOCAL_PX
    photo = np.empty((height_px + 2 * margin_px, width_px + 2 * margin_px, 3), np.uint8)
    photo[:] = colour_bgr
    mask = np.zeros(photo.shape[:2], np.uint8)
    mask[margin_px:margin_px + height_px, margin_px:margin_px + width_px] = 1
    w, h = width_px * mm / 2, height_px * mm / 2
    outline = np.array([[-w, -h, 0.0], [w, -h, 0.0], [w, h, 0.0], [-w, h, 0.0]])
    return PhotoModel(name="rect", points_in_mm=np.zeros((1, 3)), hsv_in=np.zeros((1, 3)),
                      points_out_mm=outline * 1.1, outline_mm=outline, photo_bgr=photo,
                      mask=mask, crop_origin_px=np.zeros(2, np.int64),
                      meta={"camera_K": [[FOCAL_PX, 0, 0], [0, FOCAL_PX, 0], [0, 0, 1]],
                            "distance_mm": DISTANCE_MM})


def _bin_centres(bins: np.ndarray) -> np.ndarray:
    """Grid coordinates (K, 3) of flat bin indices."""
    return np.stack(np.unravel_index(bins, COLOUR_GRID_SHAPE), axis=1).astype(np.float64)


def _check_valid(d: ModelDescriptor) -> None:
    """What every descriptor holds, whatever it came from."""
    assert d.version == DESCRIPTOR_VERSION
    numbers = [d.area_mm2, *d.size_mm, *d.moments_mm2, *d.mean_lab]
    assert all(isinstance(v, float) and math.isfinite(v) for v in numbers)
    assert d.area_mm2 > 0 and min(d.size_mm) > 0 and min(d.moments_mm2) >= 0
    assert d.colour_bins.dtype == np.int32 and d.colour_weights.dtype == np.float32
    assert d.colour_bins.shape == d.colour_weights.shape
    assert 1 <= len(d.colour_bins) <= MAX_COLOUR_BINS
    assert d.colour_bins.min() >= 0 and d.colour_bins.max() < N_BINS
    assert d.colour_weights.min() >= 0
    assert float(d.colour_weights.sum()) == pytest.approx(1.0, abs=1e-5)


# --- describe_model --------------------------------------------------------------------------


def test_a_rectangle_has_its_size_and_the_moments_of_a_rectangle() -> None:
    model = _rectangle_model((40, 60, 200), width_px=120, height_px=80)
    assert model_mm_per_px(model) == pytest.approx(0.5)
    d = describe_model(model)
    _check_valid(d)
    assert d.area_mm2 == pytest.approx(60.0 * 40.0)
    assert d.size_mm == pytest.approx((60.0, 40.0))
    # a uniform grid of n pixels a side: variance (n^2 - 1) / 12 pixels^2, in mm^2
    assert d.moments_mm2 == pytest.approx(((120**2 - 1) / 12 * 0.25, (80**2 - 1) / 12 * 0.25),
                                          rel=1e-3)
    tall = describe_model(_rectangle_model((40, 60, 200), width_px=50, height_px=140))
    assert tall.moments_mm2[0] > tall.moments_mm2[1]       # largest first, whichever axis
    assert tall.moments_mm2 == pytest.approx(((140**2 - 1) / 12 * 0.25,
                                              (50**2 - 1) / 12 * 0.25), rel=1e-3)


@settings(max_examples=25, deadline=None)
@given(st.tuples(*[st.integers(20, 200)] * 3))
def test_one_colour_is_shared_between_the_bins_around_it(colour: tuple[int, int, int]) -> None:
    """Trilinear sharing: at most 8 bins, whose weighted centre is the colour itself."""
    lab = log_opponent(np.array([[colour]], np.uint8))[0, 0].astype(np.float64)
    coords = colour_grid_coords(lab)[0]
    assume(np.all(coords > 0.01) and np.all(coords < np.array(COLOUR_GRID_SHAPE) - 1.01))
    d = describe_model(_rectangle_model(colour, width_px=60, height_px=40))
    _check_valid(d)
    assert d.mean_lab == pytest.approx(tuple(lab), abs=1e-4)
    assert len(d.colour_bins) <= 8
    centre = d.colour_weights.astype(np.float64) @ _bin_centres(d.colour_bins)
    assert centre == pytest.approx(coords, abs=1e-3)
    assert np.all(np.diff(d.colour_weights) <= 0)          # heaviest first


def test_a_built_garment_is_described_consistently(plain_case, plaid_case) -> None:
    for case in (plain_case, plaid_case):
        model = case.built.model
        d = describe_model(model)
        _check_valid(d)
        assert d.area_mm2 == pytest.approx(model.area_mm2)
        assert d.size_mm == pytest.approx(model.size_mm)
        assert d.moments_mm2[0] >= d.moments_mm2[1] > 0
        assert len(np.unique(d.colour_bins)) == len(d.colour_bins)
        assert np.all(np.diff(d.colour_weights) <= 0)
        assert _same(describe_model(model), d)                   # deterministic
    plain, plaid = describe_model(plain_case.built.model), describe_model(plaid_case.built.model)
    # one colour needs few bins; a tartan spreads over many more
    top = np.cumsum(plain.colour_weights)
    assert np.searchsorted(top, 0.9) + 1 < np.searchsorted(np.cumsum(plaid.colour_weights), 0.9)


def _same(a: ModelDescriptor, b: ModelDescriptor) -> bool:
    return (a.area_mm2 == b.area_mm2 and a.size_mm == b.size_mm
            and a.moments_mm2 == b.moments_mm2 and a.mean_lab == b.mean_lab
            and np.array_equal(a.colour_bins, b.colour_bins)
            and np.array_equal(a.colour_weights, b.colour_weights))


# --- JSON ------------------------------------------------------------------------------------


def _via_json(d: ModelDescriptor) -> ModelDescriptor:
    return ModelDescriptor.from_json_dict(json.loads(json.dumps(d.to_json_dict())))


def _assert_round_trip(d: ModelDescriptor, back: ModelDescriptor) -> None:
    assert back.version == d.version
    assert back.area_mm2 == pytest.approx(d.area_mm2, abs=0.006)
    assert back.size_mm == pytest.approx(d.size_mm, abs=0.006)
    assert back.moments_mm2 == pytest.approx(d.moments_mm2, abs=0.006)
    assert back.mean_lab == pytest.approx(d.mean_lab, abs=6e-5)
    assert back.colour_bins.dtype == np.int32 and back.colour_weights.dtype == np.float32
    assert np.array_equal(back.colour_bins, d.colour_bins)
    np.testing.assert_allclose(back.colour_weights, d.colour_weights, atol=2e-5)


def test_json_round_trip_of_a_built_garment(plaid_case) -> None:
    d = describe_model(plaid_case.built.model)
    doc = json.loads(json.dumps(d.to_json_dict()))
    assert set(doc) == {"version", "area_mm2", "size_mm", "moments_mm2", "mean_lab",
                        "colour_bins", "colour_weights"}
    _assert_round_trip(d, ModelDescriptor.from_json_dict(doc))


@st.composite
def descriptors(draw: st.DrawFn) -> ModelDescriptor:
    """Valid descriptors of any size and colours."""
    positive = st.floats(0.5, 1e5, allow_nan=False)
    k = draw(st.integers(1, MAX_COLOUR_BINS))
    bins = draw(st.lists(st.integers(0, N_BINS - 1), min_size=k, max_size=k, unique=True))
    raw = np.array(draw(st.lists(st.floats(0.01, 1.0), min_size=k, max_size=k)))
    moments = sorted(draw(st.tuples(positive, positive)), reverse=True)
    return ModelDescriptor(
        area_mm2=draw(positive), size_mm=draw(st.tuples(positive, positive)),
        moments_mm2=(moments[0], moments[1]),
        mean_lab=draw(st.tuples(*[st.floats(-4.0, 6.0)] * 3)),
        colour_bins=np.array(bins, np.int32),
        colour_weights=(raw / raw.sum()).astype(np.float32))


@settings(max_examples=150, deadline=None)
@given(descriptors())
def test_json_round_trip_property(d: ModelDescriptor) -> None:
    _assert_round_trip(d, _via_json(d))


# --- validation ------------------------------------------------------------------------------


def _valid_doc() -> dict[str, Any]:
    return {"version": DESCRIPTOR_VERSION, "area_mm2": 2400.0, "size_mm": [60.0, 40.0],
            "moments_mm2": [300.0, 133.0], "mean_lab": [4.3, 1.1, 1.4],
            "colour_bins": [700, 701, 1000], "colour_weights": [0.5, 0.3, 0.2]}


def test_the_valid_document_is_accepted() -> None:
    """The base of the cases below is valid: each case's change alone is refused."""
    _check_valid(ModelDescriptor.from_json_dict(_valid_doc()))


_MISSING = object()
BAD = {
    "version 2": ("version", 2),
    "version as text": ("version", "1"),
    "no version": ("version", _MISSING),
    "no area": ("area_mm2", _MISSING),
    "no size": ("size_mm", _MISSING),
    "no moments": ("moments_mm2", _MISSING),
    "no mean colour": ("mean_lab", _MISSING),
    "no bins": ("colour_bins", _MISSING),
    "no weights": ("colour_weights", _MISSING),
    "NaN area": ("area_mm2", float("nan")),
    "NaN mean colour": ("mean_lab", [4.3, float("nan"), 1.4]),
    "infinite size": ("size_mm", [float("inf"), 40.0]),
    "negative area": ("area_mm2", -2400.0),
    "zero area": ("area_mm2", 0.0),
    "negative moment": ("moments_mm2", [300.0, -1.0]),
    "three sizes": ("size_mm", [60.0, 40.0, 1.0]),
    "two mean colours": ("mean_lab", [4.3, 1.1]),
    "area as text": ("area_mm2", "big"),
    "size a number": ("size_mm", 60.0),
    "bins as text": ("colour_bins", "x"),
    "bin below the grid": ("colour_bins", [-1, 701, 1000]),
    "bin beyond the grid": ("colour_bins", [700, 701, N_BINS]),
    "no bin at all": ("colour_bins", []),
    "more bins than weights": ("colour_bins", [700, 701, 1000, 1001]),
    "too many bins": ("colour_bins", list(range(MAX_COLOUR_BINS + 1))),
    "nested bins": ("colour_bins", [[700], [701], [1000]]),
    "weights summing to 2": ("colour_weights", [1.0, 0.6, 0.4]),
    "weights summing to 0.1": ("colour_weights", [0.05, 0.03, 0.02]),
    "negative weight": ("colour_weights", [0.9, 0.3, -0.2]),
    "NaN weight": ("colour_weights", [0.5, float("nan"), 0.5]),
    "huge weights": ("colour_weights", [1e308, 1e308, 1e308]),
    "version true": ("version", True),
    "area null": ("area_mm2", None),
    "area as a text of digits": ("area_mm2", "2400"),
    "size as a text of digits": ("size_mm", "64"),
    "bins as texts of digits": ("colour_bins", ["700", "701", "1000"]),
    "fractional bin": ("colour_bins", [700, 701.5, 1000]),
    "boolean bins": ("colour_bins", [True, False, 1000]),
    "repeated bin": ("colour_bins", [700, 700, 1000]),
    "weights as texts": ("colour_weights", ["0.5", "0.3", "0.2"]),
    "area beyond float": ("area_mm2", 10**400),
    "bin beyond int64": ("colour_bins", [700, 701, 10**30]),
    "weight beyond float": ("colour_weights", [10**400, 0.3, 0.2]),
}


@pytest.mark.parametrize("case", list(BAD))
def test_a_malformed_descriptor_is_refused_naming_it(case: str) -> None:
    key, value = BAD[case]
    doc = _valid_doc()
    if value is _MISSING:
        del doc[key]
    else:
        doc[key] = value
    with pytest.raises(ValueError, match="^descriptor: "):
        ModelDescriptor.from_json_dict(doc)


@pytest.mark.parametrize("doc", [None, [], "descriptor", 1, [_valid_doc()]])
def test_a_descriptor_that_is_not_an_object_is_refused(doc: Any) -> None:
    with pytest.raises(ValueError, match="^descriptor: expected an object"):
        ModelDescriptor.from_json_dict(doc)


# --- fuzz ------------------------------------------------------------------------------------

JSON_SCALARS = (st.none() | st.booleans() | st.integers() | st.floats() | st.text(max_size=8))
JSON_VALUES = st.recursive(JSON_SCALARS, lambda inner: st.lists(inner, max_size=6)
                           | st.dictionaries(st.text(max_size=8), inner, max_size=4),
                           max_leaves=20)
KEYS = list(_valid_doc())


@st.composite
def near_descriptors(draw: st.DrawFn) -> Any:
    """JSON-like input: anything, or a valid descriptor with some keys removed or replaced
    by anything (a number, a list of numbers of any length, any JSON value)."""
    if draw(st.integers(0, 3)) == 0:
        return draw(JSON_VALUES)
    doc = _valid_doc()
    numbers = st.integers() | st.floats()
    for key in draw(st.lists(st.sampled_from(KEYS), min_size=1, max_size=3, unique=True)):
        doc[key] = draw(numbers | st.lists(numbers | JSON_SCALARS, max_size=70) | JSON_VALUES
                        | st.just(_MISSING))
        if doc[key] is _MISSING:
            del doc[key]
    return doc


@settings(max_examples=500, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(near_descriptors())
def test_fuzzed_descriptors_raise_value_error_or_are_valid(doc: Any) -> None:
    try:
        d = ModelDescriptor.from_json_dict(doc)
    except ValueError as exc:
        assert str(exc).startswith("descriptor: ") and "\n" not in str(exc), str(exc)
        return
    _check_valid(d)
    _assert_round_trip(d, _via_json(d))     # what was accepted can be stored and read back
    # and it is what the document said, not a reading of something else (digits of a text)
    assert (d.area_mm2, d.size_mm, d.moments_mm2, d.mean_lab) == (
        doc["area_mm2"], tuple(doc["size_mm"]), tuple(doc["moments_mm2"]),
        tuple(doc["mean_lab"]))
    assert d.colour_bins.tolist() == list(doc["colour_bins"])
