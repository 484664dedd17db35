"""The library's label map (``labels.json``): set, move, drop, refused for a model the library
does not hold, written atomically, never read as a model, and any damaged file refused in one
line naming it."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from photomodel.errors import InputError
from photomodel.library import LABELS_NAME, ModelLibrary
from photomodel.model import PhotoModel


def _renamed(model: PhotoModel, name: str) -> PhotoModel:
    return PhotoModel(**{**model.__dict__, "name": name})


@pytest.fixture()
def library(tmp_path: Path, plain_case) -> ModelLibrary:  # type: ignore[no-untyped-def]
    lib = ModelLibrary(tmp_path / "lib", create=True)
    for name in ("shirt", "towel"):
        lib.add_model(_renamed(plain_case.built.model, name))
    return lib


def test_labels_are_set_moved_and_dropped(library: ModelLibrary) -> None:
    assert library.labels() == {}
    assert library.set_label("PM-1", "shirt") is None
    assert library.set_label("PM-1", "shirt") == "shirt"             # nothing to change
    assert library.set_label("0123456789", "towel") is None
    assert library.labels() == {"PM-1": "shirt", "0123456789": "towel"}
    before = library.labels_path.read_bytes()
    with pytest.raises(InputError, match="already names model 'shirt'.*--replace"):
        library.set_label("PM-1", "towel")
    assert library.labels_path.read_bytes() == before
    assert library.set_label("PM-1", "towel", replace=True) == "shirt"
    assert library.remove_label("PM-1") == "towel"
    assert library.labels() == {"0123456789": "towel"}
    data = json.loads(library.labels_path.read_text())
    assert data["format"] == "photomodel-labels" and data["version"] == 1
    assert [p.name for p in library.root.iterdir() if ".tmp" in p.name] == []


def test_a_label_must_name_a_model_of_the_library(library: ModelLibrary) -> None:
    with pytest.raises(InputError, match="no model named 'jeans'") as info:
        library.set_label("PM-9", "jeans")
    assert "\n" not in str(info.value)
    assert not library.labels_path.exists()
    with pytest.raises(InputError, match="no label 'PM-9'"):
        library.remove_label("PM-9")
    for bad in ("", "two\nlines", "x" * 501):
        with pytest.raises(InputError, match="label code"):
            library.set_label(bad, "shirt")
    assert not library.labels_path.exists()


def test_removing_a_model_drops_its_labels_and_the_map_is_no_model(
        library: ModelLibrary) -> None:
    library.set_label("PM-1", "shirt")
    library.set_label("PM-2", "towel")
    scan = library.scan()
    assert [s.path.name for s in scan.skipped] == []            # labels.json is no model
    library.remove("shirt")
    assert library.labels() == {"PM-2": "towel"}


@pytest.mark.parametrize("content", [
    b"", b"{not json", b"[]", b'{"format": "photomodel-library", "version": 1}',
    b'{"format": "photomodel-labels", "version": 9, "labels": {}}',
    b'{"format": "photomodel-labels", "version": "1", "labels": {}}',
    b'{"format": "photomodel-labels", "version": 1, "labels": ["PM-1"]}',
    b'{"format": "photomodel-labels", "version": 1, "labels": {"PM-1": 3}}',
    b'{"format": "photomodel-labels", "version": 1, "labels": {"PM-1": "a/b"}}',
    b'{"format": "photomodel-labels", "version": 1, "labels": {"": "shirt"}}',
    b"\xff\xfe\x00garbage",
])
def test_a_damaged_map_is_one_line_naming_it_and_is_left_alone(library: ModelLibrary,
                                                               content: bytes) -> None:
    library.labels_path.write_bytes(content)
    for call in (library.labels, lambda: library.set_label("PM-1", "shirt", replace=True),
                 lambda: library.remove_label("PM-1")):
        with pytest.raises(InputError) as info:
            call()
        message = str(info.value)
        assert message.startswith(str(library.labels_path)) and "\n" not in message
    assert library.labels_path.read_bytes() == content


_JSON = st.recursive(st.none() | st.booleans() | st.integers() | st.floats() | st.text(),
                     lambda inner: st.lists(inner, max_size=3)
                     | st.dictionaries(st.text(max_size=8), inner, max_size=3), max_leaves=8)


@settings(max_examples=150, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(labels=_JSON, version=_JSON, raw=st.binary(max_size=64), use_raw=st.booleans())
def test_fuzzed_maps_load_or_raise_one_input_error(library: ModelLibrary, labels: object,
                                                   version: object, raw: bytes,
                                                   use_raw: bool) -> None:
    if use_raw:
        library.labels_path.write_bytes(raw)
    else:
        library.labels_path.write_text(json.dumps(
            {"format": "photomodel-labels", "version": version, "labels": labels}))
    try:
        read = library.labels()
    except InputError as exc:
        assert "\n" not in str(exc) and LABELS_NAME in str(exc)
    else:
        assert all(isinstance(c, str) and c and isinstance(n, str) for c, n in read.items())
