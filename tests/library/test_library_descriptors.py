"""Model descriptors in the library's index (issue 50): every added model is described; an
index of an older photomodel (no descriptors) or with a malformed descriptor is upgraded in
place by ``described()``, nothing else changed, also by two processes at once; a library that
cannot be written is described in memory; ``load_entry`` names the file it cannot read."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import textwrap
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from photomodel.errors import InputError
from photomodel.library import INDEX_NAME, LibraryEntry, LibraryScan, ModelLibrary
from photomodel.model import ModelDescriptor, PhotoModel, describe_model, load_model

NAMES = ("plaid", "plain", "plain-twin")


def _renamed(model: PhotoModel, name: str) -> PhotoModel:
    return PhotoModel(**{**model.__dict__, "name": name})


@pytest.fixture()
def library(tmp_path: Path, plain_case, plaid_case) -> ModelLibrary:  # type: ignore[no-untyped-def]
    """A library of three models (two of them the same garment under two names)."""
    lib = ModelLibrary(tmp_path / "lib", create=True)
    for name, case in zip(NAMES, (plaid_case, plain_case, plain_case), strict=True):
        lib.add_model(_renamed(case.built.model, name))
    return lib


def _index(lib: ModelLibrary) -> dict[str, Any]:
    return json.loads(lib.index_path.read_text())


def _write_index(lib: ModelLibrary, index: dict[str, Any]) -> None:
    lib.index_path.write_text(json.dumps(index, indent=1) + "\n")


def _strip_descriptors(lib: ModelLibrary) -> dict[str, Any]:
    """Make ``lib``'s index one an older photomodel wrote (no ``descriptor`` keys); returns
    it."""
    index = _index(lib)
    for entry in index["models"].values():
        del entry["descriptor"]
    _write_index(lib, index)
    return index


def _same_descriptor(a: ModelDescriptor | None, b: ModelDescriptor | None) -> bool:
    assert a is not None and b is not None
    return (a.to_json_dict() == b.to_json_dict())      # as stored: rounded alike


def _file_descriptor(lib: ModelLibrary, name: str) -> ModelDescriptor:
    return describe_model(load_model(lib.root / f"{name}.npz"))


def _files(lib: ModelLibrary) -> dict[str, tuple[int, int]]:
    return {p.name: (p.stat().st_size, p.stat().st_mtime_ns) for p in lib.root.glob("*.npz")}


@pytest.fixture()
def count_loads(monkeypatch: pytest.MonkeyPatch) -> Iterator[list[Path]]:
    """The model files the library reads, in order."""
    import photomodel.library._library as library_module

    loaded: list[Path] = []
    real = library_module._load_one

    def counting(path: Path) -> PhotoModel:
        loaded.append(Path(path))
        return real(path)

    monkeypatch.setattr(library_module, "_load_one", counting)
    yield loaded


def test_every_added_model_is_described_in_the_index(library: ModelLibrary) -> None:
    index = _index(library)
    assert sorted(index["models"]) == list(NAMES)
    for name, entry in index["models"].items():
        stored = ModelDescriptor.from_json_dict(entry["descriptor"])
        assert _same_descriptor(stored, _file_descriptor(library, name))
    scan = library.scan()
    assert scan.skipped == () and all(e.descriptor is not None for e in scan.entries)
    twins = [e.descriptor for e in scan.entries if e.name.startswith("plain")]
    assert _same_descriptor(*twins)                       # one garment, one descriptor
    assert not _same_descriptor(scan.entries[0].descriptor, twins[0])


def test_an_older_index_is_upgraded_in_place(library: ModelLibrary,
                                             count_loads: list[Path]) -> None:
    old = _strip_descriptors(library)
    files = _files(library)
    scan = library.scan()
    assert [e.name for e in scan.entries] == list(NAMES) and scan.skipped == ()
    assert all(e.descriptor is None for e in scan.entries)
    assert count_loads == []                   # the index still vouches for every file

    described = library.described()
    assert [e.name for e in described.entries] == list(NAMES) and described.skipped == ()
    for before, after in zip(scan.entries, described.entries, strict=True):
        assert _same_descriptor(after.descriptor, _file_descriptor(library, after.name))
        assert after == LibraryEntry(**{**before.__dict__, "descriptor": after.descriptor})
    new = _index(library)
    for name, entry in new["models"].items():  # the same entries, with their descriptors
        assert {k: v for k, v in entry.items() if k != "descriptor"} == old["models"][name]
        assert ModelDescriptor.from_json_dict(entry["descriptor"]) is not None
    assert _files(library) == files            # no model file rewritten
    assert sorted(p.name for p in count_loads) == sorted(f"{n}.npz" for n in NAMES)

    count_loads.clear()                        # upgraded once: no file is read again
    again = library.described()
    assert count_loads == [] and again.skipped == ()
    assert all(_same_descriptor(a.descriptor, b.descriptor)
               for a, b in zip(again.entries, described.entries, strict=True))


def test_a_null_descriptor_is_an_undescribed_entry(library: ModelLibrary) -> None:
    index = _index(library)
    index["models"]["plaid"]["descriptor"] = None
    _write_index(library, index)
    scan = library.scan()
    assert scan.skipped == () and scan.entries[0].descriptor is None
    described = library.described()
    assert described.skipped == ()
    assert _same_descriptor(described.entries[0].descriptor, _file_descriptor(library, "plaid"))


CORRUPTIONS = {
    "bins a text": lambda d: {**d, "colour_bins": "x"},
    "area an integer beyond float": lambda d: {**d, "area_mm2": 10**400},
    "another version": lambda d: {**d, "version": 99},
    "not an object": lambda d: "descriptor",
    "weights summing to 3": lambda d: {**d, "colour_weights": [3 * w for w in
                                                               d["colour_weights"]]},
}


@pytest.mark.parametrize("corruption", list(CORRUPTIONS))
def test_a_corrupt_descriptor_is_noted_and_described_again(library: ModelLibrary,
                                                           corruption: str) -> None:
    index = _index(library)
    good = {n: e["descriptor"] for n, e in index["models"].items()}
    index["models"]["plain"]["descriptor"] = CORRUPTIONS[corruption](good["plain"])
    _write_index(library, index)

    scan = library.scan()                      # the entry is kept, without its descriptor
    assert [e.name for e in scan.entries] == list(NAMES)
    by_name = {e.name: e for e in scan.entries}
    assert by_name["plain"].descriptor is None
    assert by_name["plaid"].descriptor is not None and by_name["plain-twin"].descriptor
    assert len(scan.skipped) == 1, scan.skipped
    note = scan.skipped[0]
    assert note.path == library.index_path
    assert "'plain'" in note.reason and "described again" in note.reason
    assert "\n" not in str(note) and str(note).isprintable()

    described = library.described()
    by_name = {e.name: e for e in described.entries}
    assert list(by_name) == list(NAMES)
    assert _same_descriptor(by_name["plain"].descriptor, _file_descriptor(library, "plain"))
    assert _index(library)["models"]["plain"]["descriptor"] == good["plain"]
    assert library.scan().skipped == ()       # repaired


def _assert_described_in_memory(library: ModelLibrary, described: LibraryScan,
                                before: bytes, listing: list[str]) -> None:
    assert [e.name for e in described.entries] == list(NAMES)
    for e in described.entries:
        assert _same_descriptor(e.descriptor, _file_descriptor(library, e.name))
    assert len(described.skipped) == 1, described.skipped
    note = described.skipped[0]
    assert note.path == library.index_path and "in memory" in note.reason
    assert "\n" not in str(note) and str(note).isprintable()
    assert library.index_path.read_bytes() == before
    assert sorted(p.name for p in library.root.iterdir()) == listing


@pytest.mark.parametrize("lock_file", ["kept", "absent"])
def test_a_read_only_library_is_described_in_memory(library: ModelLibrary,
                                                    lock_file: str) -> None:
    """chmod 0o555 (without the lock file the lock cannot be taken; with it, the index
    cannot be written)."""
    _strip_descriptors(library)
    if lock_file == "absent":
        (library.root / ".index.lock").unlink()
    before = library.index_path.read_bytes()
    listing = sorted(p.name for p in library.root.iterdir())
    library.root.chmod(0o555)
    try:
        if os.access(library.root, os.W_OK):
            pytest.skip("the directory stays writable (running as root)")
        described = library.described()
    finally:
        library.root.chmod(0o755)
    _assert_described_in_memory(library, described, before, listing)


@pytest.mark.parametrize("refused", ["lock", "index"])
def test_a_library_refusing_writes_is_described_in_memory(library: ModelLibrary,
                                                          refused: str,
                                                          monkeypatch: pytest.MonkeyPatch
                                                          ) -> None:
    """The read-only paths as root meets them too: the lock file cannot be opened, or the
    index cannot be replaced (EACCES from the file system)."""
    import photomodel.library._library as library_module

    _strip_descriptors(library)
    before = library.index_path.read_bytes()
    listing = sorted(p.name for p in library.root.iterdir())
    real_open = os.open

    def refusing_open(path: Any, *args: Any, **kwargs: Any) -> int:
        if refused == "lock" and str(path).endswith(".index.lock"):
            raise PermissionError(13, "Permission denied", str(path))
        return real_open(path, *args, **kwargs)

    def refusing_write(self: ModelLibrary, entries: Any) -> None:
        raise PermissionError(13, "Permission denied", str(self.index_path))

    monkeypatch.setattr(library_module.os, "open", refusing_open)
    if refused == "index":
        monkeypatch.setattr(ModelLibrary, "_write_index", refusing_write)
    described = library.described()
    monkeypatch.undo()
    _assert_described_in_memory(library, described, before, listing)


def test_load_entry_names_the_file_it_cannot_read(library: ModelLibrary) -> None:
    entries = {e.name: e for e in library.described().entries}
    assert library.load_entry(entries["plaid"]).name == "plaid"
    gone = library.root / "plaid.npz"
    gone.unlink()
    with pytest.raises(InputError, match="not found") as missing:
        library.load_entry(entries["plaid"])
    assert missing.value.source == str(gone)
    other = library.root / "plain.npz"                 # now holds another model
    shutil.copyfile(library.root / "plain-twin.npz", other)
    with pytest.raises(InputError, match="holds model 'plain-twin', not 'plain'") as renamed:
        library.load_entry(entries["plain"])
    assert renamed.value.source == str(other)
    other.write_bytes(b"PK\x03\x04 not a zip")
    with pytest.raises(InputError) as corrupt:
        library.load_entry(entries["plain"])
    assert corrupt.value.source == str(other) and "\n" not in str(corrupt.value)


_DESCRIBE = textwrap.dedent("""
    import json, sys, time
    from pathlib import Path
    from photomodel.library import ModelLibrary
    root, me = Path(sys.argv[1]), sys.argv[2]
    library = ModelLibrary(root)
    (root.parent / f"ready-{me}").touch()
    while not (root.parent / "go").exists():
        time.sleep(0.002)
    scan = library.described()
    print(json.dumps({"names": [e.name for e in scan.entries],
                      "described": all(e.descriptor is not None for e in scan.entries),
                      "notes": [str(s) for s in scan.skipped]}))
""")


def test_two_processes_upgrading_an_older_index_at_once(library: ModelLibrary) -> None:
    old = _strip_descriptors(library)
    runs = [subprocess.Popen([sys.executable, "-c", _DESCRIBE, str(library.root), str(k)],
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
            for k in range(2)]
    deadline = time.monotonic() + 60.0
    while not all((library.root.parent / f"ready-{k}").exists() for k in range(2)):
        assert time.monotonic() < deadline and all(r.poll() is None for r in runs)
        time.sleep(0.01)
    (library.root.parent / "go").touch()       # both describe the same old index now
    for run in runs:
        out, err = run.communicate(timeout=120)
        assert run.returncode == 0, err
        answer = json.loads(out)
        assert answer == {"names": list(NAMES), "described": True, "notes": []}, answer
    index = _index(library)                    # parses, every entry kept and described
    assert sorted(index["models"]) == list(NAMES)
    for name, entry in index["models"].items():
        assert {k: v for k, v in entry.items() if k != "descriptor"} == old["models"][name]
        assert _same_descriptor(ModelDescriptor.from_json_dict(entry["descriptor"]),
                                _file_descriptor(library, name))
    assert not list(library.root.glob(f".{INDEX_NAME}.tmp-*"))
    assert np.all([p.name in (*[f"{n}.npz" for n in NAMES], INDEX_NAME, ".index.lock")
                   for p in library.root.iterdir()])
