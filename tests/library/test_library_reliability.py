"""A model library survives its worst file, concurrent writers and writers killed mid-write.

Each bad file is skipped with one note whatever is wrong with it (flipped bytes, any version
field, a truncated or empty file, a folder named like a model, a name that would garble a
listing); concurrent ``add``\\ s keep every entry (the read-modify-write of the index holds a
file lock); a writer killed with SIGKILL at a random moment never leaves a corrupt index nor
loses a model it reported as added.
"""

from __future__ import annotations

import json
import os
import random
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from photomodel.errors import InputError
from photomodel.library import INDEX_NAME, ModelLibrary, check_model_name
from photomodel.model import PhotoModel, save_model


@pytest.fixture(scope="module")
def model_file(tmp_path_factory: pytest.TempPathFactory, plain_case) -> Path:  # type: ignore[no-untyped-def]
    path = tmp_path_factory.mktemp("model") / "shirt.npz"
    save_model(plain_case.built.model, path)
    return path


def _renamed(model: PhotoModel, name: str) -> PhotoModel:
    return PhotoModel(**{**model.__dict__, "name": name})


def _with_meta(path: Path, out: Path, **changes: object) -> None:
    """A copy of model file ``path`` whose metadata has ``changes`` (the raw JSON values)."""
    with np.load(path) as data:
        arrays = {k: data[k] for k in data.files}
    meta = json.loads(str(arrays["meta"]))
    text = json.dumps(meta)
    for key, raw in changes.items():
        text = text.replace(f'"{key}": {json.dumps(meta[key])}', f'"{key}": {raw}')
    arrays["meta"] = np.array(text)
    np.savez(out, **arrays)


def test_every_kind_of_bad_file_is_skipped_with_one_note(tmp_path: Path,
                                                         model_file: Path) -> None:
    lib = ModelLibrary(tmp_path / "lib", create=True)
    lib.add(model_file, "good")
    root = lib.root
    raw = model_file.read_bytes()
    bad: list[str] = []
    for k, offset in enumerate((200, 1000, len(raw) // 3, len(raw) // 2, len(raw) - 30)):
        flipped = bytearray(raw)
        flipped[offset] ^= 0xFF
        (root / f"flip{k}.npz").write_bytes(bytes(flipped))
        bad.append(f"flip{k}.npz")
    for k, version in enumerate(('"x"', "null", "1e999", "[1]", "2.5", "-3", "99", '{"a": 1}')):
        _with_meta(model_file, root / f"version{k}.npz", version=version)
        bad.append(f"version{k}.npz")
    _with_meta(model_file, root / "rtl_name.npz", name='"evil\\u202eman"')
    _with_meta(model_file, root / "newline_name.npz", name='"a\\nb"')
    (root / "truncated.npz").write_bytes(raw[: len(raw) // 2])
    (root / "empty.npz").write_bytes(b"")
    (root / "folder.npz").mkdir()
    bad += ["rtl_name.npz", "newline_name.npz", "truncated.npz", "empty.npz"]

    scan = lib.scan()
    assert [e.name for e in scan.entries] == ["good"]
    skipped = [s.path.name for s in scan.skipped]
    assert sorted(skipped) == sorted(bad)          # one note each, the folder is no file
    for note in scan.skipped:
        assert "\n" not in str(note) and str(note).isprintable(), str(note)
    models, skipped_load = lib.load()
    assert [m.name for m in models] == ["good"] and len(skipped_load) == len(bad)
    # the writers work on such a library too
    lib.add(model_file, "second")
    assert lib.remove("good").name == "good"
    assert [e.name for e in lib.reindex().entries] == ["second"]


@pytest.mark.parametrize("name", ["a\nb", "evil\u202eman", "tab\there", " lead", "trail ",
                                  "a/b", ".hidden", "", "x" * 101, "zero\u200bwidth"])
def test_names_that_would_garble_a_listing_are_refused(name: str) -> None:
    with pytest.raises(InputError) as info:
        check_model_name(name, "--name")
    text = str(info.value)
    assert text.startswith("--name: ") and text.isprintable(), text
    assert len(text) < 400


@pytest.mark.parametrize("name", ["No.3", "red shirt", "Hemd-ä", "x" * 100])
def test_printable_names_are_accepted(name: str) -> None:
    assert check_model_name(name) == name


def test_concurrent_writers_in_threads_keep_every_entry(tmp_path: Path,
                                                        model_file: Path) -> None:
    lib_dir = tmp_path / "lib"
    errors: list[BaseException] = []

    def add(k: int) -> None:
        try:
            ModelLibrary(lib_dir, create=True).add(model_file, f"m{k}")
        except BaseException as exc:  # noqa: BLE001
            errors.append(exc)

    threads = [threading.Thread(target=add, args=(k,)) for k in range(8)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert errors == []
    index = json.loads((lib_dir / INDEX_NAME).read_text())
    assert sorted(index["models"]) == sorted(f"m{k}" for k in range(8))
    assert not list(lib_dir.glob(f".{INDEX_NAME}.tmp-*"))


def _add_process(lib: Path, model: Path, name: str) -> subprocess.Popen[str]:
    return subprocess.Popen([sys.executable, "-m", "photomodel", "models", "add", "--models",
                             str(lib), str(model), "--name", name],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def test_concurrent_add_commands_keep_every_entry(tmp_path: Path, model_file: Path) -> None:
    lib = tmp_path / "lib"
    procs = [_add_process(lib, model_file, f"p{k}") for k in range(6)]
    for p in procs:
        out, err = p.communicate(timeout=120)
        assert p.returncode == 0, err
        assert "added" in out
    index = json.loads((lib / INDEX_NAME).read_text())
    assert sorted(index["models"]) == [f"p{k}" for k in range(6)]
    assert ModelLibrary(lib).scan().skipped == ()


def test_killing_add_at_random_moments_never_corrupts_or_loses(tmp_path: Path,
                                                               model_file: Path) -> None:
    """SIGKILL once the library starts changing, 0-30 ms later (inside the write), 6 times."""
    lib = tmp_path / "lib"
    ModelLibrary(lib, create=True).add(model_file, "base")
    rng = random.Random(5)
    reported = {"base"}
    for k in range(6):
        before = {q.name: q.stat().st_mtime_ns for q in lib.iterdir()}
        proc = _add_process(lib, model_file, f"k{k}")
        deadline = time.monotonic() + 60
        while proc.poll() is None and time.monotonic() < deadline:
            now = {q.name: q.stat().st_mtime_ns for q in lib.iterdir() if q.exists()}
            if now != before:
                time.sleep(rng.uniform(0.0, 0.03))
                break
            time.sleep(0.001)
        if proc.poll() is None:
            os.kill(proc.pid, signal.SIGKILL)
        out, _ = proc.communicate(timeout=60)
        if "added" in out:
            reported.add(f"k{k}")
        index = json.loads((lib / INDEX_NAME).read_text())     # never torn
        assert index["format"] == "photomodel-library"
        scan = ModelLibrary(lib).scan()
        assert reported <= set(index["models"])
        assert reported <= {e.name for e in scan.entries}
        assert [s for s in scan.skipped if s.path.name == INDEX_NAME] == []
    # the library stays writable, and the next writer clears the dead ones' temporaries
    for tmp in lib.glob(".*.npz.tmp*"):
        old = time.time() - 120
        os.utime(tmp, (old, old))
    ModelLibrary(lib).add(model_file, "after")
    assert not list(lib.glob(f".{INDEX_NAME}.tmp-*")) and not list(lib.glob(".*.npz.tmp*"))
