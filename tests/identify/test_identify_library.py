"""The model library: index, add/remove/show, and files that are not photo-models."""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np
import pytest
from identify_helpers import IdentifyData

from photomodel.errors import InputError
from photomodel.library import INDEX_NAME, ModelLibrary, main_colours
from photomodel.model import load_model, save_model


def _library(tmp_path: Path, data: IdentifyData) -> ModelLibrary:
    lib = ModelLibrary(tmp_path / "lib", create=True)
    for m in data.models:
        lib.add(data.library / f"{m.name}.npz")
    return lib


def test_add_list_show_remove(tmp_path: Path, identify_data: IdentifyData) -> None:
    lib = _library(tmp_path, identify_data)
    scan = lib.scan()
    assert [e.name for e in scan.entries] == sorted(m.name for m in identify_data.models)
    assert scan.skipped == ()
    index = json.loads(lib.index_path.read_text())
    assert index["format"] == "photomodel-library"
    assert set(index["models"]) == {"No.3", "No.5", "No.9"}
    e = lib.entry("No.5")
    model = load_model(tmp_path / "lib" / "No.5.npz")
    assert e.size_mm == pytest.approx(model.size_mm)
    assert e.n_in == model.n_in and e.colours and e.colours[0][0].startswith("#")
    assert e.added_utc and e.created_utc
    lib.remove("No.3")
    assert not (tmp_path / "lib" / "No.3.npz").exists()
    assert [e.name for e in lib.scan().entries] == ["No.5", "No.9"]
    assert "No.3" not in json.loads(lib.index_path.read_text())["models"]
    # no temporary files left behind by the atomic index writes (the writers' lock file stays)
    assert sorted(p.name for p in (tmp_path / "lib").iterdir()) == [
        ".index.lock", "No.5.npz", "No.9.npz", INDEX_NAME]


def test_add_renames_and_refuses_duplicates(tmp_path: Path,
                                            identify_data: IdentifyData) -> None:
    lib = _library(tmp_path, identify_data)
    with pytest.raises(InputError, match="already holds"):
        lib.add(identify_data.library / "No.3.npz")
    lib.add(identify_data.library / "No.3.npz", "flowers")
    assert load_model(tmp_path / "lib" / "flowers.npz").name == "flowers"
    lib.add(identify_data.library / "No.9.npz", replace=True)
    assert [e.name for e in lib.scan().entries] == ["No.3", "No.5", "No.9", "flowers"]
    with pytest.raises(InputError, match="cannot be a model name"):
        lib.add(identify_data.library / "No.3.npz", "../escape")
    with pytest.raises(InputError, match="no model named"):
        lib.remove("No.99")


def test_corrupt_foreign_and_missing_files_are_skipped(tmp_path: Path,
                                                       identify_data: IdentifyData) -> None:
    lib = _library(tmp_path, identify_data)
    root = tmp_path / "lib"
    (root / "corrupt.npz").write_bytes(
        np.random.default_rng(0).integers(0, 256, 500, dtype=np.uint8).tobytes())
    np.savez(root / "foreign.npz", a=np.arange(3))
    (root / "notes.txt").write_text("not a model")  # any file may be a model: looked at
    save_model(identify_data.models[0], root / "copy_of_No.3.npz")  # a name already taken
    os.unlink(root / "No.9.npz")  # indexed, then deleted behind the library's back
    scan = lib.scan()
    assert [e.name for e in scan.entries] == ["No.3", "No.5"]
    skipped = {s.path.name: s.reason for s in scan.skipped}
    assert set(skipped) == {"corrupt.npz", "foreign.npz", "copy_of_No.3.npz", "No.9.npz",
                            "notes.txt"}
    assert "not a" in skipped["foreign.npz"] and "already taken" in skipped["copy_of_No.3.npz"]
    assert "missing" in skipped["No.9.npz"] and "not a photomodel file" in skipped["notes.txt"]
    models, skipped_load = lib.load()
    assert [m.name for m in models] == ["No.3", "No.5"] and len(skipped_load) == 5


def test_damaged_index_is_ignored_and_rebuilt(tmp_path: Path,
                                              identify_data: IdentifyData) -> None:
    lib = _library(tmp_path, identify_data)
    lib.index_path.write_text("{ torn")
    scan = lib.scan()
    assert [e.name for e in scan.entries] == ["No.3", "No.5", "No.9"]
    assert [s.path.name for s in scan.skipped] == [INDEX_NAME]
    lib.reindex()
    assert lib.scan().skipped == ()


def test_missing_library_and_colours(tmp_path: Path, identify_data: IdentifyData) -> None:
    with pytest.raises(InputError, match="not found"):
        ModelLibrary(tmp_path / "nope")
    red = main_colours(identify_data.models[1])  # No.5: white dots on red
    r, g, b = (int(red[0][0][i:i + 2], 16) for i in (1, 3, 5))
    assert r > 150 and g < 90 and b < 90
    assert sum(share for _, share in red) <= 1.0
