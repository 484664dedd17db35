"""A library is the model files in it (issue 47, item 5).

A directory of files written by ``photomodel build --out DIR/NAME.model`` (any file name, no
index) is a library for ``models list``, ``identify`` and ``pm.ModelLibrary``: the models are
named by the names they hold, the index is only a cache that writers keep (a read never
writes it), other files are skipped with a note, two files holding one name are both named in
a note, and a directory without model files says what it looked for.
"""

from __future__ import annotations

import json
import os
import shutil
from pathlib import Path

import numpy as np
import pytest

from photomodel.cli import main
from photomodel.errors import InputError
from photomodel.library import INDEX_NAME, LOOKED_FOR, ModelLibrary
from photomodel.library import _library as library_module
from photomodel.locate import THRESHOLD_FILE
from photomodel.model import PhotoModel, load_model, save_model


def _run(capsys: pytest.CaptureFixture[str], *argv: object) -> tuple[int, str, str]:
    code = main([str(a) for a in argv])
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def _listing(root: Path) -> list[str]:
    return sorted(p.name for p in root.iterdir())


@pytest.fixture(scope="module")
def built(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A simulated dataset of No.3 and No.5, and ``built/``: their models as ``photomodel
    build`` writes them, under file names unlike their names (``shirt.model`` holds
    ``flowers``, ``towel`` (no ending) holds ``dots``), each with its preview picture."""
    root = tmp_path_factory.mktemp("model_files")
    assert main(["simulate", "--out", str(root / "D"), "--garments", "No.3,No.5", "--scenes",
                 "1", "--seed", "3"]) == 0
    out = root / "built"
    for garment, file, name in (("No.3", "shirt.model", "flowers"), ("No.5", "towel", "dots")):
        photos = root / "D" / "models" / garment
        assert main(["build", "--photo", str(photos / "photo.bmp"), "--background",
                     str(photos / "background.bmp"), "--camera",
                     str(root / "D" / "model_camera.yaml"), "--out", str(out / file),
                     "--name", name]) == 0
    return root


@pytest.fixture()
def plain(tmp_path: Path, built: Path) -> Path:
    """A copy of ``built/`` (two model files and their previews, no index), times kept."""
    return Path(shutil.copytree(built / "built", tmp_path / "plain", copy_function=shutil.copy2))


def _renamed(model: PhotoModel, name: str) -> PhotoModel:
    return PhotoModel(**{**model.__dict__, "name": name})


def test_built_files_of_any_name_are_the_library_and_a_read_writes_nothing(
        plain: Path) -> None:
    before = _listing(plain)
    assert before == ["shirt.model", "shirt.preview.png", "towel", "towel.preview.png"]
    lib = ModelLibrary(plain)
    scan = lib.scan()
    assert [(e.name, e.file) for e in scan.entries] == [("dots", "towel"),
                                                        ("flowers", "shirt.model")]
    assert scan.skipped == ()                      # previews are build's, not looked at
    described = lib.described()
    assert all(e.descriptor is not None for e in described.entries)  # described in memory
    models, skipped = lib.load()
    assert [m.name for m in models] == ["dots", "flowers"] and skipped == []
    assert lib.load_entry(lib.entry("flowers")).name == "flowers"
    # un-indexed: "added" is when the file was written, the same on every read
    mtime = (plain / "towel").stat().st_mtime
    assert lib.entry("dots").added_utc == library_module._utc(mtime)
    assert _listing(plain) == before               # no index, no lock file: reads write nothing


def test_other_files_are_skipped_with_a_note_and_own_files_are_not_looked_at(
        plain: Path, built: Path) -> None:
    (plain / "README.md").write_text("the catalogue of line 3\n")
    shutil.copyfile(built / "D" / "models" / "No.3" / "photo.bmp", plain / "photo.bmp")
    (plain / "empty").write_bytes(b"")
    (plain / THRESHOLD_FILE).write_text("{}")
    (plain / "old").mkdir()                        # a sub-folder: not looked at
    save_model(load_model(plain / "towel"), plain / "old" / "hidden.npz")
    (plain / ".notes.model").write_text("hidden")  # a hidden file: not looked at
    scan = ModelLibrary(plain).scan()
    assert [e.name for e in scan.entries] == ["dots", "flowers"]
    notes = {s.path.name: str(s) for s in scan.skipped}
    assert sorted(notes) == ["README.md", "empty", "photo.bmp"]
    for name, note in notes.items():
        assert note.startswith(f"{plain / name}: skipped: ") and "\n" not in note
        assert "not a photomodel file" in note or "empty" in note, note


def test_two_files_of_one_name_are_both_named(plain: Path) -> None:
    save_model(load_model(plain / "shirt.model"), plain / "another_copy.npz")
    lib = ModelLibrary(plain)
    scan = lib.scan()
    assert [(e.name, e.file) for e in scan.entries] == [("dots", "towel"),
                                                        ("flowers", "another_copy.npz")]
    (note,) = scan.skipped
    assert note.path == plain / "shirt.model"
    assert "'flowers' is already taken by another_copy.npz" in str(note)
    # the file the index lists under the name is the one used, whatever the file names
    lib.reindex()
    index = json.loads(lib.index_path.read_text())
    assert index["models"]["flowers"]["file"] == "another_copy.npz"
    index["models"]["flowers"] = {**index["models"]["flowers"], "file": "shirt.model"}
    st = (plain / "shirt.model").stat()
    index["models"]["flowers"].update(file_bytes=st.st_size, file_mtime_ns=st.st_mtime_ns)
    lib.index_path.write_text(json.dumps(index))
    scan = lib.scan()
    assert {e.name: e.file for e in scan.entries}["flowers"] == "shirt.model"
    assert [s.path.name for s in scan.skipped] == ["another_copy.npz"]


def test_writers_index_the_files_and_a_scan_then_trusts_the_index(
        plain: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    lib = ModelLibrary(plain)
    scan = lib.reindex()
    assert [e.file for e in scan.entries] == ["towel", "shirt.model"]
    index = json.loads((plain / INDEX_NAME).read_text())
    assert {n: e["file"] for n, e in index["models"].items()} == {
        "dots": "towel", "flowers": "shirt.model"}
    assert all("descriptor" in e for e in index["models"].values())

    def no_reads(path: Path) -> PhotoModel:
        raise AssertionError(f"{path} was opened")

    monkeypatch.setattr(library_module, "_load_one", no_reads)
    cached = lib.scan()                            # unchanged files: from the index
    assert [(e.name, e.file, e.added_utc) for e in cached.entries] == [
        (e.name, e.file, e.added_utc) for e in scan.entries]
    assert all(e.descriptor is not None for e in cached.entries) and cached.skipped == ()
    monkeypatch.undo()
    (plain / "towel").unlink()                     # deleted behind the library's back
    scan = lib.scan()
    assert [e.name for e in scan.entries] == ["flowers"]
    assert "listed in index.json as 'dots' but the file is missing" in str(scan.skipped[0])


def test_add_and_remove_in_a_directory_of_built_files(plain: Path) -> None:
    lib = ModelLibrary(plain)
    with pytest.raises(InputError, match="already holds a model named 'flowers'"):
        lib.add(plain / "shirt.model")
    entry = lib.add(plain / "shirt.model", "flowers-2")     # models add, as it always was
    assert entry.file == "flowers-2.npz"
    index = json.loads(lib.index_path.read_text())
    assert sorted(index["models"]) == ["dots", "flowers", "flowers-2"]
    assert index["models"]["flowers"]["file"] == "shirt.model"
    lib.add(plain / "towel", "flowers", replace=True)        # replaced: its old file goes
    assert not (plain / "shirt.model").exists()
    assert load_model(plain / "flowers.npz").name == "flowers"
    lib.remove("dots")
    assert not (plain / "towel").exists()
    assert [e.name for e in lib.scan().entries] == ["flowers", "flowers-2"]


def test_add_refuses_a_file_name_that_another_model_holds(plain: Path) -> None:
    lib = ModelLibrary(plain)
    save_model(_renamed(load_model(plain / "towel"), "stripes"), plain / "shirt.npz")
    with pytest.raises(InputError, match="holds the library's model 'stripes'"):
        lib.add_model(_renamed(load_model(plain / "towel"), "shirt"))
    assert load_model(plain / "shirt.npz").name == "stripes"


def test_leftover_model_temporaries_are_removed_by_the_next_writer(plain: Path) -> None:
    for name in (".shirt.model.tmp", ".towel.npz.tmp", ".towel.npz.tmp-12-34", ".keep.tmp"):
        (plain / name).write_bytes(b"PK")
        os.utime(plain / name, (1e9, 1e9))
    ModelLibrary(plain).reindex()
    assert [n for n in _listing(plain) if n.endswith(".tmp")] == [".keep.tmp"]


def test_the_library_files_threshold_name_is_the_threshold_file() -> None:
    assert THRESHOLD_FILE in library_module._OWN_FILES


# --- the command line ----------------------------------------------------------------------


def test_models_list_and_reindex_on_built_files(capsys: pytest.CaptureFixture[str],
                                                plain: Path) -> None:
    (plain / "README.md").write_text("line 3\n")
    code, out, err = _run(capsys, "models", "list", "--models", plain)
    assert code == 0
    assert [line.split()[0] for line in out.splitlines()] == ["dots", "flowers", "2"]
    assert err == f"photomodel: warning: {plain / 'README.md'}: skipped: not a photomodel file " \
                  "(not a zip archive, or cut short)\n"
    code, out, err = _run(capsys, "models", "list", "--models", plain, "--json")
    doc = json.loads(out)
    assert [(m["name"], m["file"]) for m in doc["models"]] == [("dots", "towel"),
                                                               ("flowers", "shirt.model")]
    assert [Path(s["file"]).name for s in doc["skipped"]] == ["README.md"]
    assert not (plain / INDEX_NAME).exists()
    code, out, err = _run(capsys, "models", "show", "--models", plain, "flowers")
    assert code == 0 and f"file        {plain / 'shirt.model'}" in out
    code, out, err = _run(capsys, "models", "reindex", "--models", plain)
    assert code == 0 and out == f"indexed 2 model(s) in {plain}/index.json\n"
    assert "README.md" in err
    assert sorted(json.loads((plain / INDEX_NAME).read_text())["models"]) == ["dots", "flowers"]


def test_identify_on_a_directory_of_built_files(capsys: pytest.CaptureFixture[str],
                                                plain: Path, built: Path) -> None:
    scene = built / "D" / "scenes" / "paper_No.5_0000"
    before = _listing(plain)
    code, out, err = _run(capsys, "identify", "--models", plain, "--stereo",
                          built / "D" / "stereo.yaml", "--right", scene / "right.png",
                          "--left", scene / "left.png", "--json", "--max-candidates", "1")
    assert code == 0 and err == "", err
    doc = json.loads(out)
    assert doc["model"] == "dots" and doc["found"] is True   # No.5, the name it was built as
    truth = json.loads((built / "D" / "truth.json").read_text())["paper_No.5_0000"]
    error_mm = np.asarray(doc["position_mm"]) - np.asarray(truth["T_cam1_model"])[:3, 3]
    assert np.linalg.norm(error_mm) < 10.0
    assert _listing(plain) == before               # identify read the files, wrote nothing


@pytest.mark.parametrize("junk", [(), ("README.md",)])
def test_a_directory_without_model_files_says_what_it_looked_for(
        capsys: pytest.CaptureFixture[str], tmp_path: Path, built: Path,
        junk: tuple[str, ...]) -> None:
    folder = tmp_path / "photos"
    folder.mkdir()
    for name in junk:
        (folder / name).write_text("notes\n")
    code, out, err = _run(capsys, "models", "list", "--models", folder)
    assert code == 0 and out == f"{folder}: no models (looked for {LOOKED_FOR})\n"
    scene = built / "D" / "scenes" / "paper_No.5_0000"
    code, out, err = _run(capsys, "identify", "--models", folder, "--stereo",
                          built / "D" / "stereo.yaml", "--right", scene / "right.png",
                          "--left", scene / "left.png")
    assert code == 2 and out == ""
    lines = err.splitlines()
    assert len(lines) == 1 + len(junk) and all("skipped" in line for line in lines[:-1])
    assert lines[-1] == (f"photomodel: error: {folder}: the library holds no usable "
                         f"photo-model (it looked for {LOOKED_FOR})")
    assert _listing(folder) == sorted(junk)
