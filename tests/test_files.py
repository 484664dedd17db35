"""``photomodel._files``: a whole file replaced at once, lines appended whole."""

from __future__ import annotations

import os
import stat
from pathlib import Path

import pytest

from photomodel._files import append_lines, locked, write_atomic, write_atomic_with


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


def test_write_atomic_with_hands_a_temporary_path_with_the_suffix(tmp_path: Path) -> None:
    """The writer gets a hidden path beside the file that ends in the file's suffix (the
    library picks the format from it); what it wrote replaces the file."""
    path = tmp_path / "stereo.yaml"
    path.write_text("old")
    seen: list[Path] = []

    def write(tmp: Path) -> None:
        seen.append(tmp)
        tmp.write_text("new")

    write_atomic_with(path, write)
    assert path.read_text() == "new"
    assert seen[0].parent == tmp_path and seen[0].name.startswith(".stereo.tmp-")
    assert seen[0].suffix == ".yaml"
    assert _others(tmp_path, "stereo.yaml") == []


def test_write_atomic_with_keeps_the_old_file_when_the_writer_fails(tmp_path: Path) -> None:
    """A writer that fails half-way: its error comes through, the old file is kept and the
    half-written temporary file is removed."""
    path = tmp_path / "plot.png"
    path.write_bytes(b"old")

    def write(tmp: Path) -> None:
        tmp.write_bytes(b"half")
        raise RuntimeError("disk full")

    with pytest.raises(RuntimeError, match="disk full"):
        write_atomic_with(path, write, fsync=False)
    assert path.read_bytes() == b"old"
    assert _others(tmp_path, "plot.png") == []


def test_write_atomic_with_refuses_a_writer_that_wrote_nothing(tmp_path: Path) -> None:
    path = tmp_path / "plot.png"
    path.write_bytes(b"old")
    with pytest.raises(FileNotFoundError, match="nothing was written"):
        write_atomic_with(path, lambda tmp: None)
    assert path.read_bytes() == b"old"
    assert _others(tmp_path, "plot.png") == []


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


@pytest.mark.parametrize("before", [None, b"", b"col_a,co"])
def test_append_lines_writes_the_header_to_a_file_without_a_whole_line(
        tmp_path: Path, before: bytes | None) -> None:
    """New, empty, or holding only a header cut short: the header comes first, once."""
    path = tmp_path / "records.csv"
    if before is not None:
        path.write_bytes(before)
    append_lines(path, [b"1,2"], header=b"col_a,col_b")
    append_lines(path, [b"3,4"], header=b"col_a,col_b")
    assert path.read_bytes() == b"col_a,col_b\n1,2\n3,4\n"


def test_append_lines_keeps_the_header_when_a_row_is_cut_short(tmp_path: Path) -> None:
    path = tmp_path / "records.csv"
    path.write_bytes(b"col_a,col_b\r\n1,2\r\n3,")
    append_lines(path, [b"5,6"], header=b"col_a,col_b")
    assert path.read_bytes() == b"col_a,col_b\r\n1,2\r\n5,6\n"


def test_append_lines_refuses_a_header_with_a_line_break(tmp_path: Path) -> None:
    path = tmp_path / "records.csv"
    with pytest.raises(ValueError, match="line break"):
        append_lines(path, [b"1"], header=b"a\nb")
    assert not path.exists()


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
