"""``Identifier`` over a directory library (issue 50): it opens from the index without reading
a model file, prepares a model when it is first needed, follows the library after
``reload()``; ``photomodel identify`` on a folder without models says so in one line."""

from __future__ import annotations

import json
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
from identify_helpers import IdentifyData

from photomodel.cli import main
from photomodel.identify import Identifier
from photomodel.library import ModelLibrary
from photomodel.model import PhotoModel


def _renamed(model: PhotoModel, name: str) -> PhotoModel:
    return PhotoModel(**{**model.__dict__, "name": name})


@pytest.fixture()
def library(tmp_path: Path, identify_data: IdentifyData) -> ModelLibrary:
    """No.3, No.5 and No.9 added to a new library (its index holds their descriptors)."""
    lib = ModelLibrary(tmp_path / "lib", create=True)
    for m in identify_data.models:
        lib.add_model(m)
    return lib


@pytest.fixture()
def model_reads(monkeypatch: pytest.MonkeyPatch) -> Iterator[list[str]]:
    """The names of the model files read from now on, by the library's loader or by
    ``load_model`` under any name it is imported as."""
    import photomodel.library._library as library_module
    import photomodel.model as model_package
    import photomodel.model._photomodel as model_module

    reads: list[str] = []
    real = model_module.load_model

    def load_model(path, *args, **kwargs):  # type: ignore[no-untyped-def]
        reads.append(Path(path).name)
        return real(path, *args, **kwargs)

    for module in (library_module, model_module, model_package):
        monkeypatch.setattr(module, "load_model", load_model)
    yield reads


def test_an_identifier_opens_from_the_index_and_prepares_on_first_use(
        library: ModelLibrary, identify_data: IdentifyData, model_reads: list[str]) -> None:
    identifier = Identifier(library, identify_data.rig, prepared_models=1)
    assert sorted(identifier.names) == ["No.3", "No.5", "No.9"] and len(identifier) == 3
    assert model_reads == []                      # the index vouched for every file
    assert identifier.stats().prepared == 0 and identifier.stats().capacity == 1
    locator = identifier.locator("No.5")
    assert locator.model.name == "No.5" and model_reads[0] == "No.5.npz"
    assert identifier.locator("No.5") is locator and model_reads.count("No.5.npz") == 1
    identifier.locator("No.3")                    # one prepared at most: No.5 goes
    stats = identifier.stats()
    assert (stats.prepared, stats.misses, stats.hits, stats.evicted) == (1, 2, 1, 1)
    with pytest.raises(KeyError):
        identifier.locator("No.99")


def test_an_older_index_is_upgraded_once(library: ModelLibrary, identify_data: IdentifyData,
                                        model_reads: list[str]) -> None:
    """An index without descriptors (an older photomodel's): the first Identifier describes
    each model from its file and writes them into the index; the next reads no file."""
    index = json.loads(library.index_path.read_text())
    for entry in index["models"].values():
        del entry["descriptor"]
    library.index_path.write_text(json.dumps(index))
    first = Identifier(library, identify_data.rig)
    assert sorted(model_reads) == ["No.3.npz", "No.5.npz", "No.9.npz"]
    assert all("descriptor" in e
               for e in json.loads(library.index_path.read_text())["models"].values())
    model_reads.clear()
    second = Identifier(library, identify_data.rig)
    assert model_reads == [] and second.names == first.names


def test_reload_follows_additions_removals_and_replacements(
        library: ModelLibrary, identify_data: IdentifyData, model_reads: list[str]) -> None:
    no3, no5, no9 = identify_data.models
    identifier = Identifier(library, identify_data.rig)
    kept = identifier.locator("No.3")
    replaced = identifier.locator("No.5")
    library.remove("No.9")
    library.add_model(_renamed(no3, "No.3-twin"))
    library.add_model(_renamed(no9, "No.5"), replace=True)   # another garment as No.5
    assert sorted(identifier.names) == ["No.3", "No.5", "No.9"]   # until reloaded
    model_reads.clear()

    identifier.reload()
    assert sorted(identifier.names) == ["No.3", "No.3-twin", "No.5"] and len(identifier) == 3
    assert model_reads == []                      # the index is read, not the files
    assert identifier.prepared.peek("No.3") is kept           # unchanged: still prepared
    assert identifier.prepared.peek("No.5") is None           # its file changed: dropped
    renewed = identifier.locator("No.5")
    assert renewed is not replaced and model_reads == ["No.5.npz"]
    np.testing.assert_array_equal(renewed.model.photo_bgr, no9.photo_bgr)
    assert identifier.locator("No.3-twin").model.name == "No.3-twin"
    with pytest.raises(KeyError):
        identifier.locator("No.9")


def test_reload_of_models_in_memory_is_refused(identify_data: IdentifyData) -> None:
    identifier = Identifier(list(identify_data.models), identify_data.rig)
    assert sorted(identifier.names) == ["No.3", "No.5", "No.9"]
    with pytest.raises(ValueError, match="reload"):
        identifier.reload()


def test_identify_on_a_folder_without_models_is_one_error_line(
        capsys: pytest.CaptureFixture[str], identify_data: IdentifyData,
        tmp_path: Path) -> None:
    empty = tmp_path / "no_models_here"
    empty.mkdir()
    code = main(["identify", "--models", str(empty), "--stereo", str(identify_data.stereo),
                 "--right", str(identify_data.right), "--left", str(identify_data.left)])
    captured = capsys.readouterr()
    assert code == 2 and captured.out == ""
    lines = captured.err.splitlines()
    assert len(lines) == 1, captured.err
    assert lines[0].startswith(f"photomodel: error: {empty}: ") and "no usable" in lines[0]
    assert list(empty.iterdir()) == []            # nothing written into it
