"""``photomodel._files``: a whole file replaced at once, lines appended whole."""

from __future__ import annotations

import os
import stat
from pathlib import Path

import pytest

from photomodel._files import append_lines, locked, write_atomic


def _others(folder: Path, *keep: str) -> list[str]:
    return sorted(p.name for p in folder.iterdir() if p.name not in keep)


def test_write_atomic_replaces_the_file_and_leaves_no_temporary_file(tmp_path: Path) -> None:
    path = tmp_path / "state.json"
    write_atomic(path, b"old")
    write_atomic(path, b"new and longer", fsync=False)
    assert path.read_bytes() == b"new and longer"
    assert _others(tmp_path, "state.json") == []


def test_write_atomic_keeps_the_old_file_when_the_write_fails(tmp_path: Path) -> None:
    """A directory in the way of the rename: the error comes through, the directory and the
    folder are as they were, no temporary file is left."""
    target = tmp_path / "taken"
    target.mkdir()
    (target / "inside.txt").write_text("kept")
    with pytest.raises(OSError):
        write_atomic(target, b"data")
    assert target.is_dir() and (target / "inside.txt").read_text() == "kept"
    assert _others(tmp_path, "taken") == []


def test_write_atomic_keeps_the_old_file_when_the_folder_is_missing(tmp_path: Path) -> None:
    path = tmp_path / "kept.txt"
    path.write_bytes(b"precious")
    with pytest.raises(OSError):
        write_atomic(tmp_path / "missing" / "kept.txt", b"x")
    assert path.read_bytes() == b"precious"
    assert _others(tmp_path, "kept.txt") == []


@pytest.mark.parametrize("mode", [0o600, 0o644])
def test_write_atomic_honours_the_mode(tmp_path: Path, mode: int) -> None:
    path = tmp_path / "key.pem"
    old = os.umask(0o022)
    try:
        write_atomic(path, b"secret", mode=mode)
    finally:
        os.umask(old)
    assert stat.S_IMODE(path.stat().st_mode) == mode


def test_write_atomic_gives_a_replaced_private_file_its_mode(tmp_path: Path) -> None:
    """Replacing a world-readable file with a key: the key is not world-readable."""
    path = tmp_path / "key.pem"
    path.write_bytes(b"public")
    path.chmod(0o644)
    write_atomic(path, b"secret", mode=0o600)
    assert stat.S_IMODE(path.stat().st_mode) == 0o600


def test_append_lines_appends_whole_lines_in_order(tmp_path: Path) -> None:
    path = tmp_path / "log.jsonl"
    append_lines(path, [b"one", b"two"], fsync=False)
    append_lines(path, [b"three"])
    assert path.read_bytes() == b"one\ntwo\nthree\n"


@pytest.mark.parametrize("line", [b"a\nb", b"a\rb", b"\n"])
def test_append_lines_refuses_a_line_with_a_line_break(tmp_path: Path, line: bytes) -> None:
    path = tmp_path / "log.jsonl"
    append_lines(path, [b"kept"])
    with pytest.raises(ValueError, match="line break"):
        append_lines(path, [b"fine", line])
    assert path.read_bytes() == b"kept\n"           # nothing of the refused batch


def test_append_lines_drops_a_torn_last_line_and_keeps_the_rest(tmp_path: Path) -> None:
    path = tmp_path / "log.jsonl"
    path.write_bytes(b"first\nsecond\n{\"half\": ")
    append_lines(path, [b"third"])
    assert path.read_bytes() == b"first\nsecond\nthird\n"


def test_append_lines_drops_a_file_that_is_all_torn_line(tmp_path: Path) -> None:
    path = tmp_path / "log.jsonl"
    path.write_bytes(b"no line break at all")
    append_lines(path, [b"whole"])
    assert path.read_bytes() == b"whole\n"


def test_append_lines_creates_a_file_with_its_mode(tmp_path: Path) -> None:
    path = tmp_path / "new.jsonl"
    old = os.umask(0o022)
    try:
        append_lines(path, [b"x"], mode=0o640)
    finally:
        os.umask(old)
    assert stat.S_IMODE(path.stat().st_mode) == 0o640


def test_locked_creates_the_lock_file_and_can_be_taken_again(tmp_path: Path) -> None:
    lock = tmp_path / ".lock"
    with locked(lock):
        assert lock.exists()
    with locked(lock):                       # released at the end of the block
        pass
